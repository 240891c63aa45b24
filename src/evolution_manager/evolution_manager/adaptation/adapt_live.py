"""``adapt-live``: a fault strikes a running swarm, and an adaptation node swaps trees into its robots
until the swarm's performance is back.

    ws/run evolution_manager adapt-live --repertoire RUN_DIR --objective food \\
        --faults "1:wheel-reversed 4:wheel-reversed" --fault-at 30 --duration 150 --out DIR \\
        [--window 10] [--lead 0.125] [--budget 8] [--stop-fraction 0.9] [--swap faulty|all] [--seed S] \\
        [--robots N] [--every 8] [--watch]

The node graph (the simulator node and one footbot controller node per robot, in lockstep) runs one trial of
``--duration`` simulated seconds of the repertoire's task (its world), every robot on the repertoire's best
tree, under the repertoire's model profile. A repertoire built of a primitive library (its run's copy,
``library.json``) sends its trees with the primitives written out, so the controllers need no library. At
``--fault-at`` seconds the faults strike (``ROBOT:KIND`` pairs, kinds of ``swarm_sim.model.faults``), injected
through the simulator's ``inject_faults`` service, which announces them on its ``faults`` topic. The
adaptation node (``graph.nodes.adaptation_node``) measures every window of ``--window`` simulated seconds with
the objective, from what the robots answer each step (``adaptation.live.window_measure``); when the first
window after the fault falls below ``--stop-fraction`` of the mean of the last ``--reference`` windows before
it (with ``--watch``, or any later window, when the first was still at the target), it tries trees of the
repertoire, one window each, chosen by Intelligent Trial and Error, loading each into the faulty robots
(``--swap all``: every robot) through their ``load_tree`` service from ``--lead`` seconds after the window
that chose it (the next step by default). The simulator is held at each window's end (its ``hold_step``
service) until the node has decided and every swapped robot has its tree, so a run makes the same swaps on any
machine, however loaded. It stops at the first window back at the target, or after ``--budget`` trials with
the best tree tried (``adaptation.live``).

Writes ``DIR/live.bag`` (MCAP: the trial's state, readings and answers, ``/faults``, ``/adaptation`` and the
trial's result), ``DIR/adaptation_live.json`` (settings, every window, fault and swap, why it stopped) and
``DIR/live.gif`` (every ``--every``-th step; faulty robots crossed, swapped robots ringed, the last windows
and swaps beside; ``--every 0``: none). Bad options print one line and exit with status 2, as does a graph
that fails; an ``--out`` that already holds a live adaptation is never overwritten.
"""

from __future__ import annotations

import argparse
import math
import sys
import time
from collections.abc import Sequence
from dataclasses import asdict, replace
from pathlib import Path

from bt_controller.robot import timeline
from evolution_manager.adaptation.live import MEASURABLE, SWAPS, LiveAdaptation, LiveSettings, window_measure
from evolution_manager.adaptation.search import load_candidates, repertoire_setting, written_out
from evolution_manager.arguments import (
    EXIT_USAGE,
    Parser,
    finite,
    non_negative_int,
    positive_int,
    seed_in_range,
)
from evolution_manager.errors import AnimationError, EvolutionError, GraphError, TrialFailedError, UsageError
from evolution_manager.files import write_json
from evolution_manager.processes import exit_status, signals_as_interrupts
from evolution_manager.recording.bags import BagError
from swarm_ros.safe_paths import refuse_links
from swarm_sim.errors import ConfigError
from swarm_sim.model import Config, parse_fault_pairs

RESULT = "adaptation_live.json"
BAG = "live.bag"
GIF = "live.gif"


def build_parser() -> Parser:
    """The ``adapt-live`` command line."""
    seconds = finite(0.0, strictly=True, what="number of seconds")
    parser = Parser(prog="adapt-live", description=__doc__.split("\n")[0])
    parser.add_argument("--repertoire", type=Path, required=True, help="a run directory holding repertoires")
    parser.add_argument("--objective", choices=MEASURABLE, required=True, help="the task's measure")
    parser.add_argument(
        "--faults", required=True, help='faults as ROBOT:KIND pairs, e.g. "1:wheel-reversed 4:rab-mirrored"'
    )
    parser.add_argument("--fault-at", type=seconds, required=True, help="simulated seconds before the fault")
    parser.add_argument("--duration", type=seconds, required=True, help="the trial's simulated seconds")
    parser.add_argument("--out", type=Path, required=True, help="output directory (no live adaptation in it)")
    parser.add_argument("--window", type=seconds, default=10.0, help="seconds per measured window (10)")
    parser.add_argument(
        "--lead", type=seconds, default=0.125, help="seconds from a window's end to its swap (0.125: a step)"
    )
    parser.add_argument("--budget", type=positive_int, default=8, help="most trials after the fault (8)")
    parser.add_argument(
        "--stop-fraction", type=finite(0.0, strictly=True, what="fraction"), default=0.9, help="target (0.9)"
    )
    parser.add_argument(
        "--reference", type=positive_int, default=2, help="windows before the fault that set the target (2)"
    )
    parser.add_argument(
        "--watch",
        action="store_true",
        help="after a fault that left the swarm at the target, adapt at the first later window below it",
    )
    parser.add_argument("--swap", choices=SWAPS, default="faulty", help="robots that get the trees (faulty)")
    parser.add_argument("--seed", type=seed_in_range, default=0, help="the trial's seed (0)")
    parser.add_argument("--robots", type=positive_int, default=None, help="swarm size (the task's: 9)")
    parser.add_argument("--every", type=non_negative_int, default=8, help="GIF: every N-th step (8; 0: none)")
    parser.add_argument("--timeout", type=seconds, default=60.0, help="seconds to wait for any step (60)")
    return parser


def steps_of(seconds: float, config: Config) -> int:
    """Whole sensing steps in ``seconds`` of simulated time (at least 1)."""
    return max(1, round(seconds / config.step_dt))


def live_adaptation(args: argparse.Namespace) -> dict[str, object]:
    """Run the live adaptation the parsed command line ``args`` asks for; return the result document."""
    setting = repertoire_setting(args.repertoire)
    profile = setting.config.profile
    # a repertoire built of a library's primitives: its trees go to the robots with the primitives written out
    candidates = written_out(
        load_candidates(args.repertoire, args.objective, setting.library), setting.library
    )
    task = setting.config.task
    base = task.config(profile)
    robots = args.robots or base.n_robots
    ticks = max(1, round(args.duration / (base.steps_per_tick * base.step_dt)))
    task = replace(task, trials=replace(task.trials, ticks=ticks))
    config = replace(task.config(profile), n_robots=robots)
    try:
        parse_fault_pairs(args.faults, robots)
    except ConfigError as error:
        raise UsageError(f"--faults: {error}") from None
    settings = LiveSettings(
        window=steps_of(args.window, config),
        lead=steps_of(args.lead, config),
        budget=args.budget,
        stop_fraction=args.stop_fraction,
        swap=args.swap,
        reference=args.reference,
        watch=args.watch,
    )
    last_step = timeline.trial_steps(config.timeline)
    fault_step = steps_of(args.fault_at, config) + 1
    if fault_step > last_step:
        raise UsageError(f"--fault-at {args.fault_at} s is not before the trial's end ({args.duration} s)")
    if fault_step <= settings.window:
        raise UsageError(
            f"--fault-at {args.fault_at} s strikes before the first window ({args.window} s) has ended: "
            "there is no performance to recover to"
        )
    core = LiveAdaptation(candidates, robots, settings)
    print(
        f"adapt-live: {robots} robots, {args.duration} s ({last_step} steps); faults {args.faults!r} from "
        f"step {fault_step}; windows of {settings.window} steps; {len(candidates)} trees in the repertoire",
        file=sys.stderr,
        flush=True,
    )
    # rclpy: the adaptation is ROS-free but its node
    from evolution_manager.graph.nodes.adaptation_node import run_live_graph

    started = time.monotonic()
    run = run_live_graph(
        core,
        window_measure,
        objective=args.objective,
        task=task,
        profile=profile,
        robots=robots,
        seed=args.seed,
        faults=args.faults,
        fault_step=fault_step,
        bag_path=args.out / BAG,
        log_dir=args.out / "logs",
        timeout=args.timeout,
    )
    return {
        "repertoire": str(args.repertoire),
        "objective": args.objective,
        "profile": profile,
        "task": task.name,
        "seed": args.seed,
        "robots": robots,
        "duration_s": args.duration,
        "steps": last_step,
        "faults": args.faults,
        "fault_step": core.fault_step,
        "faulty": list(core.faulty),
        "settings": asdict(settings),
        "target": None if math.isnan(core.target) else core.target,
        "unchanged": None if math.isnan(core.unchanged) else core.unchanged,
        "trials_used": core.trial,
        "stopped": run.note,
        "swaps_retimed": run.retimed,
        "trees": list(core.trees),
        "repertoire_best": {"tree": core.best.tree, "prior": core.best.prior, "bin": list(core.best.bin)},
        "windows": [asdict(w) for w in core.windows],
        "events": run.events,
        "trial_values": list(run.record.values),
        "wall_seconds": round(time.monotonic() - started, 1),
    }


def main(argv: Sequence[str] | None = None) -> int:
    """``adapt-live``; the exit status."""
    try:
        args = build_parser().parse_args(sys.argv[1:] if argv is None else argv)
        for name in (RESULT, GIF):
            refuse_links(args.out / name)
        if (args.out / RESULT).exists():
            raise UsageError(f"{args.out} already holds a live adaptation ({RESULT}): choose another --out")
        args.out.mkdir(parents=True, exist_ok=True)
        with signals_as_interrupts():
            document = live_adaptation(args)
        write_json(args.out / RESULT, document)
        if args.every:
            # late: the animation loads matplotlib and Pillow (about 1.5 s), wanted only with --every
            from evolution_manager.viewing.animate import write_animation
            from evolution_manager.viewing.frames import frames_from_bag

            write_animation(frames_from_bag(args.out / BAG), args.out / GIF, fps=8, every=args.every)
    except (
        UsageError,
        EvolutionError,
        BagError,
        AnimationError,
        GraphError,
        TrialFailedError,
        OSError,
        ValueError,
    ) as error:
        print(f"adapt-live: error: {error}", file=sys.stderr)
        return EXIT_USAGE
    except KeyboardInterrupt as error:
        print("adapt-live: interrupted", file=sys.stderr)
        return exit_status(error)
    print(
        f"adapt-live: {document['trials_used']} trials; {document['stopped']}; wrote {args.out / RESULT}, "
        f"{args.out / BAG}" + (f", {args.out / GIF}" if args.every else "")
    )
    return 0
