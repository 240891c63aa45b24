"""Benchmark of the compiled interpreter (``ws/run bt_controller bench``); a benchmark, never a test.

Measures robot-ticks per second of the compiled interpreter on random trees of 10, 30 and 100 nodes (one
core: the kernel is serial), of the reference interpreter on a sample of the same robots, and their ratio.
``--agreement N`` also checks the two interpreters tick for tick on N more random trees. ``--parser`` instead
times the parser and the XML importer on the pathological inputs of ``PATHOLOGICAL`` (which the fuzz tests
check for a tree or a documented error, untimed): each should take well under a second.
"""

from __future__ import annotations

import argparse
import sys
import time
from collections.abc import Callable
from typing import NamedTuple

import numpy as np

from bt_controller.errors import TreeError
from bt_controller.interpreters.agreement import check_random
from bt_controller.interpreters.compiled import N_COUNTS, new_memory, pack, run_ticks, run_ticks_kernel
from bt_controller.interpreters.semantics import ReferenceRobot
from bt_controller.language.formats import from_xml
from bt_controller.language.random_trees import random_blackboards, random_tree
from bt_controller.language.tree import parse
from bt_controller.validate import check_options

PATHOLOGICAL: tuple[tuple[str, Callable[[str], object], str], ...] = (
    ("1e6 open brackets", parse, "(" * 1_000_000),
    ("200,000 nested seq(", parse, "seq(" * 200_000),
    ("2e6 spaces then x", parse, " " * 2_000_000 + "x"),
    ("a seq of 300,000 children", parse, "seq(stop," + " stop," * 300_000),
    (
        "XML nested 50,000 deep",
        from_xml,
        "<root><BehaviorTree>" + "<Sequence>" * 50_000 + "</Sequence>" * 50_000 + "</BehaviorTree></root>",
    ),
    (
        "XML entity expansion",
        from_xml,
        '<?xml version="1.0"?><!DOCTYPE l [<!ENTITY a "aaaaaaaaaa"><!ENTITY b "&a;&a;&a;&a;&a;&a;">]>'
        "<root>&b;</root>",
    ),
    ("100,000 unclosed XML elements", from_xml, "<root>" * 100_000),
)
"""(what, function, input): inputs built to make a parser slow or deep."""


def parser_times() -> list[tuple[str, float, float, str]]:
    """(what, wall seconds, CPU seconds, outcome) of each ``PATHOLOGICAL`` input."""
    rows = []
    for what, function, text in PATHOLOGICAL:
        wall, cpu = time.perf_counter(), time.process_time()
        try:
            function(text)
            outcome = "a tree"
        except TreeError as error:
            outcome = type(error).__name__
        rows.append((what, time.perf_counter() - wall, time.process_time() - cpu, outcome))
    return rows


class Rates(NamedTuple):
    """Robot-ticks per second by wall-clock and by CPU time."""

    wall: float
    cpu: float


def _timed(function: Callable[..., object], *args: object) -> tuple[float, float]:
    """(wall seconds, this thread's CPU seconds) of one call; CPU time is steadier on a shared machine."""
    wall, cpu = time.perf_counter(), time.thread_time()
    function(*args)
    return time.perf_counter() - wall, time.thread_time() - cpu


def _compiled_rates(seed: int, size: int, n_trees: int, n_robots: int, n_ticks: int, repeats: int) -> Rates:
    rng = np.random.default_rng(seed)
    packed = pack([random_tree(rng, size) for _ in range(n_trees)])
    robot_tree = np.arange(n_robots, dtype=np.int64) % n_trees
    keys = rng.integers(0, 2**64, size=n_robots, dtype=np.uint64)
    boards = random_blackboards(rng, n_robots, n_ticks)
    run_ticks(packed, robot_tree[:1], keys[:1], boards[:1])  # compile or load the cache
    best_wall = best_cpu = np.inf
    for _ in range(repeats):
        memory = new_memory(packed, robot_tree)
        counts = np.zeros((n_robots, N_COUNTS), np.int64)
        status = np.empty((n_robots, n_ticks), np.int8)
        action = np.empty((n_robots, n_ticks), np.int8)
        wall, cpu = _timed(run_ticks_kernel, packed, robot_tree, memory, boards, keys, counts, status, action)
        best_wall, best_cpu = min(best_wall, wall), min(best_cpu, cpu)
    return Rates(n_robots * n_ticks / best_wall, n_robots * n_ticks / max(best_cpu, 1e-9))


def _reference_rates(seed: int, size: int, n_robots: int, n_ticks: int) -> Rates:
    rng = np.random.default_rng(seed)
    robots = [ReferenceRobot(random_tree(rng, size), int(k)) for k in rng.integers(0, 2**63, size=n_robots)]
    boards = random_blackboards(rng, n_robots, n_ticks).tolist()
    ReferenceRobot(parse("prob(stop, forward)"), 0).step(boards[0][0])  # load the draws' compiled code

    def run() -> None:
        for robot, robot_boards in zip(robots, boards, strict=True):
            for board in robot_boards:
                robot.step(board)

    wall, cpu = _timed(run)
    return Rates(n_robots * n_ticks / wall, n_robots * n_ticks / max(cpu, 1e-9))


def main(argv: list[str] | None = None) -> int:
    """Run the benchmark and print a table; exit 1 if an agreement run finds a difference."""
    parser = argparse.ArgumentParser(prog="bench", description=__doc__.split("\n\n")[0])
    parser.add_argument("--sizes", type=int, nargs="+", default=[10, 30, 100], help="tree sizes in nodes")
    parser.add_argument("--trees", type=int, default=256, help="distinct random trees per size")
    parser.add_argument("--robots", type=int, default=8192, help="robots ticked per repeat (compiled)")
    parser.add_argument("--ticks", type=int, default=40, help="ticks per robot (a trial has 40)")
    parser.add_argument("--repeats", type=int, default=5, help="timed repeats; the best is reported")
    parser.add_argument("--reference-robots", type=int, default=1000, help="robots ticked by the reference")
    parser.add_argument("--agreement", type=int, default=0, metavar="N", help="also check N random trees")
    parser.add_argument("--seed", type=int, default=1, help="seed of the random trees and blackboards")
    parser.add_argument(
        "--parser", action="store_true", help="time the parser on pathological inputs instead"
    )
    args = parser.parse_args(argv)
    if args.parser:
        for what, wall, cpu, outcome in parser_times():
            print(f"{what:32s} {cpu:6.3f} s CPU ({wall:6.3f} s wall): {outcome}")
        return 0
    for size in args.sizes:
        if size == 2 or size < 1:
            parser.error(f"no tree has {size} nodes")
    counts = ("trees", "robots", "ticks", "repeats", "reference_robots")
    try:
        check_options(
            args, {**{name: (1, None) for name in counts}, "agreement": (0, None), "seed": (0, None)}
        )
    except ValueError as error:
        parser.error(str(error))

    print(f"robot-ticks per second on one core: best of {args.repeats} repeats of {args.robots} robots")
    print(f"x {args.ticks} ticks over {args.trees} random trees; reference: {args.reference_robots} robots")
    print("rates from this thread's CPU time (from wall-clock time in brackets)")
    print(f"{'nodes':>5}  {'compiled, M/s':>22}  {'reference, k/s':>18}  {'ratio':>6}")
    for size in args.sizes:
        fast = _compiled_rates(args.seed, size, args.trees, args.robots, args.ticks, args.repeats)
        slow = _reference_rates(args.seed, size, args.reference_robots, args.ticks)
        print(
            f"{size:>5}  {fast.cpu / 1e6:>10.2f} ({fast.wall / 1e6:>6.2f} wall)"
            f"  {slow.cpu / 1e3:>7.1f} ({slow.wall / 1e3:>5.1f} wall)  {fast.cpu / slow.cpu:>5.0f}x",
            flush=True,
        )

    if args.agreement:
        chunk, checked, start = 2000, 0, time.perf_counter()
        while checked < args.agreement:
            n = min(chunk, args.agreement - checked)
            mismatch = check_random(seed=args.seed * 1_000_003 + checked, n_trees=n, n_ticks=args.ticks)
            if mismatch is not None:
                print(f"agreement: DIFFERENCE after {checked} trees: {mismatch}", flush=True)
                return 1
            checked += n
            print(f"agreement: {checked} trees x {args.ticks} ticks agree", file=sys.stderr, flush=True)
        print(f"agreement: {checked} random trees x {args.ticks} ticks: no difference "
              f"({time.perf_counter() - start:.0f} s)")  # fmt: skip
    return 0


if __name__ == "__main__":
    sys.exit(main())
