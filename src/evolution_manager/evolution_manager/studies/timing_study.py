"""``timing-study``: what free-running timing does to evolved trees, against the lockstep.

    ws/run evolution_manager timing-study --force --out docs/results/timing [--trials 6] [--foraging-trials 3]
    ws/run evolution_manager timing-study --table-only --force --out docs/results/timing

For each task it runs the committed best trees through the full node graph twice, on the same trials: in
lockstep (every step waits for every controller: bit-exact with ``evaluate``) and free-running (``trial
--timing free``: the simulator steps at ``--rate`` times real time, the controllers tick on their own
timers in simulated time against the latest sensing). The trees (``TREES``):

- ``primitives``: the best go-to-food tree (objective ``food``) of the paper experiment's ten QD_food runs
  (``experiments/paper/runs/QD_food/*/summary.json``, the highest ``best_fitness``);
- ``foraging``: the foraging study's best heterogeneous swarm (``docs/results/foraging/best_swarm/swarm.json``
  over the ``qd8`` library), objective ``foraging``.

The trials are the first of their chains (0, 5, 10, ...: one trial's steps per goal, both arena
configurations in turn) of seed ``--seed``. Writes ``trials.csv`` (one row per trial and timing: fitness,
wall seconds, nominal seconds) and ``README.md``: per task the mean fitness in each timing and the mean
paired difference (free minus lockstep) with a 95 % percentile bootstrap interval (10,000 resamples of the
pairs, a ``numpy.random.Generator`` seeded with ``--ci-seed`` passed explicitly:
``studies.intervals``), the machine's load while it ran, and the command that made it. ``--table-only``
remakes ``README.md`` from ``trials.csv``. An output that exists is overwritten only with ``--force``; a
link at one is refused.
"""

from __future__ import annotations

import csv
import glob
import json
import os
import sys
import time
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from evolution_manager.arguments import (
    EXIT_IO,
    EXIT_USAGE,
    Parser,
    non_negative_int,
    positive_int,
    rate_argument,
)
from evolution_manager.errors import GraphError, TrialFailedError, UsageError
from evolution_manager.studies.intervals import RESAMPLES, interval
from swarm_ros.safe_paths import UnsafePathError, check_folder, check_output, make_folder, replace_file
from swarm_sim.model import VALUE_NAMES, SwarmLayout
from swarm_sim.tasks import resolve_task

FIELDS = ("task", "objective", "seed", "trial", "timing", "rate", "fitness", "wall_s", "nominal_s")
"""The columns of ``trials.csv``."""
CI_SEED = 40
"""The default seed of the bootstrap's generator."""
OUT = "docs/results/timing"
"""Where the committed study lives."""


@dataclass(frozen=True)
class StudyTree:
    """A committed tree (or swarm) and where it came from."""

    task: str
    objective: str
    source: str
    trees: tuple[str, ...]
    library: Path | None


def best_food_tree(root: Path) -> StudyTree:
    """The best go-to-food tree of the paper experiment's QD_food runs (highest ``best_fitness``)."""
    best: tuple[float, str, str] | None = None
    for path in sorted(glob.glob(str(root / "experiments/paper/runs/QD_food/*/summary.json"))):
        food = json.loads(Path(path).read_text())["objectives"]["food"]
        if best is None or food["best_fitness"] > best[0]:
            best = (food["best_fitness"], food["best_tree_simplified"], str(Path(path).relative_to(root)))
    if best is None:
        raise UsageError(f"no experiments/paper/runs/QD_food/*/summary.json under {root}")
    return StudyTree("primitives", "food", best[2], (best[1],), None)


def best_forager_swarm(root: Path) -> StudyTree:
    """The foraging study's best heterogeneous swarm and its library."""
    path = root / "docs/results/foraging/best_swarm/swarm.json"
    try:
        trees = tuple(json.loads(path.read_text())["trees"])
    except (OSError, ValueError, KeyError) as error:
        raise UsageError(f"cannot read the swarm {path}: {error}") from None
    library = root / "experiments/foraging/libraries/qd8.json"
    return StudyTree("foraging", "foraging", str(path.relative_to(root)), trees, library)


def study_trials(task: str, count: int) -> list[int]:
    """``count`` trials, each the first of its chain, under the task's paper timeline."""
    chain = resolve_task(task).config("paper").chain_length
    return [k * chain for k in range(count)]


def run_timing(tree: StudyTree, timing: str, rate: float, seed: int, trials: Sequence[int]) -> list[dict]:
    """Every trial of ``trials`` of ``seed`` through one graph of ``timing``; one row per trial."""
    from evolution_manager.graph.nodes.trial import TrialGraph  # rclpy: only when trials run

    task = resolve_task(tree.task)
    config = task.config("paper")
    nominal = config.timeline.ticks * config.timeline.steps_per_tick * config.step_dt
    layout = SwarmLayout(tree.trees) if len(tree.trees) > 1 else tree.trees[0]
    rows = []
    with TrialGraph(task=task, library=tree.library, timing=timing, rate=rate, timeout=300.0) as graph:
        for trial in trials:
            started = time.monotonic()
            record = graph.run(layout, seed, trial)
            wall = time.monotonic() - started
            fitness = dict(zip(VALUE_NAMES, record.values, strict=True))[tree.objective]
            rows.append(
                {
                    "task": tree.task,
                    "objective": tree.objective,
                    "seed": seed,
                    "trial": trial,
                    "timing": timing,
                    "rate": rate if timing == "free" else "",
                    "fitness": repr(float(fitness)),
                    "wall_s": f"{wall:.1f}",
                    "nominal_s": f"{nominal / (rate if timing == 'free' else 1.0):.1f}",
                }
            )
            shown = f"{tree.task} {timing} trial {trial}: {fitness:.4f} in {wall:.1f} s"
            print(f"timing-study: {shown}", flush=True)
    return rows


def table(rows: Sequence[dict], ci_seed: int) -> list[dict]:
    """Per task: n, mean fitness in each timing, the mean paired difference (free - lockstep) and its 95 %
    percentile bootstrap interval (generator seeded with ``ci_seed``, one per task in order)."""
    out = []
    rng = np.random.default_rng(ci_seed)
    for task in dict.fromkeys(r["task"] for r in rows):
        of_task = [r for r in rows if r["task"] == task]
        by = {
            timing: {int(r["trial"]): float(r["fitness"]) for r in of_task if r["timing"] == timing}
            for timing in ("lockstep", "free")
        }
        paired = sorted(set(by["lockstep"]) & set(by["free"]))
        differences = [by["free"][t] - by["lockstep"][t] for t in paired]
        ci = interval(differences, "mean", rng)
        free_rows = [r for r in of_task if r["timing"] == "free"]
        late = [float(r["wall_s"]) / float(r["nominal_s"]) for r in free_rows]
        out.append(
            {
                "task": task,
                "objective": of_task[0]["objective"],
                "n": len(paired),
                "lockstep": float(np.mean([by["lockstep"][t] for t in paired])) if paired else float("nan"),
                "free": float(np.mean([by["free"][t] for t in paired])) if paired else float("nan"),
                "difference": float(np.mean(differences)) if paired else float("nan"),
                "ci": ci,
                "rate": free_rows[0]["rate"] if free_rows else "",
                "wall_ratio": max(late) if late else float("nan"),
            }
        )
    return out


def markdown(rows: Sequence[dict], trees: Sequence[StudyTree], ci_seed: int, notes: dict, root: Path) -> str:
    """The README of the study: the table, how it was made, and what it means."""
    header = (
        "| task | objective | n | lockstep mean | free mean | free - lockstep | 95 % CI | rate "
        "| slowest free trial |"
    )
    lines = [
        "# Timing: free-running against lockstep",
        "",
        "The committed best trees through the full node graph (simulator and nine controller processes),",
        "each trial run twice: in **lockstep** (each step waits for every controller: the graph is bit-exact",
        "with `evaluate`) and **free-running** (`trial --timing free`: the simulator steps on its own clock,",
        "the controllers tick their trees at 2 Hz on their own timers in simulated time against the latest",
        "sensing, `docs/ros.md`). Same seed, same trials (the first of each chain), so the differences are",
        "paired.",
        "",
        header,
        "|---|---|---|---|---|---|---|---|---|",
    ]
    for row in table(rows, ci_seed):
        ci = row["ci"]
        shown = f"[{ci[0]:+.4f}, {ci[1]:+.4f}]" if ci is not None else "n/a (n < 2)"
        lines.append(
            f"| {row['task']} | {row['objective']} | {row['n']} | {row['lockstep']:.4f} | {row['free']:.4f} "
            f"| {row['difference']:+.4f} | {shown} | {row['rate']} x real time | {row['wall_ratio']:.2f} |"
        )
    lines += [
        "",
        "The interval is a percentile bootstrap of the mean paired difference",
        f"({RESAMPLES:,} resamples of the pairs; `numpy.random.default_rng({ci_seed})` passed to",
        "`evolution_manager.studies.intervals`, one draw per task in the table's order). Every trial is in",
        "`trials.csv`. The last column is the slowest free trial's wall time over its nominal time: above 1,",
        "steps were published late (the machine did not keep the rate), and that trial measures the machine",
        "as well as the timing.",
        "",
        "What differs, free: each controller ticks when its 2 Hz timer fires (at a phase the model does not",
        "fix) rather than at the model's tick steps; it senses every step whose two readings it received,",
        "its answers (motors, broadcast estimates, smoothed values) are published at its ticks, and the",
        "simulator moves each robot with the latest answer it has. A difference measures these together.",
    ]
    small = [row["task"] for row in table(rows, ci_seed) if row["n"] < 10]
    if small:
        lines += [
            "",
            f"Few trials ({', '.join(small)}: n < 10): a percentile bootstrap of so few pairs is rough",
            "(three pairs give at most ten distinct resampled means); read such a row as a direction, not an",
            "estimate.",
        ]
    lines += [
        "",
        "Trees:",
        "",
    ]
    for tree in trees:
        what = tree.trees[0] if len(tree.trees) == 1 else f"{len(tree.trees)} trees, one per robot"
        library = f", library `{tree.library.relative_to(root)}`" if tree.library is not None else ""
        lines.append(f"- {tree.task} (`{tree.objective}`): `{what}` from `{tree.source}`{library}")
    lines += [
        "",
        "Made with:",
        "",
        "```bash",
        f"ws/run evolution_manager timing-study --force --out {OUT} {notes.get('arguments', '')}",
        f"ws/run evolution_manager timing-study --table-only --force --out {OUT}   # the table again",
        "```",
        "",
        f"Machine: {notes.get('machine', 'not recorded')}",
        "",
    ]
    return "\n".join(lines)


def write_rows(path: Path, rows: Sequence[dict]) -> None:
    """``trials.csv``, written whole (a link at it refused)."""

    def write(temporary: Path) -> None:
        with temporary.open("w", newline="") as handle:
            writer = csv.DictWriter(handle, fieldnames=FIELDS, lineterminator="\n")
            writer.writeheader()
            writer.writerows(rows)

    replace_file(path, write)


def read_rows(path: Path) -> list[dict]:
    try:
        with path.open(newline="") as handle:
            rows = list(csv.DictReader(handle))
    except OSError as error:
        raise UsageError(f"cannot read {path}: {error.strerror or error}") from None
    if not rows or set(rows[0]) != set(FIELDS):
        raise UsageError(f"{path}: expected the columns {', '.join(FIELDS)}")
    return rows


def load_average() -> str:
    """The 1, 5 and 15 minute load averages and the CPU count, as ``uptime`` gives them."""
    one, five, fifteen = os.getloadavg()
    return f"load average {one:.2f}, {five:.2f}, {fifteen:.2f} on {os.cpu_count()} CPUs"


def study(argv: Sequence[str] | None = None) -> int:
    """Run ``timing-study``; return the exit status."""
    parser = Parser(prog="timing-study", description=__doc__.split("\n")[0])
    parser.add_argument("--out", type=Path, required=True, help="folder for trials.csv and README.md")
    parser.add_argument("--trials", type=positive_int, default=6, help="primitives trials (default 6)")
    parser.add_argument(
        "--foraging-trials", type=non_negative_int, default=3, help="foraging trials (default 3; 100 s each)"
    )
    parser.add_argument(
        "--rate", type=rate_argument, default=1.0, help="free timing's rate (default 1.0: real time)"
    )
    parser.add_argument("--seed", type=non_negative_int, default=1, help="the trials' seed (default 1)")
    parser.add_argument("--ci-seed", type=non_negative_int, default=CI_SEED, help="the bootstrap's seed")
    parser.add_argument("--table-only", action="store_true", help="remake README.md from trials.csv")
    parser.add_argument("--force", action="store_true", help="overwrite the outputs that exist")
    parser.add_argument(
        "--repo", type=Path, default=Path("."), help="the repository holding the experiments (default: here)"
    )
    try:
        args = parser.parse_args(sys.argv[1:] if argv is None else argv)
        root = args.repo.resolve()
        trees = [best_food_tree(root), best_forager_swarm(root)]
        csv_path, readme = args.out / "trials.csv", args.out / "README.md"
        notes_path = args.out / "machine.json"
        check_folder(args.out, "--out")
        for output in [readme] if args.table_only else [csv_path, readme, notes_path]:
            check_output(output, args.force, "--out")
        if args.table_only:
            rows = read_rows(csv_path)
            notes = json.loads(notes_path.read_text()) if notes_path.is_file() else {}
        else:
            make_folder(args.out)
            before = load_average()
            rows = []
            for tree, count in ((trees[0], args.trials), (trees[1], args.foraging_trials)):
                chosen = study_trials(tree.task, count)
                if not chosen:
                    continue
                for timing in ("lockstep", "free"):
                    rows += run_timing(tree, timing, args.rate, args.seed, chosen)
                    write_rows(csv_path, rows)
            arguments = (
                f"--trials {args.trials} --foraging-trials {args.foraging_trials} --rate {args.rate} "
                f"--seed {args.seed} --ci-seed {args.ci_seed}"
            )
            notes = {
                "arguments": arguments,
                "machine": f"{before} before the study, {load_average()} after it (other work running); "
                f"finished {time.strftime('%Y-%m-%d %H:%M UTC', time.gmtime())}",
            }
            text = json.dumps(notes, indent=1) + "\n"
            replace_file(notes_path, lambda temporary: temporary.write_text(text))
        page = markdown(rows, trees, args.ci_seed, notes, root)
        replace_file(readme, lambda temporary: temporary.write_text(page))
    except UsageError as error:
        print(f"timing-study: {error}", file=sys.stderr)
        return EXIT_USAGE
    except UnsafePathError as error:
        print(f"timing-study: {error}", file=sys.stderr)
        return EXIT_USAGE
    except (GraphError, TrialFailedError) as error:
        print(f"timing-study: {error}", file=sys.stderr)
        return 1
    except OSError as error:
        print(f"timing-study: {error}", file=sys.stderr)
        return EXIT_IO
    print(f"timing-study: wrote {readme}", file=sys.stderr)
    return 0


def main() -> None:
    """Console entry point of ``timing-study``."""
    sys.exit(study())
