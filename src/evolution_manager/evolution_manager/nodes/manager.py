"""The evolution manager node: an algorithm of the evolution core, its batches evaluated by evaluator nodes.

    ws/run evolution_manager manager --algorithm qd --objective food --evaluations 5000 --seed 1 \\
        --out runs/qd --evaluators 2
    ws/run evolution_manager manager --out runs/qd --resume        # continue a killed or interrupted run

Node ``manager``. It takes the options of ``evolve`` and writes the same run directory (bit for bit the same
result files as ``evolve`` with the in-process evaluator), but evaluates over every ``EvaluateBatch`` action
server
of its ROS domain — on this machine or others — spreading each batch over them, re-sending the work of an
evaluator that vanishes or times out, and counting each evaluation once (``ServiceEvaluator``). With
``--evaluators K`` it starts K evaluator nodes itself (logs in ``<out>/logs/``); otherwise it uses the ones
it finds, waiting up to ``--wait`` seconds for ``--expect`` of them (default 1, or K).

The run is recorded to ``<out>/run.bag/`` (rosbag2, MCAP storage; ``run.resume-<k>.bag/`` for the k-th
resume): every evaluation on ``/evaluations`` and the archive's progress on ``/progress`` after each batch.

Parameters (ROS, read once at start; ``--ros-args -p timeout:=20``):
    chunk_size (int, 50): most requests in one goal sent to an evaluator.
    timeout (float, 60): seconds a chunk may take before its work is re-sent to another evaluator (longer
        when the chunk's expected time is: 10 times it).
    first_timeout (float, 300): the same for an evaluator's first chunk (it compiles its kernels).
    discovery_period (float, 1): seconds between looks for evaluators.

Publishers:
    /evaluations (swarm_msgs/EvaluationResult): every evaluation, in order (tree, seed, the six values).
    /progress (swarm_msgs/ArchiveProgress): after each batch, one per objective: evaluations, best fitness,
        coverage and QD score of that objective's grid.

Action clients:
    every action server of type swarm_msgs/action/EvaluateBatch in the domain (``/<evaluator>/evaluate``);
    the goals still running when the manager stops (interrupted, or failed) are cancelled.

Exit status: 0 done; 1 no evaluator or an evaluation that could not be finished; 2 bad options; 130
interrupted (continue with ``--resume``).
"""

from __future__ import annotations

import argparse
import os
import sys
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

import rclpy
from rclpy.executors import ExternalShutdownException, SingleThreadedExecutor
from rclpy.node import Node
from rclpy.publisher import Publisher
from rclpy.serialization import serialize_message
from rclpy.utilities import remove_ros_args

from evolution_manager import cli
from evolution_manager.bags import BagError, BagRecorder
from evolution_manager.config import RunConfig
from evolution_manager.dispatch import DispatchError, Timeouts
from evolution_manager.errors import EvolutionError
from evolution_manager.files import read_json_object
from evolution_manager.graph import Graph, GraphError
from evolution_manager.nodes.service_evaluator import ServiceEvaluator, ServiceSettings
from evolution_manager.outputs import write_results
from evolution_manager.primitives import OBJECTIVES
from evolution_manager.run import Run, RunDirectory
from swarm_msgs.msg import ArchiveProgress, EvaluationResult
from swarm_ros.parameters import declare_dataclass
from swarm_sim.evaluation import Evaluator
from swarm_sim.result_messages import evaluation_fields

EXIT_FAILED = 1
EVALUATIONS_TOPIC = "/evaluations"
PROGRESS_TOPIC = "/progress"
EVALUATION_TYPE = "swarm_msgs/msg/EvaluationResult"
PROGRESS_TYPE = "swarm_msgs/msg/ArchiveProgress"


def build_parser() -> argparse.ArgumentParser:
    """The ``manager`` command line: ``evolve``'s run options, and where the evaluators come from."""
    parser = cli.Parser(prog="manager", description=__doc__.split("\n")[0])
    parser.add_argument("--algorithm", choices=cli.ALGORITHMS, help="gp (GP_o), gp-fnd (GP_fnd) or qd")
    parser.add_argument("--objective", choices=cli.OBJECTIVES, help="the objective of gp and qd")
    parser.add_argument("--evaluations", type=cli.positive_int, help="evaluation budget (default: as evolve)")
    parser.add_argument("--seed", type=cli.seed_int, help="run seed in [0, 2**63 - 1] (default 0)")
    parser.add_argument("--trials", type=cli.positive_int, help="trials per evaluation (default 10)")
    parser.add_argument("--out", type=Path, required=True, help="run directory (new, unless --resume)")
    parser.add_argument("--resume", action="store_true", help="continue the run in --out")
    parser.add_argument(
        "--evaluators", type=int, default=0, metavar="K", help="start K evaluator nodes (default 0)"
    )
    parser.add_argument(
        "--expect",
        type=cli.positive_int,
        metavar="N",
        help="evaluators to wait for before starting (default 1 or K)",
    )
    parser.add_argument(
        "--wait",
        type=cli.seconds,
        default=120.0,
        metavar="SECONDS",
        help="how long to wait for evaluators, at the start and whenever none is left (default 120)",
    )
    parser.add_argument(
        "--checkpoint-every", type=cli.seconds, default=30.0, metavar="SECONDS", help="default 30"
    )
    parser.add_argument("--no-progress", action="store_true", help="no progress bar")
    parser.add_argument("--no-figures", action="store_true", help="write results but no figures")
    return parser


@dataclass(frozen=True)
class ManagerParameters:
    """The node's ROS parameters (read-only, read once at start; checked by ``ServiceSettings``)."""

    chunk_size: int = 50
    """Most requests in one goal sent to an evaluator."""
    timeout: float = 60.0
    """Seconds a chunk may take before its work is re-sent elsewhere (or 10 times its expected time)."""
    first_timeout: float = 300.0
    """The same for an evaluator's first chunk (it compiles its kernels)."""
    discovery_period: float = 1.0
    """Seconds between looks for evaluators."""


class ManagerNode(Node):
    """Declares the parameters and publishers; the run itself is driven by :func:`manage`."""

    def __init__(self) -> None:
        super().__init__("manager")
        self.parameters = declare_dataclass(self, ManagerParameters(), read_only=True)
        self.evaluations = self.create_publisher(EvaluationResult, EVALUATIONS_TOPIC.lstrip("/"), 100)
        self.progress = self.create_publisher(ArchiveProgress, PROGRESS_TOPIC.lstrip("/"), 10)


class _Remember:
    """An evaluator that keeps the last batch it evaluated, for the recording after each batch."""

    def __init__(self, evaluator: ServiceEvaluator) -> None:
        self.evaluator = evaluator
        self.requests: Sequence = ()
        self.results: Sequence = ()

    def evaluate(self, requests: Sequence) -> list:
        self.requests = requests
        self.results = self.evaluator.evaluate(requests)
        return list(self.results)


class RunRecording:
    """Publishes and records, after each batch, its evaluations and the grids' progress."""

    def __init__(self, node: ManagerNode, recorder: BagRecorder, config: RunConfig) -> None:
        self.node = node
        self.recorder = recorder
        self.config = config
        self._last_ns = 0

    def _stamp(self) -> int:
        self._last_ns = max(self._last_ns + 1, self.node.get_clock().now().nanoseconds)
        return self._last_ns

    def _emit(self, publisher: Publisher, topic: str, msgtype: str, msg: object) -> None:
        publisher.publish(msg)
        self.recorder.write_cdr(topic, msgtype, self._stamp(), serialize_message(msg))

    def batch(self, run: Run, requests: Sequence, results: Sequence) -> None:
        """Record the batch just told to the algorithm (``run.evaluations`` already counts it)."""
        objective = self.config.objective or OBJECTIVES[0]
        for request, result in zip(requests, results, strict=True):
            fields = evaluation_fields(request.tree, request.seed, request.trials, result, objective)
            msg = EvaluationResult(**fields)
            self._emit(self.node.evaluations, EVALUATIONS_TOPIC, EVALUATION_TYPE, msg)
        for name in OBJECTIVES:
            grid = run.passive[name]
            msg = ArchiveProgress(
                algorithm=self.config.algorithm,
                objective=name,
                evaluations=run.evaluations,
                best=float("nan") if grid.best_value is None else grid.best_value,
                coverage=grid.coverage,
                qd_score=grid.qd_score,
            )
            msg.header.stamp = self.node.get_clock().now().to_msg()
            self._emit(self.node.progress, PROGRESS_TOPIC, PROGRESS_TYPE, msg)


def bag_path(out: Path) -> Path:
    """``run.bag`` for a new run; ``run.resume-<k>.bag`` for the k-th resume."""
    path, k = out / "run.bag", 0
    while path.exists():
        k += 1
        path = out / f"run.resume-{k}.bag"
    return path


def _open_run(args: argparse.Namespace, evaluator: Evaluator) -> Run:
    directory = RunDirectory(args.out)
    if args.resume:
        if not directory.started():
            raise cli.UsageError(f"--resume: {args.out} holds no run to continue (no config.json)")
        cli.check_resume_options(args, RunConfig.from_json(read_json_object(directory.config)))
        return Run.resume(args.out, evaluator)
    if directory.started():
        raise cli.UsageError(
            f"{args.out} already holds a run: add --resume to continue it, or use another --out"
        )
    return Run.start(cli.config_from_args(args), args.out, evaluator)


def manage(argv: Sequence[str]) -> int:
    """Run the manager with ``argv`` (ROS arguments included); return the exit status."""
    try:
        args = build_parser().parse_args(remove_ros_args(list(argv))[1:])
        if args.evaluators < 0:
            raise cli.UsageError(f"--evaluators must be 0 or more, got {args.evaluators}")
        if not args.resume:
            cli.config_from_args(args)  # refuse bad options before anything starts
    except (cli.UsageError, EvolutionError) as error:
        print(f"manager: error: {error}", file=sys.stderr)
        return cli.EXIT_USAGE
    rclpy.init(args=list(argv))
    node = ManagerNode()
    executor = SingleThreadedExecutor()
    executor.add_node(node)
    logger = node.get_logger()
    p = node.parameters

    def log(level: str, text: str) -> None:  # rclpy wants one severity per call site
        if level == "warn":
            logger.warning(text)
        else:
            logger.info(text)

    try:
        settings = ServiceSettings(
            max_chunk=p.chunk_size,
            timeouts=Timeouts(timeout=p.timeout, first_timeout=p.first_timeout),
            discovery_period=p.discovery_period,
            wait=args.wait,
            objective=args.objective or OBJECTIVES[0],
        )
        services = ServiceEvaluator(node, executor, settings, log)
    except ValueError as error:
        print(f"manager: error: {error} (see the node's parameters and --wait)", file=sys.stderr)
        executor.shutdown()
        node.destroy_node()
        rclpy.try_shutdown()
        return cli.EXIT_USAGE
    evaluator = _Remember(services)
    graph = Graph(int(os.environ.get("ROS_DOMAIN_ID", "0")))
    try:
        try:
            run = _open_run(args, evaluator)
        except OSError as error:  # an --out that cannot be created or written
            raise cli.UsageError(f"{args.out}: {error.strerror or error}") from None
        if args.evaluators:
            graph.log_dir = Path(args.out) / "logs"
            for i in range(1, args.evaluators + 1):
                graph.start(f"evaluator_{i}", "swarm_sim", "evaluator", node_name=f"manager_evaluator_{i}")
        expect = args.expect or max(args.evaluators, 1)
        ready = services.wait_for(expect, args.wait)
        graph.check()
        if not ready:
            raise DispatchError(
                f"no evaluator service found in ROS domain {graph.domain} within {args.wait:.0f} s: start "
                "evaluator nodes (ws/run swarm_sim evaluator) or use --evaluators K"
            )
        logger.info(f"ready: {len(ready)} evaluator(s): {', '.join(ready)}; run directory {args.out}")
        return _execute(args, node, run, evaluator)
    except (DispatchError, GraphError, BagError) as error:
        print(f"manager: error: {error}; continue with --resume --out {args.out}", file=sys.stderr)
        return EXIT_FAILED
    except (cli.UsageError, EvolutionError) as error:
        print(f"manager: error: {error}", file=sys.stderr)
        return cli.EXIT_USAGE
    except (KeyboardInterrupt, ExternalShutdownException):
        print(f"manager: interrupted; continue with: manager --out {args.out} --resume", file=sys.stderr)
        return cli.EXIT_INTERRUPTED
    finally:
        graph.stop()
        services.close()
        executor.shutdown()
        node.destroy_node()
        rclpy.try_shutdown()


def _execute(args: argparse.Namespace, node: ManagerNode, run: Run, evaluator: _Remember) -> int:
    bar = cli.progress_bar(run.config, run.evaluations, not args.no_progress)
    with BagRecorder(bag_path(Path(args.out))) as recorder:
        recording = RunRecording(node, recorder, run.config)

        def on_batch(done: int, total: int) -> None:
            recording.batch(run, evaluator.requests, evaluator.results)
            if bar is not None:
                bar.update(done - bar.n)

        try:
            run.execute(on_batch=on_batch, checkpoint_interval=args.checkpoint_every)
        finally:
            if bar is not None:
                bar.close()
    write_results(run, with_figures=not args.no_figures)
    dispatcher = evaluator.evaluator.dispatcher
    node.get_logger().info(
        f"{run.config.label}: {run.evaluations} evaluations in {args.out} "
        f"(requests re-sent: {dispatcher.resent}, duplicate results ignored: {dispatcher.duplicates})"
    )
    return 0


def main() -> None:
    """Console entry point of ``manager``."""
    sys.exit(manage(sys.argv))
