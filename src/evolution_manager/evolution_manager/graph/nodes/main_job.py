"""The main job (``ws/run`` with no arguments): evolve a repertoire through the ROS 2 graph, then watch its
best tree in the full node graph.

1. MAP-Elites for go-to-food (the paper's QD_f) runs in the evolution manager node, which spreads its batches
   over evaluator nodes (started here, each its own process) through their evaluate services, records every
   evaluation and the archive's progress to an MCAP bag, and writes the run directory: the repertoire per
   objective (JSON), progress (CSV), figures (PNG) and the best trees in every format.
2. The best go-to-food tree then runs one trial through the full node graph (the simulator and nine footbot
   controller processes, in lockstep over topics and services), recorded to a second bag.
3. It prints where everything is, and the commands to replay and verify the recorded trial.

With ``--cluster dask://HOST:PORT`` or ``--cluster slurm`` (``--cluster-config FILE``; ``docs/cluster.md``)
the evolution of step 1 runs as ``evolve --cluster ...`` instead, its batches on the Dask cluster's workers
rather than on evaluator nodes: evaluator nodes need one DDS domain, which a cluster's network does not
carry. The run directory holds the same result files, without the run bag (the manager node records it);
step 2 still runs through the node graph on this machine.

Ctrl-C or SIGTERM stops the job cleanly (the manager stops its evaluators, the trial graph its nodes) and
exits 130 or 143; ``ws/run --resume --out DIR`` continues it: the evolution from its last checkpoint (or
afresh if it had none), then the trial stage again. ``kill -9`` leaves no process behind either: every
child dies with its parent.

Options: ``ws/run evolution_manager main --help``.
"""

from __future__ import annotations

import argparse
import json
import shutil
import signal
import subprocess
import sys
import time
from collections.abc import Sequence
from datetime import UTC, datetime
from pathlib import Path

from evolution_manager.arguments import Parser, positive_int, seed_in_range
from evolution_manager.errors import AnimationError, UsageError
from evolution_manager.evolution.run_config import DEFAULT_PROFILE, PROFILES, SCENARIOS
from evolution_manager.graph.nodes.trial import TrialFailedError, run_recorded_trial
from evolution_manager.graph.startup import GraphError, executable
from evolution_manager.processes import die_with_parent, exit_status, signals_as_interrupts
from evolution_manager.recording.bags import BagError
from evolution_manager.viewing.animate import write_animation
from evolution_manager.viewing.frames import frames_from_bag
from swarm_ros.isolation import domain_environment, reserved_domain
from swarm_ros.safe_paths import check_folder
from swarm_sim.model import OBJECTIVES

DEFAULT_EVALUATIONS = 25_000  # the paper's budget per run; about two minutes here
DEFAULT_EVALUATORS = 2


def default_out() -> Path:
    """A new run directory under ./runs, named by the time it starts."""
    return Path("runs") / datetime.now(UTC).strftime("main-%Y%m%d-%H%M%S")


def build_parser() -> argparse.ArgumentParser:
    parser = Parser(
        prog="ws/run",
        description=__doc__.split("\n\n")[0],
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    parser.add_argument(
        "--evaluations", type=positive_int, default=DEFAULT_EVALUATIONS, help="evaluation budget"
    )
    parser.add_argument(
        "--seed", type=seed_in_range, default=1, help="seed of the run, in [0, 2**63 - 1] (default 1)"
    )
    parser.add_argument(
        "--evaluators",
        type=positive_int,
        default=None,
        help=f"evaluator nodes to start (default {DEFAULT_EVALUATORS}; not with a --cluster)",
    )
    parser.add_argument(
        "--scenarios", choices=SCENARIOS, default="fixed", help="fixed (default) or fresh scenarios"
    )
    parser.add_argument(
        "--scenario-seed",
        type=seed_in_range,
        default=None,
        help="scenario seed, in [0, 2**63 - 1] (default: derived from --seed)",
    )
    parser.add_argument(
        "--profile",
        choices=PROFILES,
        default=DEFAULT_PROFILE,
        help=f"the model's profile (docs/model.md; default {DEFAULT_PROFILE})",
    )
    parser.add_argument("--out", type=Path, default=None, help="new run directory (default runs/main-<time>)")
    parser.add_argument(
        "--resume", action="store_true", help="continue the interrupted job in --out (with its own options)"
    )
    parser.add_argument(
        "--cluster",
        default="local",
        metavar="local|dask://HOST:PORT|slurm",
        help="where the evolution's evaluations run: evaluator nodes on this machine (local, the default), "
        "or through evolve on a Dask scheduler's workers or Dask workers started as SLURM jobs "
        "(docs/cluster.md); the trial runs through the node graph here",
    )
    parser.add_argument(
        "--cluster-config", type=Path, metavar="FILE", help="with --cluster slurm: its YAML settings"
    )
    return parser


def evolution_command(args: argparse.Namespace, out: Path) -> list[str]:
    """The command of the evolution stage: the manager with its evaluator nodes, or with a ``--cluster``
    other than ``local``, ``evolve`` on that cluster (which checks the cluster options itself)."""
    on_cluster = args.cluster != "local"
    program = str(executable("evolution_manager", "evolve" if on_cluster else "manager"))
    where = ["--cluster", args.cluster] if on_cluster else ["--evaluators", str(args.evaluators)]
    if args.cluster_config is not None:
        where += ["--cluster-config", str(args.cluster_config)]
    if args.resume and (out / "config.json").exists():
        return [program, "--out", str(out), "--resume", *where]
    command = [
        program,
        "--algorithm", "qd",
        "--objective", "food",
        "--evaluations", str(args.evaluations),
        "--seed", str(args.seed),
        "--out", str(out),
        "--scenarios", args.scenarios,
        "--profile", args.profile,
        *where,
    ]  # fmt: skip
    if args.scenario_seed is not None:
        command += ["--scenario-seed", str(args.scenario_seed)]
    return command


def run_manager(command: list[str], env: dict[str, str]) -> tuple[int, int]:
    """Run the manager to its end; return its exit status and the signal (SIGINT or SIGTERM) that asked this
    job to stop meanwhile (0 if none). The manager runs in a process group of its own and gets the signal
    from here, once; it dies with this process if this process is killed."""
    received = 0
    manager = subprocess.Popen(command, env=env, preexec_fn=die_with_parent, process_group=0)

    def forward(signum: int, frame: object) -> None:
        nonlocal received
        received = received or signum
        if manager.poll() is None:
            manager.send_signal(signum)

    previous = {s: signal.signal(s, forward) for s in (signal.SIGINT, signal.SIGTERM)}
    try:
        return manager.wait(), received
    finally:
        for s, handler in previous.items():
            signal.signal(s, handler)


def main(argv: Sequence[str] | None = None) -> int:
    """Run the main job; return the exit status."""
    try:
        args = build_parser().parse_args(sys.argv[1:] if argv is None else argv)
    except UsageError as error:
        print(f"main: {error}", file=sys.stderr)
        return 2
    if args.resume and args.out is None:
        print("main: --resume needs the --out of the job to continue", file=sys.stderr)
        return 2
    if args.resume and not args.out.is_dir():  # it started a new job of 25,000 evaluations there
        print(f"main: --resume --out {args.out}: no job there to continue (no such folder)", file=sys.stderr)
        return 2
    out = args.out or default_out()
    if (out.exists() or out.is_symlink()) and not args.resume:
        print(
            f"main: {out} exists already: choose a new --out, or continue its job with --resume --out {out} "
            "(nothing there is touched)",
            file=sys.stderr,
        )
        return 2
    on_cluster = args.cluster != "local"
    refused = None
    if on_cluster and args.evaluators is not None:
        refused = f"--evaluators applies to --cluster local only, not to --cluster {args.cluster}"
    if args.cluster_config is not None and not on_cluster:  # dask://: its TLS files (evolve checks them)
        refused = "--cluster-config applies to --cluster slurm or dask://HOST:PORT, not to --cluster local"
    try:  # a link or a place under a file, before the job starts (the cluster's settings: evolve checks them)
        check_folder(out, "--out")
    except OSError as error:
        refused = refused or str(error)
    if refused:
        print(f"main: {refused}", file=sys.stderr)
        return 2
    if args.evaluators is None:
        args.evaluators = DEFAULT_EVALUATORS
    if args.evaluations < 150 or args.evaluators < 1:
        print("main: --evaluations must be at least 150 and --evaluators at least 1", file=sys.stderr)
        return 2
    again = f"ws/run --resume --out {out}" + (f" --cluster {args.cluster}" if on_cluster else "")
    if args.cluster_config is not None:
        again += f" --cluster-config {args.cluster_config}"
    started = time.monotonic()
    where = (
        f"evolve on --cluster {args.cluster}"
        if on_cluster
        else f"the manager node and {args.evaluators} evaluator nodes"
    )
    print(
        f"[1/2] MAP-Elites for go-to-food, {args.evaluations} evaluations (seed {args.seed}), through "
        f"{where} -> {out}",
        flush=True,
    )
    try:
        command = evolution_command(args, out)
    except GraphError as error:
        print(f"main: {error}", file=sys.stderr)
        return 1
    with reserved_domain() as domain:
        status, received = run_manager(command, domain_environment(domain))
        if received:
            print(f"main: interrupted; continue with: {again}", file=sys.stderr)
            return 128 + received
        if status == 2 and on_cluster:  # evolve refused an option (a cluster setting) and said why, in a line
            return 2
        if status != 0:
            print(f"main: the evolution run failed (exit {status}); its directory is {out}", file=sys.stderr)
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
    if args.resume and bag.exists():
        shutil.rmtree(bag)  # an interrupted trial's bag: the trial is run again (it takes seconds)
    try:
        config = summary["config"]
        # under fixed scenarios, trial 0 of the scenario the run scored the tree on
        trial_seed = config["scenario_seed"] if config.get("scenarios") == "fixed" else summary["seed"]
        with signals_as_interrupts():
            record = run_recorded_trial(
                best["best_tree"],
                trial_seed,
                0,
                bag,
                log_dir=out / "logs" / "trial",
                profile=config.get("profile", DEFAULT_PROFILE),
            )
    except (GraphError, BagError, TrialFailedError) as error:
        print(f"main: the trial through the node graph failed: {error}", file=sys.stderr)
        return 1
    except KeyboardInterrupt as error:
        print(f"main: interrupted; continue with: {again}", file=sys.stderr)
        return exit_status(error)
    animation = out / "best" / "food_trial.gif"
    try:
        write_animation(frames_from_bag(bag), animation)
    except AnimationError as error:
        print(f"main: the best tree's trial animation failed: {error}", file=sys.stderr)
        return 1
    finished = time.monotonic()

    values = dict(zip(OBJECTIVES, record.values[: len(OBJECTIVES)], strict=True))
    run_bag = (
        ""
        if on_cluster  # evolve records no run bag
        else f"  run bag (MCAP)   {out}/run.bag/  (every evaluation on /evaluations, archive progress on "
        "/progress)\n"
    )
    print(
        f"""
Done in {finished - started:.0f} s (evolution {evolved - started:.0f} s, trial through the graph {finished - evolved:.0f} s).

Run directory      {out}/
  summary          {out}/summary.json  (best fitness {best["best_fitness"]:.4f}, coverage {best["coverage"]:.4f}, QD score {best["qd_score"]:.4f}, held-out QD score {best["heldout_qd_score"]:.4f})
  repertoire       {out}/repertoire_food.json  (and one per objective: every tree was scored on all three)
  progress         {out}/progress.csv
  figures          {out}/figures/
  best trees       {out}/best/  (simplified; as evolved in best/food.original.txt)
  explorer         {out}/explorer.html  (open it in a browser: every bin's trees, values and trial)
  animation        {animation}  (the best tree's trial through the graph, one frame per step)
{run_bag}Best tree          {best.get("best_tree_simplified") or best["best_tree"]}  (simplified)
  as evolved       {best["best_tree"]}
Trial bag (MCAP)   {bag}/  (every topic of the graph; trial 0, food {values["food"]:.4f})
Node logs          {out}/logs/

Watch it in Foxglove:      open {bag}/ with the layout docs/foxglove_layout.json (docs/ros.md)
Replay it for ROS tools:   ws/run evolution_manager replay {bag}
Verify it reproduces:      ws/run evolution_manager replay {bag} --verify
Evolve more:               ws/run evolution_manager evolve --help
"""  # noqa: E501
    )
    return 0
