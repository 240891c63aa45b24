"""``adapt-benchmark``: Intelligent Trial and Error beside its baselines over conditions, repertoires, seeds.

    ws/run evolution_manager adapt-benchmark --repertoires RUN_DIR [RUN_DIR ...] --objective food \\
        --condition-set dead-robots=3 --condition-set message-loss=0.6,gap=900 ... \\
        --seeds 3 --budget 20 --ceiling 5000 --out DIR

For every condition set (``NAME=VALUE`` conditions joined by commas) and seed ``s`` (scenario ``s``: every
evaluation of that seed is on the same fixed scenario, so all methods are scored alike):

- ``unchanged``: the repertoire's best tree, as it is (one trial);
- ``ite``: Intelligent Trial and Error over the repertoire (``adapt``'s search, run for the whole budget;
  where its stopping rule would have stopped is recorded too);
- ``random``: distinct bins of the repertoire drawn at random, the same budget;
- ``qd-scratch`` and ``gp-scratch``: MAP-Elites and GP_o from scratch in the changed world, the same budget
  (each with a seed of its own derived from ``s``);
- the ceiling: the best fitness found by MAP-Elites and by GP_o from scratch with ``--ceiling`` evaluations
  (algorithm seed ``s``).

The repertoire methods run once per repertoire; the scratch methods and the ceiling once per seed.
Writes ``DIR/runs.csv`` (every trial of every adaptation run: its tree, fitness and the best so far),
``DIR/ceilings.csv``, ``DIR/summary.json``, ``DIR/curves.png`` and ``DIR/report.md`` (the table: for each
condition, the trials until a method reaches 90 % of the ceiling, median over runs, or by how much it falls
short). Ceilings already in ``DIR/ceilings.csv`` are reused, so an interrupted benchmark continues.

``--cluster dask://HOST:PORT`` or ``--cluster slurm`` (``--cluster-config FILE``) evaluates on a Dask
cluster's workers, each changed world sent whole to them (``cluster.evaluator.DaskEvaluator``), instead of in
this process; the files are the same either way (the cluster is not recorded in them). The methods still run
one after another, so this pays for the ceilings' runs (batches of 25 to 100 evaluations), not for the
adaptation trials (one evaluation each).
"""

from __future__ import annotations

import argparse
import csv
import io
import math
import sys
import time
from collections.abc import Sequence
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from bt_controller.draws import MAX_SEED, derive_seed
from evolution_manager.adaptation.search import (
    AdaptationError,
    ConditionEvaluation,
    IntelligentTrialAndError,
    ITEParameters,
    RandomPicks,
    best_so_far,
    load_candidates,
    reevolve,
    repertoire_profile,
    run_picker,
)
from evolution_manager.arguments import EXIT_IO, EXIT_USAGE, Parser, positive_int
from evolution_manager.cluster.client import open_client
from evolution_manager.cluster.settings import ClusterError, add_cluster_options, settings_from_args
from evolution_manager.errors import DispatchError, UsageError, WriteError
from evolution_manager.evolution.run_config import OBJECTIVES
from evolution_manager.files import write_atomic, write_json
from swarm_ros.safe_paths import make_folder, refuse_links
from swarm_sim.errors import ConditionError
from swarm_sim.evaluation import BatchEvaluator, Evaluator
from swarm_sim.model import apply_conditions, default_config

if TYPE_CHECKING:  # Dask loads only for a cluster
    from distributed import Client

METHODS: tuple[str, ...] = ("unchanged", "ite", "random", "qd-scratch", "gp-scratch")
LABELS = {
    "unchanged": "repertoire's best, unchanged",
    "ite": "Intelligent Trial and Error",
    "random": "random picks from the repertoire",
    "qd-scratch": "MAP-Elites from scratch",
    "gp-scratch": "GP_o from scratch",
}
TARGET = 0.9
"""The goal: reach this fraction of the ceiling."""
RUN_HEADER = ["condition", "method", "repertoire", "seed", "trial", "tree", "fitness", "best_so_far"]
CEILING_HEADER = [
    "condition",
    "seed",
    "algorithm",
    "evaluations",
    "simulated",
    "best_fitness",
    "tree",
    "profile",
]
_PURPOSE_RANDOM = 71
_PURPOSE_SCRATCH = 72


def build_parser() -> argparse.ArgumentParser:
    """The ``adapt-benchmark`` command line."""
    parser = Parser(prog="adapt-benchmark", description=__doc__.split("\n")[0])
    parser.add_argument("--repertoires", type=Path, nargs="+", required=True, help="run directories")
    parser.add_argument("--objective", choices=OBJECTIVES, default="food", help="objective (default food)")
    parser.add_argument(
        "--condition-set",
        action="append",
        required=True,
        metavar="NAME=VALUE[,NAME=VALUE]",
        help="one changed world (repeatable)",
    )
    parser.add_argument("--seeds", type=positive_int, default=3, help="seeds 1..N (default 3)")
    parser.add_argument("--budget", type=positive_int, default=20, help="adaptation trials (default 20)")
    parser.add_argument("--ceiling", type=positive_int, default=5000, help="ceiling evaluations (5000)")
    parser.add_argument("--trials", type=positive_int, default=10, help="simulated trials per evaluation")
    parser.add_argument("--out", type=Path, required=True, help="output directory")
    parser.add_argument("--no-progress", action="store_true", help="no progress lines on stderr")
    add_cluster_options(parser)
    return parser


def _csv_text(header: Sequence[str], rows: Sequence[Sequence[object]]) -> str:
    buffer = io.StringIO()
    writer = csv.writer(buffer, lineterminator="\n")
    writer.writerow(header)
    writer.writerows(rows)
    return buffer.getvalue()


def _read_ceilings(path: Path, profile: str) -> dict[tuple[str, int, str], list[str]]:
    """The ceilings already found (under the model's ``profile``: a file of another refused)."""
    if not path.is_file():
        return {}
    with path.open(newline="") as handle:
        rows = list(csv.reader(handle))
    if not rows or rows[0] != CEILING_HEADER:
        raise UsageError(
            f"{path} is not a ceilings file of this benchmark: remove it or choose another --out"
        )
    other = {r[-1] for r in rows[1:]} - {profile}
    if other:
        raise UsageError(
            f"{path} holds ceilings of the model profile {sorted(other)[0]}, the repertoires' is {profile}: "
            "remove it or choose another --out"
        )
    return {(r[0], int(r[1]), r[2]): r for r in rows[1:]}


def trials_to_target(curve: Sequence[float], bar: float) -> float:
    """The first trial (1-based) whose best so far reaches ``bar``; infinity when none does."""
    for k, value in enumerate(curve):
        if value >= bar:
            return float(k + 1)
    return math.inf


OUTPUTS = ("runs.csv", "ceilings.csv", "summary.json", "curves.png", "report.md")
"""The files the benchmark writes in ``--out``."""


def benchmark(args: argparse.Namespace) -> dict:
    """Run every method (on the cluster of ``--cluster``); write the files; return the summary."""
    cluster = settings_from_args(args)
    with open_client(cluster, say=lambda line: print(f"adapt-benchmark: {line}", file=sys.stderr)) as client:
        return _benchmark(args, client)


def _benchmark(args: argparse.Namespace, client: Client | None) -> dict:

    profiles = {str(path): repertoire_profile(path) for path in args.repertoires}
    profile = profiles[str(args.repertoires[0])]
    if len(set(profiles.values())) > 1:
        raise UsageError(
            "the repertoires were evolved under different model profiles "
            f"({', '.join(f'{p}: {r}' for r, p in profiles.items())}): give repertoires of one profile"
        )
    args.profile = profile
    worlds = {}
    for text in args.condition_set:
        try:
            worlds[text] = apply_conditions([t for t in text.split(",") if t], default_config(profile))
        except ConditionError as error:
            raise UsageError(f"--condition-set {text}: {error}") from None
    repertoires = {str(path): load_candidates(path, args.objective) for path in args.repertoires}
    make_folder(args.out)
    for name in OUTPUTS:  # a link planted at one: refused before the benchmark's minutes, not after them
        refuse_links(args.out / name)
    ceilings_path = args.out / "ceilings.csv"
    ceilings = _read_ceilings(ceilings_path, profile)
    k = OBJECTIVES.index(args.objective)
    seeds = range(1, args.seeds + 1)
    rows: list[list[object]] = []
    curves: dict[tuple[str, str], list[list[float]]] = {}
    stops: dict[str, list[float]] = {}
    ceiling_of: dict[tuple[str, int], float] = {}
    started = time.monotonic()

    def say(message: str) -> None:
        if not args.no_progress:
            print(
                f"adapt-benchmark [{time.monotonic() - started:6.0f} s]: {message}",
                file=sys.stderr,
                flush=True,
            )

    def add_run(
        condition: str, method: str, repertoire: str, seed: int, trees: list[str], fitness: list[float]
    ) -> None:
        curve = best_so_far(fitness)
        if method == "unchanged":  # one tree, kept: its fitness at every trial
            curve = curve * args.budget
        curves.setdefault((condition, method), []).append(curve)
        for trial, (tree, value, best) in enumerate(zip(trees, fitness, curve, strict=False), start=1):
            rows.append([condition, method, repertoire, seed, trial, tree, f"{value:.6f}", f"{best:.6f}"])

    for condition, (config, _) in worlds.items():
        if client is None:
            batch: Evaluator = BatchEvaluator(config)
        else:
            # Dask (about 0.3 s to import) loads only for a cluster
            from evolution_manager.cluster.evaluator import DaskEvaluator

            batch = DaskEvaluator(client, config)
        for seed in seeds:
            evaluate = ConditionEvaluation(batch, seed, args.trials)
            best_ceiling = -math.inf
            for algorithm in ("qd", "gp"):
                key = (condition, seed, algorithm)
                if key not in ceilings:
                    say(f"{condition} seed {seed}: ceiling, {algorithm} with {args.ceiling} evaluations")
                    run_eval = ConditionEvaluation(batch, seed, args.trials)
                    trees, fitness = reevolve(algorithm, args.objective, args.ceiling, seed, run_eval)
                    best = int(np.argmax(fitness))
                    ceilings[key] = [
                        condition,
                        str(seed),
                        algorithm,
                        str(len(fitness)),
                        str(run_eval.simulated),
                    ]
                    ceilings[key] += [f"{fitness[best]:.6f}", trees[best], profile]
                    write_atomic(ceilings_path, _csv_text(CEILING_HEADER, list(ceilings.values())))
                best_ceiling = max(best_ceiling, float(ceilings[key][5]))
            ceiling_of[(condition, seed)] = best_ceiling
            say(f"{condition} seed {seed}: ceiling {best_ceiling:.4f}; scratch and repertoire methods")
            for n, algorithm in enumerate(("qd", "gp")):
                # Own seeds: with the same seed both would draw the same initial random trees.
                own = derive_seed(seed, _PURPOSE_SCRATCH, n) & MAX_SEED
                trees, fitness = reevolve(algorithm, args.objective, args.budget, own, evaluate)
                add_run(condition, f"{algorithm}-scratch", "", seed, trees, fitness)
            for r, (name, candidates) in enumerate(repertoires.items()):
                top = max(candidates, key=lambda c: c.prior)
                value = evaluate([top.tree])[0].objective(k)
                add_run(condition, "unchanged", name, seed, [top.tree], [value])
                ite = IntelligentTrialAndError(candidates, args.budget, ITEParameters(stop_fraction=None))
                run_picker(ite, evaluate, args.objective)
                add_run(
                    condition, "ite", name, seed, [t.tree for t in ite.tried], [t.fitness for t in ite.tried]
                )
                stop = next(
                    (
                        n + 1
                        for n in range(len(ite.tried))
                        if max(t.fitness for t in ite.tried[: n + 1]) >= TARGET * ite.tried[n].expected_max
                    ),
                    math.inf,
                )
                stops.setdefault(condition, []).append(float(stop))
                seed_random = derive_seed(seed, _PURPOSE_RANDOM, r) & MAX_SEED
                picks = RandomPicks(candidates, args.budget, seed_random)
                run_picker(picks, evaluate, args.objective)
                add_run(
                    condition,
                    "random",
                    name,
                    seed,
                    [t.tree for t in picks.tried],
                    [t.fitness for t in picks.tried],
                )

    write_atomic(args.out / "runs.csv", _csv_text(RUN_HEADER, rows))
    summary = summarise(worlds, curves, ceiling_of, stops, args)
    write_json(args.out / "summary.json", summary)
    curves_figure(summary, curves, ceiling_of, args.out / "curves.png", args.objective)
    write_atomic(args.out / "report.md", report_text(summary, args))
    say(f"done: {args.out / 'report.md'}")
    return summary


def _median(values: Sequence[float]) -> float:
    return float(np.median(np.asarray(values, dtype=np.float64)))


def summarise(
    worlds: dict,
    curves: dict[tuple[str, str], list[list[float]]],
    ceiling_of: dict[tuple[str, int], float],
    stops: dict[str, list[float]],
    args: argparse.Namespace,
) -> dict:
    """Per condition and method: trials to 90 % of the ceiling (median over runs), the share of runs that get
    there, and the best at the budget as a fraction of the ceiling."""
    out: dict[str, object] = {
        "objective": args.objective,
        "profile": args.profile,
        "budget": args.budget,
        "ceiling_evaluations": args.ceiling,
    }
    seeds = list(range(1, args.seeds + 1))
    per_condition = {}
    for condition, (_, record) in worlds.items():
        ceiling = [ceiling_of[(condition, s)] for s in seeds]
        methods = {}
        for method in METHODS:
            runs = curves.get((condition, method), [])
            # Runs are in seed-major order: each seed's repertoires (or one scratch run) in turn.
            per_seed = len(runs) // len(seeds)
            bars = [TARGET * ceiling_of[(condition, seeds[i // per_seed])] for i in range(len(runs))]
            fractions = [
                run[-1] / ceiling_of[(condition, seeds[i // per_seed])] for i, run in enumerate(runs)
            ]
            hits = [trials_to_target(run, bar) for run, bar in zip(runs, bars, strict=True)]
            methods[method] = {
                "runs": len(runs),
                "median_trials_to_90": _median(hits),
                "reached": sum(math.isfinite(h) for h in hits),
                "median_best_at_budget": _median([run[-1] for run in runs]),
                "median_fraction_of_ceiling": _median(fractions),
            }
        per_condition[condition] = {
            "conditions": record,
            "ceiling_median": _median(ceiling),
            "ceilings": ceiling,
            "ite_stopping_rule_median_trials": _median(stops.get(condition, [math.inf])),
            "methods": methods,
        }
    out["conditions"] = per_condition
    finite = _finite(out)
    assert isinstance(finite, dict)
    return finite


def _finite(data: object) -> object:
    """Infinity (never reached) as None, for strict JSON."""
    if isinstance(data, dict):
        return {k: _finite(v) for k, v in data.items()}
    if isinstance(data, list):
        return [_finite(v) for v in data]
    if isinstance(data, float) and not math.isfinite(data):
        return None
    return data


def curves_figure(
    summary: dict,
    curves: dict[tuple[str, str], list[list[float]]],
    ceiling_of: dict[tuple[str, int], float],
    path: Path,
    objective: str,
) -> Path:
    """One panel per condition: median best-so-far against trials used, per method, with 90 % of the
    ceiling."""
    # matplotlib (about 1.5 s to import) loads only when figures are drawn
    from evolution_manager.viewing import figures

    conditions = list(summary["conditions"])
    columns = min(3, len(conditions))
    rows = math.ceil(len(conditions) / columns)
    figure, axes = figures.subplots(rows, columns, figsize=(5.0 * columns, 3.6 * rows), squeeze=False)
    for axis, condition in zip(axes.flat, conditions, strict=False):
        for method in METHODS:
            runs = curves.get((condition, method))
            if not runs:
                continue
            data = np.array(runs)
            x = np.arange(1, data.shape[1] + 1)
            median = np.median(data, axis=0)
            axis.plot(x, median, label=LABELS[method], drawstyle="steps-post")
            axis.fill_between(
                x, np.percentile(data, 25, axis=0), np.percentile(data, 75, axis=0), alpha=0.15, step="post"
            )
        bar = TARGET * summary["conditions"][condition]["ceiling_median"]
        axis.axhline(bar, color="k", linestyle="--", linewidth=1, label="90 % of the ceiling (median)")
        axis.set_title(condition, fontsize=10)
        axis.set_xlabel("trials used (evaluations)")
        axis.set_ylabel(f"best {objective} fitness so far")
    for axis in list(axes.flat)[len(conditions) :]:
        axis.axis("off")
    handles, labels = axes.flat[0].get_legend_handles_labels()
    figure.legend(handles, labels, loc="lower center", ncol=3, fontsize=8, bbox_to_anchor=(0.5, -0.02))
    figure.tight_layout(rect=(0, 0.08, 1, 1))
    return figures._save(figure, path)


def _trials(value: float | None, budget: int) -> str:
    return f"never in {budget}" if value is None else f"{value:g}"


def _shortfall(method: dict) -> str:
    if method["median_trials_to_90"] is not None:
        return "reaches it"
    return f"{100 * (TARGET - method['median_fraction_of_ceiling']):.1f} points"


def report_text(summary: dict, args: argparse.Namespace) -> str:
    """``report.md``: how it was made, the curves and the table."""
    command = " ".join(
        ["ws/run evolution_manager adapt-benchmark", "--repertoires", *(str(r) for r in args.repertoires)]
        + [f"--objective {args.objective}"]
        + [f"--condition-set {c}" for c in args.condition_set]
        + [f"--seeds {args.seeds} --budget {args.budget} --ceiling {args.ceiling} --trials {args.trials}"]
        + [f"--out {args.out}"]
    )
    lines = [
        "# Adaptation: Intelligent Trial and Error against its baselines",
        "",
        f"Model profile `{summary['profile']}` (the repertoires'); objective {summary['objective']}; "
        f"budget {summary['budget']} trials (one trial = one evaluation of "
        f"{args.trials} simulated trials in the changed world, every evaluation of a seed on the same "
        f"scenario); {len(args.repertoires)} repertoires x {args.seeds} seeds per condition. The ceiling: "
        f"the best fitness found by MAP-Elites or GP_o from scratch with {summary['ceiling_evaluations']} "
        "evaluations in the changed world, per seed. Made by:",
        "",
        f"    {command}",
        "",
        "Files: `runs.csv` (every trial of every adaptation run: condition, method, repertoire, seed, trial, "
        "tree, fitness, best so far), `ceilings.csv`, `summary.json`, `curves.png`.",
        "",
        "![median best fitness so far against trials used, interquartile range shaded](curves.png)",
        "",
        "## Trials until 90 % of the ceiling",
        "",
        "Median over runs (repertoire methods: repertoires x seeds; scratch methods: seeds), a run that "
        "never gets there counting as never; where the median run never gets there, how far its best at the "
        "budget falls short of 90 % of the ceiling (percentage points of the ceiling).",
        "",
        "| condition | ceiling (median) | method | median trials to 90 % | runs reaching 90 % | "
        "median best at budget | median % of ceiling | falls short by |",
        "|---|---|---|---|---|---|---|---|",
    ]
    for condition, data in summary["conditions"].items():
        for method in METHODS:
            m = data["methods"][method]
            lines.append(
                f"| {condition} | {data['ceiling_median']:.4f} | {LABELS[method]} | "
                f"{_trials(m['median_trials_to_90'], summary['budget'])} | {m['reached']} / {m['runs']} | "
                f"{m['median_best_at_budget']:.4f} | {100 * m['median_fraction_of_ceiling']:.1f} % | "
                f"{_shortfall(m)} |"
            )
    lines += [
        "",
        "ITE's stopping rule (stop when the best observed reaches 0.9 of the highest expected fitness) would "
        "have stopped after (median trials):",
        "",
    ]
    for condition, data in summary["conditions"].items():
        lines.append(f"- {condition}: {_trials(data['ite_stopping_rule_median_trials'], summary['budget'])}")
    return "\n".join(lines) + "\n"


def main(argv: Sequence[str] | None = None) -> None:
    """Console entry point of ``adapt-benchmark``."""
    try:
        args = build_parser().parse_args(argv)
        benchmark(args)
    except (UsageError, AdaptationError, ClusterError) as error:
        print(f"adapt-benchmark: error: {error}", file=sys.stderr)
        sys.exit(EXIT_USAGE)
    except DispatchError as error:  # the cluster's workers could not finish a chunk
        print(f"adapt-benchmark: error: {error}; the ceilings found so far are kept", file=sys.stderr)
        sys.exit(1)
    except (WriteError, OSError) as error:  # a link planted in --out, a full disk, a read-only folder
        print(f"adapt-benchmark: error: {error}", file=sys.stderr)
        sys.exit(EXIT_IO)
    sys.exit(0)
