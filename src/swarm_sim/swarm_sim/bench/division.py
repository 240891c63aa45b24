"""``ws/run swarm_sim division-bench``: does a division of labour pay on ``multifood-arena6-balanced``?

    division-bench [--seeds 20] [--trials 10] [--task NAME|FILE] [--threads K] [--out CSV] [--estimates]

Hand-written controllers, no evolution (issue 36's first, cheap evidence): every swarm of :func:`swarms` is
evaluated on seeds 1 to ``--seeds`` with ``--trials`` trials each, on the batch road. The homogeneous swarms
run one tree on every robot: a forager of any kind (it follows the first food kind it has an estimate of,
kind 1 before 2 before 3: the node set has no way to compare two kinds' estimates, so "the nearest kind" is
not expressible); per kind k, a forager of only kind k (it seeks kind k and turns home once it carries kind
k) and one that prefers kind k (it seeks kind k but turns home with any kind); a forager whose ``prob`` node
draws the kind it seeks anew whenever the seeking finishes (every tick or two: the trees have no memory, so a
robot cannot draw a kind once and keep it); and a wanderer that reads no food condition (home with any kind,
else a random walk), the floor that following the food estimates should beat. The heterogeneous swarms split
the robots into as many groups as kinds, robot i in group i mod kinds (3 + 3 + 3 of nine: the groups of a
team and of ``robots.carries``), group k running the forager of
only kind k, or the one preferring kind k. Every forager picks up whatever kind it crosses (carrying is the
world's, not the tree's) and delivers all it carries in the nest.

Writes one CSV row per swarm and seed (the evaluation's mean per trial of ``foraging_balanced``, ``foraging``
and the deliveries of each kind per robot); prints :func:`table` (mean and standard error over the seeds,
and the ratio of each heterogeneous swarm's ``foraging_balanced`` to the best homogeneous swarm's) and
:func:`paired_table` (each heterogeneous swarm against the best homogeneous one seed by seed: a seed is the
same scenario for every swarm, its start poses, wheel gains and message losses). On
``multifood-arena6-carriers`` (``robots.carries``: robot i picks up only food kind i mod 3 + 1) the
specialists' groups are the task's, so each specialist seeks the one kind it can carry, while a homogeneous
swarm's robots seek kinds that two thirds of them cannot pick up.
``--estimates`` also prints, for the wanderer and the specialists, how often a robot knows where each kind
is (:func:`estimate_shares`).
"""

from __future__ import annotations

import argparse
import csv
import io
import math
import statistics
import sys
from collections.abc import Sequence

import numpy as np

from bt_controller.validate import check_options
from swarm_ros.safe_paths import UnsafePathError, check_output, replace_file
from swarm_sim.evaluation import MAX_TRIALS, BatchEvaluator, SwarmRequest, most_threads
from swarm_sim.model import OBJECTIVES, SwarmLayout
from swarm_sim.roads import record_trial
from swarm_sim.tasks import TaskError, resolve_task

TASK = "multifood-arena6-balanced"
KINDS = (1, 2, 3)
COLUMNS: tuple[str, ...] = ("foraging_balanced", "foraging", "foraging1", "foraging2", "foraging3")
"""The values each row keeps, in ``OBJECTIVES`` names."""
HEADER: tuple[str, ...] = ("swarm", "composition", "seed", "trials", *COLUMNS)
SPECIALISTS = "specialists (only kind k)"
"""The first heterogeneous swarm's name: a group of robots per kind, each fetching only its kind."""

_HOME = "sel(seq(nest_left, forward_left), seq(nest_right, forward_right), forward)"
_WANDER = "prob(forward, forward_left, forward_right)"


def towards(kind: int) -> str:
    """Turn towards food kind ``kind`` while its estimate says on which side it lies."""
    return f"seq(food_left{kind}, forward_left), seq(food_right{kind}, forward_right)"


_CARRYING = "sel(got_food1, got_food2, got_food3)"


def kind_forager(kind: int) -> str:
    """Home once carrying kind ``kind``; else towards kind ``kind``, or wander."""
    return f"sel(seq(got_food{kind}, {_HOME}), sel({towards(kind)}, {_WANDER}))"


def preferring_forager(kind: int) -> str:
    """Home once carrying any kind; else towards kind ``kind``, or wander."""
    return f"sel(seq({_CARRYING}, {_HOME}), sel({towards(kind)}, {_WANDER}))"


def wanderer() -> str:
    """Home once carrying any kind; else wander (no food condition read)."""
    return f"sel(seq({_CARRYING}, {_HOME}), {_WANDER})"


def any_forager() -> str:
    """Home once carrying any kind; else towards kind 1, 2 or 3, the first with an estimate; or wander."""
    seek = ", ".join(f"sel({towards(k)})" for k in KINDS)
    return f"sel(seq({_CARRYING}, {_HOME}), sel({seek}, {_WANDER}))"


def random_kind_forager() -> str:
    """Home once carrying any kind; else a ``prob`` node seeks a kind drawn anew whenever its seeking ends."""
    seek = ", ".join(f"sel({towards(k)}, {_WANDER})" for k in KINDS)
    return f"sel(seq({_CARRYING}, {_HOME}), prob({seek}))"


def swarms(n_robots: int) -> dict[str, tuple[str, tuple[str, ...]]]:
    """Each swarm of the benchmark: its composition (``homogeneous`` or ``heterogeneous``) and its tree per
    robot. The specialists: robot i fetches kind ``KINDS[i mod kinds]``, the groups of a team of as many trees
    as kinds and of ``robots.carries`` (robot i in group i mod groups)."""
    group = [KINDS[i % len(KINDS)] for i in range(n_robots)]
    return {
        "any kind": ("homogeneous", (any_forager(),) * n_robots),
        **{f"only kind {k}": ("homogeneous", (kind_forager(k),) * n_robots) for k in KINDS},
        **{f"prefers kind {k}": ("homogeneous", (preferring_forager(k),) * n_robots) for k in KINDS},
        "random kind (prob)": ("homogeneous", (random_kind_forager(),) * n_robots),
        "wanderer (no food condition)": ("homogeneous", (wanderer(),) * n_robots),
        SPECIALISTS: ("heterogeneous", tuple(kind_forager(k) for k in group)),
        "specialists (prefer kind k)": ("heterogeneous", tuple(preferring_forager(k) for k in group)),
    }


def measure(task: str, seeds: int, trials: int, threads: int = 1) -> list[dict[str, str]]:
    """The benchmark's rows: every swarm on seeds 1 to ``seeds``, ``trials`` trials each, on ``task``."""
    config = resolve_task(task).config()
    if config.food_kinds != len(KINDS):
        raise TaskError(f"the division benchmark needs a task with {len(KINDS)} food kinds, got {task!r}")
    planned = [
        (name, composition, seed, SwarmRequest(SwarmLayout(trees), seed, trials))
        for name, (composition, trees) in swarms(config.n_robots).items()
        for seed in range(1, seeds + 1)
    ]
    results = BatchEvaluator(config, threads=threads).evaluate([request for *_, request in planned])
    rows = []
    for (name, composition, seed, _), result in zip(planned, results, strict=True):
        if result.fitness is None:
            raise RuntimeError(f"{name}, seed {seed}: {result.error}")
        values = dict(zip(OBJECTIVES, result.fitness, strict=True))
        rows.append(
            {
                "swarm": name,
                "composition": composition,
                "seed": str(seed),
                "trials": str(trials),
                **{column: repr(values[column]) for column in COLUMNS},
            }
        )
    return rows


FOOD_COLUMNS: tuple[int, ...] = (1, 3, 4)
"""The smoothed values' columns of food kinds 1, 2 and 3 (nest, food, density, food2, food3)."""
ESTIMATE_SWARMS: tuple[str, ...] = ("wanderer (no food condition)", SPECIALISTS)
ESTIMATE_SEEDS = 5
"""``--estimates`` records trials 0 to 4 of seeds 1 to 5 of each of :data:`ESTIMATE_SWARMS`."""


def estimate_shares(task: str, swarm: str, seeds: int = ESTIMATE_SEEDS) -> tuple[float, ...]:
    """The share of the robots' steps, over trials 0 to 4 of seeds 1 to ``seeds`` of ``swarm`` (recorded on
    the batch road), in which the robot's smoothed estimate of each food kind is below the cap: it heard of
    the kind (or stood on it) within its last window of samples. The food conditions of a kind can hold only
    then."""
    config = resolve_task(task).config()
    cap = config.params().estimate_cap
    trees = SwarmLayout(swarms(config.n_robots)[swarm][1])
    known = [
        [float((record.smoothed[:, :, column] < cap).mean()) for column in FOOD_COLUMNS]
        for record in (
            record_trial(trees, seed, trial, config) for seed in range(1, seeds + 1) for trial in range(5)
        )
    ]
    return tuple(statistics.mean(share[k] for share in known) for k in range(len(FOOD_COLUMNS)))


def estimates_lines(task: str) -> str:
    """One line per swarm of :data:`ESTIMATE_SWARMS`: its :func:`estimate_shares`, as percentages."""
    lines = []
    for swarm in ESTIMATE_SWARMS:
        shares = ", ".join(f"{100 * s:.0f} %" for s in estimate_shares(task, swarm))
        lines.append(f"- {swarm}: a food estimate of kinds 1, 2, 3 in {shares} of robot-steps")
    return "\n".join(lines) + "\n"


def _mean_sem(values: Sequence[float]) -> tuple[float, float]:
    return statistics.mean(values), statistics.stdev(values) / len(values) ** 0.5


def table(rows: Sequence[dict[str, str]]) -> str:
    """The Markdown table of ``rows`` (each swarm's mean +- standard error over its seeds, in the rows'
    order) and a line per heterogeneous swarm: the ratio of its ``foraging_balanced`` to the best homogeneous
    swarm's."""
    names = list(dict.fromkeys(row["swarm"] for row in rows))
    lines = [
        "| swarm | composition | seeds | foraging_balanced | foraging | kind 1 | kind 2 | kind 3 |",
        "|---|---|---|---|---|---|---|---|",
    ]
    means: dict[str, float] = {}
    for name in names:
        mine = [row for row in rows if row["swarm"] == name]
        cells = []
        for column in COLUMNS:
            mean, sem = _mean_sem([float(row[column]) for row in mine])
            cells.append(f"{mean:.3f} ± {sem:.3f}")
            if column == "foraging_balanced":
                means[name] = mean
        lines.append(f"| {name} | {mine[0]['composition']} | {len(mine)} | {' | '.join(cells)} |")
    composition = {row["swarm"]: row["composition"] for row in rows}
    homogeneous = [n for n in names if composition[n] == "homogeneous"]
    best = max(homogeneous, key=lambda n: means[n])
    lines.append("")
    for name in (n for n in names if n not in homogeneous):
        ratio = means[name] / means[best] if means[best] else math.inf
        lines.append(
            f"- {name} / best homogeneous ({best}), foraging_balanced: {means[name]:.3f} / "
            f"{means[best]:.3f} = {ratio:.2f}"
        )
    return "\n".join(lines) + "\n"


PAIRED_COLUMNS: tuple[str, ...] = ("foraging", "foraging_balanced")
"""The objectives :func:`paired_table` compares."""
BOOTSTRAP_RESAMPLES = 10_000
BOOTSTRAP_SEED = 36
"""The paired intervals' resamples and generator seed (issue 36), so that a table is recomputed exactly."""
LEVEL = 0.95


def paired(differences: Sequence[float], rng: np.random.Generator) -> tuple[float, float, float, float]:
    """The mean of per-seed ``differences``, its percentile bootstrap interval at :data:`LEVEL` (the seeds
    resampled with replacement, :data:`BOOTSTRAP_RESAMPLES` times, from ``rng``) and the two-sided Wilcoxon
    signed-rank p-value (zero differences dropped; 1.0 when every difference is zero)."""
    from scipy.stats import wilcoxon  # only the paired table needs scipy (a slow import)

    data = np.asarray(differences, dtype=float)
    picks = rng.integers(0, len(data), size=(BOOTSTRAP_RESAMPLES, len(data)))
    tail = (1.0 - LEVEL) / 2.0
    low, high = np.quantile(data[picks].mean(axis=1), [tail, 1.0 - tail])
    p = 1.0 if not data.any() else float(wilcoxon(data).pvalue)
    return float(data.mean()), float(low), float(high), p


def paired_table(rows: Sequence[dict[str, str]]) -> str:
    """The Markdown table of each heterogeneous swarm against the best homogeneous swarm (highest mean) on
    each of :data:`PAIRED_COLUMNS`, seed by seed (:func:`paired`): the mean difference, its 95 % bootstrap
    interval and the Wilcoxon p-value. One generator (:data:`BOOTSTRAP_SEED`) draws every interval, in the
    table's order."""
    names = list(dict.fromkeys(row["swarm"] for row in rows))
    composition = {row["swarm"]: row["composition"] for row in rows}
    by_seed = {(row["swarm"], row["seed"]): row for row in rows}
    rng = np.random.default_rng(BOOTSTRAP_SEED)
    lines = [
        "| swarm | objective | best homogeneous | mean difference | 95 % CI | Wilcoxon p |",
        "|---|---|---|---|---|---|",
    ]
    for column in PAIRED_COLUMNS:
        homogeneous = [n for n in names if composition[n] == "homogeneous"]
        best = max(
            homogeneous,
            key=lambda n: statistics.mean(float(r[column]) for r in rows if r["swarm"] == n),
        )
        for name in (n for n in names if composition[n] != "homogeneous"):
            seeds = [row["seed"] for row in rows if row["swarm"] == name]
            if {row["seed"] for row in rows if row["swarm"] == best} != set(seeds):
                raise ValueError(f"{name} and {best} were not run on the same seeds: no pairs to compare")
            differences = [
                float(by_seed[name, seed][column]) - float(by_seed[best, seed][column]) for seed in seeds
            ]
            mean, low, high, p = paired(differences, rng)
            lines.append(
                f"| {name} | {column} | {best} | {mean:+.3f} | [{low:+.3f}, {high:+.3f}] | {p:.3g} |"
            )
    return "\n".join(lines) + "\n"


def read_rows(text: str) -> list[dict[str, str]]:
    """The rows of a CSV the benchmark wrote."""
    return list(csv.DictReader(io.StringIO(text)))


def rows_csv(rows: Sequence[dict[str, str]]) -> str:
    """``rows`` as the benchmark's CSV (:data:`HEADER`)."""
    out = io.StringIO()
    writer = csv.DictWriter(out, fieldnames=HEADER, lineterminator="\n")
    writer.writeheader()
    writer.writerows(rows)
    return out.getvalue()


def main(argv: Sequence[str] | None = None) -> int:
    parser = argparse.ArgumentParser(
        prog="division-bench",
        description="Hand-written foragers on a balanced task: does a division of labour pay?",
    )
    parser.add_argument("--seeds", type=int, default=20, help="seeds 1 to N (default 20)")
    parser.add_argument("--trials", type=int, default=10, help="trials per seed (default 10)")
    parser.add_argument(
        "--task", default=TASK, help=f"a task of three food kinds, a name or a file (default {TASK})"
    )
    parser.add_argument("--threads", type=int, default=1, help="numba threads (default 1)")
    parser.add_argument("--out", help="write the rows to this CSV (default: only the table)")
    parser.add_argument(
        "--estimates",
        action="store_true",
        help="also how often robots have a food estimate (wanderer and specialists, seeds 1-5, trials 0-4)",
    )
    args = parser.parse_args(argv)
    try:
        check_options(args, {"seeds": (2, None), "trials": (1, MAX_TRIALS), "threads": (1, most_threads())})
    except ValueError as error:
        parser.error(str(error))
    try:
        # before measuring: a link, a folder or a place under a file is refused (a file is replaced)
        if args.out:
            check_output(args.out, force=True)
        rows = measure(args.task, args.seeds, args.trials, args.threads)
    except (TaskError, UnsafePathError) as error:
        print(f"division-bench: error: {error}", file=sys.stderr)
        return 2
    if args.out:
        text = rows_csv(rows)
        replace_file(args.out, lambda temporary: temporary.write_text(text))
    sys.stdout.write(table(rows))
    sys.stdout.write("\n" + paired_table(rows))
    if args.estimates:
        sys.stdout.write("\n" + estimates_lines(args.task))
    return 0


if __name__ == "__main__":
    sys.exit(main())
