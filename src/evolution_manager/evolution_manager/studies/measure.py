"""``measure``: the algorithms' own overhead per evaluation and the end-to-end speed of a run.

    ws/run evolution_manager measure --evaluations 5000

For each algorithm it runs a real run (in-process batch evaluator, one thread) in a temporary folder and
reports, from the run's own clocks: the seconds spent in the evaluator; the seconds spent in everything
else (ask, tell, variation, the passive grids, the CSV logs, checkpoints every 30 s) per evaluation, and as a
fraction of the evaluator's time; and the end-to-end evaluations per second. The issue's target: overhead
under 10 % of the evaluator's time.
"""

from __future__ import annotations

import json
import sys
import tempfile
import time
from collections.abc import Sequence
from pathlib import Path

from evolution_manager.arguments import EXIT_IO, EXIT_USAGE, Parser, positive_int, seed_in_range
from evolution_manager.errors import UsageError
from evolution_manager.evolution.run import Run
from evolution_manager.evolution.run_config import ALGORITHMS, OBJECTIVES, RunConfig
from swarm_ros.safe_paths import check_output, describe, replace_file
from swarm_sim.evaluation import BatchEvaluator


def measure_one(
    algorithm: str, objective: str | None, evaluations: int, seed: int, root: Path, workers: int
) -> dict:
    """Run one configuration and return its timings."""
    run = Run.start(
        RunConfig.make(algorithm, objective, evaluations, seed), root, BatchEvaluator(threads=workers)
    )
    started = time.perf_counter()
    run.execute()
    wall = time.perf_counter() - started
    n = run.evaluations
    return {
        "run": run.config.label,
        "evaluations": n,
        "wall_seconds": wall,
        "evaluator_seconds": run.timing.evaluator,
        "overhead_seconds": run.timing.manager,
        "overhead_ms_per_evaluation": 1000 * run.timing.manager / n,
        "evaluator_ms_per_evaluation": 1000 * run.timing.evaluator / n,
        "overhead_fraction": run.timing.manager / run.timing.evaluator,
        "evaluations_per_second": n / wall,
    }


def measure(argv: Sequence[str] | None = None) -> int:
    """Run ``measure``; return the exit status."""
    parser = Parser(prog="measure", description=__doc__.split("\n")[0])
    parser.add_argument(
        "--evaluations", type=positive_int, default=5000, help="evaluations per run (default 5000)"
    )
    parser.add_argument("--algorithms", nargs="+", choices=ALGORITHMS, default=list(ALGORITHMS))
    parser.add_argument(
        "--objective", choices=OBJECTIVES, default="food", help="objective of gp and qd (default food)"
    )
    parser.add_argument("--seed", type=seed_in_range, default=1, help="run seed (default 1)")
    parser.add_argument("--workers", type=positive_int, default=1, help="evaluator threads (default 1)")
    parser.add_argument("--json", type=Path, help="also write the measurements to this file (new)")
    parser.add_argument("--force", action="store_true", help="overwrite a --json file that exists")
    try:
        args = parser.parse_args(argv)
        if args.json is not None:  # refused before anything is measured: a link, a folder, a file there
            check_output(args.json, args.force, "--json")
    except UsageError as error:
        print(f"measure: error: {error}", file=sys.stderr)
        return EXIT_USAGE
    except OSError as error:
        print(f"measure: error: {describe(args.json, error)}", file=sys.stderr)
        return EXIT_USAGE
    rows = []
    with tempfile.TemporaryDirectory(prefix="measure-") as folder:
        for algorithm in args.algorithms:
            objective = None if algorithm == "gp-fnd" else args.objective
            rows.append(
                measure_one(
                    algorithm, objective, args.evaluations, args.seed, Path(folder) / algorithm, args.workers
                )
            )
    print("| run | evaluations | evaluator ms/eval | overhead ms/eval | overhead / evaluator | evals/s |")
    print("|---|---|---|---|---|---|")
    for r in rows:
        print(
            f"| {r['run']} | {r['evaluations']} | {r['evaluator_ms_per_evaluation']:.3f} "
            f"| {r['overhead_ms_per_evaluation']:.3f} | {100 * r['overhead_fraction']:.1f} % "
            f"| {r['evaluations_per_second']:.1f} |"
        )
    if args.json:
        text = json.dumps(rows, indent=1) + "\n"
        try:
            replace_file(args.json, lambda temporary: temporary.write_text(text))
        except OSError as error:
            print(f"measure: error: {describe(args.json, error)}", file=sys.stderr)
            return EXIT_IO
    return 0


def main() -> None:
    """Console entry point of ``measure``."""
    sys.exit(measure())
