"""Run one trial through the full node graph and record it.

``ws/run evolution_manager trial --tree TREE --seed S [--trial K] --bag DIR`` starts the simulator and one
footbot controller per robot as separate processes in a ROS domain of their own, loads the tree into every
controller, runs trial K of seed S in lockstep, records every topic of the graph to a rosbag2 bag with MCAP
storage, and prints the same JSON as ``ws/run swarm_sim evaluate --per-trial`` for that trial.
"""

from __future__ import annotations

import argparse
import contextlib
import sys
import tempfile
import time
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

import numpy as np
import rclpy
from rclpy.executors import SingleThreadedExecutor
from rclpy.node import Node
from rclpy.signals import SignalHandlerOptions

from bt_controller.errors import TreeError
from bt_controller.nodes.isolation import reserved_domain
from bt_controller.tree import parse, to_text
from evolution_manager.bags import BagError, BagRecorder
from evolution_manager.errors import TrialFailedError
from evolution_manager.graph import Graph, GraphError, start_trial_graph
from evolution_manager.nodes.recorder import GraphRecorder, trial_topics
from evolution_manager.reproduce import RESULT_TOPIC
from swarm_msgs.msg import TreeStatus, TrialStart
from swarm_msgs.srv import LoadTree, RunTrial
from swarm_sim.cli import evaluation_json
from swarm_sim.config import DEFAULT
from swarm_sim.trial_data import VALUE_NAMES, TrialRecord


def expected_messages(robots: int) -> dict[str, int]:
    """How many messages each topic of a trial graph (``trial_topics``) carries in one trial."""
    p = DEFAULT.params()
    steps = p.settle_steps + p.ticks * p.steps_per_tick
    per_trial = {TrialStart: 1, TreeStatus: p.ticks}
    return {topic: per_trial.get(msg_class, steps) for topic, msg_class in trial_topics(robots)}


class TrialRunner:
    """A client node that loads trees into the controllers and asks the simulator for trials."""

    def __init__(self, context: rclpy.Context, graph: Graph, robots: int, timeout: float) -> None:
        self.graph = graph
        self.robots = robots
        self.timeout = timeout
        self.node = Node("trial_runner", context=context)
        self.executor = SingleThreadedExecutor(context=context)
        self.executor.add_node(self.node)
        self.load_clients: list[rclpy.client.Client] = [
            self.node.create_client(LoadTree, f"/footbot_{i}/load_tree") for i in range(robots)
        ]
        self.run_client: rclpy.client.Client = self.node.create_client(RunTrial, "/simulator/run_trial")

    def close(self) -> None:
        self.executor.shutdown()
        self.node.destroy_node()

    def spin_until(self, done: Callable[[], bool], what: str, timeout: float | None = None) -> None:
        """Spin until ``done()``; raise ``TrialFailedError`` naming ``what`` on timeout or a dead node."""
        deadline = time.monotonic() + (self.timeout if timeout is None else timeout)
        while not done():
            self.graph.check()
            if time.monotonic() > deadline:
                raise TrialFailedError(f"timed out waiting for {what}")
            self.executor.spin_once(timeout_sec=0.05)

    def spin_for(self, seconds: float) -> None:
        """Spin for ``seconds``."""
        deadline = time.monotonic() + seconds
        while time.monotonic() < deadline:
            self.executor.spin_once(timeout_sec=0.05)

    def call(self, client: rclpy.client.Client, request: object, what: str) -> Any:  # an untyped ROS response
        self.spin_until(client.service_is_ready, f"the {client.srv_name} service")
        future = client.call_async(request)
        self.spin_until(future.done, what)
        return future.result()

    def load_tree(self, tree_text: str) -> None:
        for i, client in enumerate(self.load_clients):
            response = self.call(client, LoadTree.Request(tree=tree_text), f"footbot_{i} to load the tree")
            if not response.success:
                raise TrialFailedError(f"footbot_{i} refused the tree: {response.message}")

    def run_trial(self, seed: int, trial: int) -> TrialRecord:
        request = RunTrial.Request(seed=seed, trial=trial, arena_configuration=-1)
        response = self.call(self.run_client, request, f"trial {trial} of seed {seed}")
        if not response.success:
            raise TrialFailedError(f"the simulator could not run the trial: {response.message}")
        return TrialRecord(
            trial=trial,
            gap=DEFAULT.gap(trial),
            values=tuple(getattr(response, name) for name in VALUE_NAMES),
            start_poses=np.array([[p.x, p.y, p.theta] for p in response.start_poses]),
            end_poses=np.array([[p.x, p.y, p.theta] for p in response.end_poses]),
        )


class TrialGraph:
    """A running trial graph (simulator and one controller process per robot, in a ROS domain of their own)
    that runs any number of trials, each optionally recorded to a bag of its own. A context manager."""

    def __init__(self, *, robots: int = 9, timeout: float = 60.0) -> None:
        self.robots = robots
        self.timeout = timeout
        self._stack = contextlib.ExitStack()
        self.runner: TrialRunner | None = None
        self.graph: Graph | None = None

    def __enter__(self) -> TrialGraph:
        stack = self._stack.__enter__()
        try:
            domain = stack.enter_context(reserved_domain())
            logs = Path(stack.enter_context(tempfile.TemporaryDirectory(prefix="swarm-trial-logs-")))
            self.graph = stack.enter_context(Graph(domain, log_dir=logs))
            start_trial_graph(self.graph, self.robots)
            context = rclpy.Context()
            rclpy.init(context=context, domain_id=domain, signal_handler_options=SignalHandlerOptions.NO)
            stack.callback(rclpy.try_shutdown, context=context)
            self.runner = TrialRunner(context, self.graph, self.robots, self.timeout)
            stack.callback(self.runner.close)
        except BaseException:
            stack.close()
            raise
        return self

    def __exit__(self, *exc_info: Any) -> None:  # (type, value, traceback), passed on as received
        self._stack.__exit__(*exc_info)

    def run(self, tree_text: str, seed: int, trial: int, bag_path: Path | None = None) -> TrialRecord:
        """Run trial ``trial`` of ``seed`` with ``tree_text`` on every robot; record it to ``bag_path`` when
        given (a new directory); return its record."""
        runner = self.runner
        if runner is None:
            raise RuntimeError("the trial graph is not started: use it as a context manager")
        runner.load_tree(tree_text)
        if bag_path is None:
            return runner.run_trial(seed, trial)
        node = Node("trial_recorder", context=runner.node.context)
        runner.executor.add_node(node)
        try:
            with BagRecorder(bag_path) as bag:
                recorder = GraphRecorder(node, bag, trial_topics(self.robots))
                runner.spin_until(lambda: recorder.all_publishers_seen(node), "the graph's publishers")
                runner.spin_for(0.5)  # let the publishers match the new subscriptions too
                record = runner.run_trial(seed, trial)
                expected = expected_messages(self.robots)
                runner.spin_until(
                    lambda: all(recorder.counts[t] >= n for t, n in expected.items()),
                    "the last messages",
                    10.0,
                )
                write_result(bag, tree_text, seed, record, recorder.last_stamp + 1)
            return record
        finally:
            runner.executor.remove_node(node)
            node.destroy_node()


def run_recorded_trial(
    tree_text: str, seed: int, trial: int, bag_path: Path, *, robots: int = 9, timeout: float = 60.0
) -> TrialRecord:
    """Run trial ``trial`` of ``seed`` with ``tree_text`` through a fresh node graph, recording it to
    ``bag_path``; return its record."""
    with TrialGraph(robots=robots, timeout=timeout) as graph:
        return graph.run(tree_text, seed, trial, bag_path)


def write_result(bag: BagRecorder, tree_text: str, seed: int, record: TrialRecord, stamp_ns: int) -> None:
    """Close the trial's bag with its result (tree, seed and the six values), stamped ``stamp_ns``."""
    values = dict(zip(VALUE_NAMES, record.values, strict=True))
    message = bag.message(
        "swarm_msgs/msg/EvaluationResult",
        tree=tree_text,
        seed=seed,
        trials=1,
        ok=True,
        error="",
        fitness=values["food"],
        **values,
    )
    bag.write(RESULT_TOPIC, message, stamp_ns)


def main(argv: Sequence[str] | None = None) -> int:
    """``trial``: one trial through the node graph, recorded; prints the trial's JSON."""
    parser = argparse.ArgumentParser(prog="trial", description=__doc__.split("\n\n")[1])
    parser.add_argument("--tree", required=True, help="the tree as text, or a file holding it")
    parser.add_argument("--seed", type=int, default=0, help="seed of the evaluation (default 0)")
    parser.add_argument("--trial", type=int, default=0, help="index of the trial (default 0)")
    parser.add_argument("--bag", required=True, type=Path, help="new bag directory to record the trial to")
    parser.add_argument(
        "--timeout", type=float, default=60.0, help="seconds to wait for any step of the graph"
    )
    args = parser.parse_args(sys.argv[1:] if argv is None else argv)
    text = Path(args.tree).read_text() if Path(args.tree).is_file() else args.tree
    try:
        tree = parse(text)
        if args.trial < 0:
            raise ValueError(f"--trial must be a non-negative integer, got {args.trial}")
        if args.bag.exists():
            raise BagError(f"refusing to overwrite {args.bag}: choose a new bag directory")
        record = run_recorded_trial(to_text(tree), args.seed, args.trial, args.bag, timeout=args.timeout)
    except (TreeError, ValueError, BagError, GraphError, TrialFailedError) as error:
        print(f"trial: {error}", file=sys.stderr)
        return 2
    print(evaluation_json(to_text(tree), args.seed, 1, record.values, [record]))
    print(f"trial: recorded to {args.bag}", file=sys.stderr)
    return 0
