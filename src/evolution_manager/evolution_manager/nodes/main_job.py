"""The main job (``ws/run`` with no arguments): evolve a repertoire through the ROS 2 graph, then watch its
best tree in the full node graph.

1. MAP-Elites for go-to-food (the paper's QD_f) runs in the evolution manager node, which spreads its batches
   over evaluator nodes (started here, each its own process) through their evaluate services, records every
   evaluation and the archive's progress to an MCAP bag, and writes the run directory: the repertoire per
   objective (JSON), progress (CSV), figures (PNG) and the best trees in every format.
2. The best go-to-food tree then runs one trial through the full node graph (the simulator and nine footbot
   controller processes, in lockstep over topics and services), recorded to a second bag.
3. It prints where everything is, and the commands to replay and verify the recorded trial.

Options: ``ws/run evolution_manager main --help``.
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
import time
from collections.abc import Sequence
from datetime import UTC, datetime
from pathlib import Path

from evolution_manager.bags import BagError
from evolution_manager.graph import GraphError, executable
from evolution_manager.nodes.trial import TrialFailedError, run_recorded_trial
from swarm_ros.isolation import domain_environment, reserved_domain

DEFAULT_EVALUATIONS = 25_000  # the paper's budget per run; about two minutes here
DEFAULT_EVALUATORS = 2


def default_out() -> Path:
    """A new run directory under ./runs, named by the time it starts."""
    return Path("runs") / datetime.now(UTC).strftime("main-%Y%m%d-%H%M%S")


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="ws/run",
        description=__doc__.split("\n\n")[0],
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    parser.add_argument("--evaluations", type=int, default=DEFAULT_EVALUATIONS, help="evaluation budget")
    parser.add_argument("--seed", type=int, default=1, help="seed of the run (default 1)")
    parser.add_argument("--evaluators", type=int, default=DEFAULT_EVALUATORS, help="evaluator nodes to start")
    parser.add_argument("--out", type=Path, default=None, help="new run directory (default runs/main-<time>)")
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    """Run the main job; return the exit status."""
    args = build_parser().parse_args(sys.argv[1:] if argv is None else argv)
    out = args.out or default_out()
    if out.exists():
        print(f"main: {out} exists already: choose a new --out (nothing there is touched)", file=sys.stderr)
        return 2
    if args.evaluations < 150 or args.evaluators < 1:
        print("main: --evaluations must be at least 150 and --evaluators at least 1", file=sys.stderr)
        return 2
    started = time.monotonic()
    print(
        f"[1/2] MAP-Elites for go-to-food, {args.evaluations} evaluations (seed {args.seed}), through the "
        f"manager node and {args.evaluators} evaluator nodes -> {out}",
        flush=True,
    )
    try:
        manager = str(executable("evolution_manager", "manager"))
    except GraphError as error:
        print(f"main: {error}", file=sys.stderr)
        return 1
    with reserved_domain() as domain:
        command = [
            manager,
            "--algorithm", "qd",
            "--objective", "food",
            "--evaluations", str(args.evaluations),
            "--seed", str(args.seed),
            "--out", str(out),
            "--evaluators", str(args.evaluators),
        ]  # fmt: skip
        if subprocess.run(command, env=domain_environment(domain), check=False).returncode != 0:
            print(f"main: the evolution run failed; its directory is {out}", file=sys.stderr)
            return 1
    summary = json.loads((out / "summary.json").read_text())
    best = summary["objectives"]["food"]
    evolved = time.monotonic()

    bag = out / "best_trial.bag"
    print(
        f"[2/2] the best go-to-food tree (fitness {best['best_fitness']:.4f}) through the full node graph "
        f"(simulator + 9 footbot controllers) -> {bag}",
        flush=True,
    )
    try:
        record = run_recorded_trial(best["best_tree"], args.seed, 0, bag, log_dir=out / "logs" / "trial")
    except (GraphError, BagError, TrialFailedError) as error:
        print(f"main: the trial through the node graph failed: {error}", file=sys.stderr)
        return 1
    finished = time.monotonic()

    values = dict(zip(("density", "nest", "food"), record.values[:3], strict=True))
    print(
        f"""
Done in {finished - started:.0f} s (evolution {evolved - started:.0f} s, trial through the graph {finished - evolved:.0f} s).

Run directory      {out}/
  summary          {out}/summary.json  (best fitness {best["best_fitness"]:.4f}, coverage {best["coverage"]:.4f}, QD score {best["qd_score"]:.2f})
  repertoire       {out}/repertoire_food.json  (and one per objective: every tree was scored on all three)
  progress         {out}/progress.csv
  figures          {out}/figures/
  best trees       {out}/best/
  run bag (MCAP)   {out}/run.bag/  (every evaluation on /evaluations, archive progress on /progress)
Best tree          {best["best_tree"]}
Trial bag (MCAP)   {bag}/  (every topic of the graph; trial 0, food {values["food"]:.4f})
Node logs          {out}/logs/

Watch it in Foxglove:      open {bag}/ with the layout docs/foxglove_layout.json (docs/ros.md)
Replay it for ROS tools:   ws/run evolution_manager replay {bag}
Verify it reproduces:      ws/run evolution_manager replay {bag} --verify
Evolve more:               ws/run evolution_manager evolve --help
"""  # noqa: E501
    )
    return 0
