"""``experiment``: every algorithm x objective x run in parallel processes, then the report.

    ws/run evolution_manager experiment --runs 10 --evaluations 25000 --out experiments/paper

GP_o and QD_o run once per objective and run index with ``--evaluations``; GP_fnd runs once per run index
on all three objectives with three times the budget (the paper's 75,000 against 25,000). Run ``r`` of a
configuration gets a seed derived from ``--seed``, the configuration and ``r``. Each run is an ordinary run
directory under ``DIR/runs/<label>/run<r>``; starting the same command again continues unfinished runs
from their checkpoints and leaves finished ones alone. ``experiment.json`` records the plan.
"""

from __future__ import annotations

import argparse
import json
import os
import sys
from collections.abc import Sequence
from concurrent.futures import ProcessPoolExecutor, as_completed
from multiprocessing import get_context
from pathlib import Path

from bt_controller.draws import MAX_SEED, RUN_EXPERIMENT, derive_seed

from .cli import EXIT_INTERRUPTED, EXIT_USAGE, Parser, UsageError, positive_int, seed_int
from .config import ALGORITHMS, RunConfig
from .errors import EvolutionError
from .files import read_json, read_json_object, write_json
from .primitives import OBJECTIVES

PLAN_FILE = "experiment.json"


def plan(runs: int, evaluations: int, seed: int, trials: int = 10) -> list[tuple[RunConfig, str]]:
    """Every run of the experiment with its directory relative to the experiment's folder."""
    planned = []
    for a, algorithm in enumerate(ALGORITHMS):
        objectives: Sequence[str | None] = [None] if algorithm == "gp-fnd" else OBJECTIVES
        budget = 3 * evaluations if algorithm == "gp-fnd" else evaluations
        for objective in objectives:
            o = -1 if objective is None else OBJECTIVES.index(objective)
            for r in range(runs):
                run_seed = derive_seed(seed, RUN_EXPERIMENT, a, o + 1, r)
                config = RunConfig.make(algorithm, objective, budget, run_seed, trials)
                planned.append((config, f"runs/{config.label}/run{r:02d}"))
    return planned


def run_one(config_data: dict, root: str) -> str:
    """Run (or finish, or leave alone when finished) one planned run; return its directory.

    A top-level function so that a process pool can call it; each process evaluates on one thread.
    """
    from swarm_sim.evaluation import BatchEvaluator

    from .outputs import write_results
    from .run import Run, RunDirectory

    config = RunConfig.from_json(config_data)
    directory = RunDirectory(Path(root))
    if directory.summary.exists() and read_json_object(directory.summary).get("finished"):
        return root
    evaluator = BatchEvaluator(threads=1)
    if directory.started():
        run = Run.resume(directory.root, evaluator)
        if run.config != config:
            raise EvolutionError(f"{root} holds a run of another configuration than the experiment's plan")
    else:
        run = Run.start(config, directory.root, evaluator)
    run.execute()
    write_results(run, with_figures=False)
    return root


def build_parser() -> argparse.ArgumentParser:
    """The ``experiment`` command line."""
    parser = Parser(prog="experiment", description=__doc__.split("\n")[0])
    parser.add_argument(
        "--runs", type=positive_int, default=10, help="runs per algorithm and objective (default 10)"
    )
    parser.add_argument(
        "--evaluations",
        type=positive_int,
        default=25_000,
        help="budget per objective (default 25000; GP_fnd 3x)",
    )
    parser.add_argument(
        "--out", type=Path, required=True, help="experiment folder (continued when it exists)"
    )
    parser.add_argument("--seed", type=seed_int, default=0, help="experiment seed (default 0)")
    parser.add_argument("--trials", type=positive_int, default=10, help="trials per evaluation (default 10)")
    parser.add_argument(
        "--processes", type=positive_int, default=os.cpu_count() or 1, help="runs at once (default: cores)"
    )
    parser.add_argument("--no-progress", action="store_true", help="no progress bar")
    return parser


def experiment(argv: Sequence[str] | None = None) -> int:
    """Run ``experiment``; return the exit status."""
    from .report import build_report

    try:
        args = build_parser().parse_args(argv)
        if not 0 <= args.seed <= MAX_SEED:
            raise UsageError(f"--seed must be in [0, {MAX_SEED}], got {args.seed}")
        planned = plan(args.runs, args.evaluations, args.seed, args.trials)
        document = {
            "runs": args.runs,
            "evaluations": args.evaluations,
            "seed": args.seed,
            "trials": args.trials,
            "plan": [{"dir": path, "config": config.to_json()} for config, path in planned],
        }
        plan_path = args.out / PLAN_FILE
        if plan_path.exists():
            saved = read_json(plan_path)
            if saved != json.loads(json.dumps(document)):
                raise UsageError(
                    f"{args.out} holds an experiment with other options; "
                    "use the same options to continue it, "
                    "or another --out"
                )
        elif args.out.exists() and any(args.out.iterdir()):
            raise UsageError(f"{args.out} exists and is not an experiment folder; choose another --out")
        args.out.mkdir(parents=True, exist_ok=True)
        write_json(plan_path, document)
    except (UsageError, EvolutionError) as error:
        print(f"experiment: error: {error}", file=sys.stderr)
        return EXIT_USAGE
    except OSError as error:  # an --out that cannot be created or written
        print(f"experiment: error: {error}", file=sys.stderr)
        return EXIT_USAGE
    bar = None
    if not args.no_progress:
        from tqdm import tqdm

        bar = tqdm(total=len(planned), unit="run", desc="experiment", dynamic_ncols=True, disable=None)
    failures = []
    try:
        with ProcessPoolExecutor(max_workers=args.processes, mp_context=get_context("spawn")) as pool:
            futures = {
                pool.submit(run_one, config.to_json(), str(args.out / path)): path for config, path in planned
            }
            for future in as_completed(futures):
                try:
                    future.result()
                except Exception as error:  # a failed run is reported, the others go on
                    failures.append(f"{futures[future]}: {error}")
                if bar is not None:
                    bar.update(1)
    except KeyboardInterrupt:
        print(
            f"experiment: interrupted; run the same command again to continue ({args.out})", file=sys.stderr
        )
        return EXIT_INTERRUPTED
    finally:
        if bar is not None:
            bar.close()
    if failures:
        print("experiment: some runs failed:\n  " + "\n  ".join(failures), file=sys.stderr)
        return 1
    report = build_report(args.out)
    print(f"experiment: {len(planned)} runs in {args.out}; report: {report}")
    return 0


def main() -> None:
    """Console entry point of ``experiment``."""
    sys.exit(experiment())
