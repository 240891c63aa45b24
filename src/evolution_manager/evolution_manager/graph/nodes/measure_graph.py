"""Measure trials through the full node graph: simulated seconds per wall-clock second.

``ws/run evolution_manager measure-graph [--trials 5] [--seed 1]`` starts the simulator and nine footbot
controller processes once (the start-up is timed apart), runs trials of a few trees through them, and reports
wall time per trial and simulated seconds per wall second, with and without recording every topic to a bag.
It is a measurement, not a test: the figures depend on the machine and its load. Measured on the 2-core
development machine: 1.4 s a trial (14 simulated seconds per wall second), 2.0 s recorded (the recorder
writes the bytes it receives, but still takes every message); before the simulator dropped rclpy's default
QoS event handlers (``swarm_ros.qos``), 6.6 s and 5.7 s.
"""

from __future__ import annotations

import argparse
import statistics
import sys
import tempfile
import time
from collections.abc import Sequence
from pathlib import Path

from bt_controller.language import random_trees
from bt_controller.robot import timeline
from evolution_manager.graph.nodes.trial import TrialGraph
from swarm_sim.model import DEFAULT

SIMULATED_SECONDS = timeline.trial_steps(DEFAULT.timeline) * DEFAULT.step_dt
"""Simulated time of one trial (20 s under ``paper``, 22 s under ``clean``). Only the first trial of each
chain is timed, so that each run is one trial long."""
FIRST_TRIALS = timeline.chain_length(DEFAULT.timeline)
"""Trials between two chain starts: trial k * FIRST_TRIALS is the first of its chain."""


def main(argv: Sequence[str] | None = None) -> int:
    """``measure-graph``: print the measurement."""
    parser = argparse.ArgumentParser(prog="measure-graph", description=__doc__.split("\n\n")[0])
    parser.add_argument("--trials", type=int, default=5, help="trials of each kind to time (default 5)")
    parser.add_argument("--seed", type=int, default=1, help="seed of the trees and trials (default 1)")
    args = parser.parse_args(sys.argv[1:] if argv is None else argv)
    if args.trials < 1:
        print(f"measure-graph: --trials must be at least 1, got {args.trials}", file=sys.stderr)
        return 2
    trees = random_trees(seed=args.seed, count=args.trials)
    started = time.monotonic()
    with TrialGraph(timeout=120.0) as graph, tempfile.TemporaryDirectory() as bags:
        graph.run(trees[0], args.seed, 0)  # the first trial also pays for discovery and warm caches
        ready = time.monotonic()
        plain, recorded = [], []
        for k, tree in enumerate(trees):
            t0 = time.monotonic()
            graph.run(tree, args.seed, k * FIRST_TRIALS)
            plain.append(time.monotonic() - t0)
            t0 = time.monotonic()
            graph.run(tree, args.seed, k * FIRST_TRIALS, Path(bags) / f"trial_{k}")
            recorded.append(time.monotonic() - t0)
    print(f"graph start-up and first trial: {ready - started:.1f} s (10 node processes)")
    for name, times in (("trial", plain), ("trial recorded to MCAP", recorded)):
        median = statistics.median(times)
        print(
            f"{name:24s} median {median:5.2f} s wall for {SIMULATED_SECONDS:.0f} s simulated: "
            f"{SIMULATED_SECONDS / median:5.2f} simulated s per wall s (over {len(times)} trials)"
        )
    return 0
