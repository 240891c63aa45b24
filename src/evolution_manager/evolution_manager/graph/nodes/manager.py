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
The bag is flushed every second and before every checkpoint, so a killed manager loses at most the last
second of it; a resume first cuts the bags back to the checkpoint (rewriting a killed segment as a whole
bag), so that together they hold every evaluation exactly once.

The run directory is locked (``<out>/.lock``) while a manager writes it: a second one exits at once naming
the first one's PID. The evaluator processes it starts die with it, whatever kills it, and one that dies
during the run is noticed at once, its work re-sent and a new one started in its place.

Parameters (ROS, read once at start; ``--ros-args -p timeout:=20``):
    chunk_size (int, 50): most requests in one goal sent to an evaluator.
    timeout (float, 3): seconds a chunk may take before its work is re-sent to another evaluator (longer
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

Exit status: 0 done; 1 no evaluator, an evaluation that could not be finished or a bag that could not be
written; 2 bad options, a damaged run directory or one in use by another process; 130 interrupted (SIGINT),
143 terminated (SIGTERM): continue with ``--resume``.
"""

from __future__ import annotations

import argparse
import os
import signal
import sys
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path

import rclpy
from rclpy.executors import ExternalShutdownException, SingleThreadedExecutor
from rclpy.node import Node
from rclpy.publisher import Publisher
from rclpy.serialization import deserialize_message, serialize_message
from rclpy.signals import SignalHandlerOptions
from rclpy.utilities import remove_ros_args

from evolution_manager.arguments import EXIT_IO, EXIT_USAGE, Parser, positive_int, seconds, seed_int
from evolution_manager.errors import EvolutionError, UsageError, WriteError
from evolution_manager.evolution.deap_trees import OBJECTIVES
from evolution_manager.evolution.options import (
    add_scenario_options,
    add_task_options,
    check_resume_options,
    config_from_args,
    library_from_args,
    progress_bar,
)
from evolution_manager.evolution.run import Run, RunDirectory
from evolution_manager.evolution.run_config import ALGORITHMS, RunConfig
from evolution_manager.evolution.run_results import run_results
from evolution_manager.graph.dispatch import DispatchError, Timeouts
from evolution_manager.graph.service_evaluator import ServiceEvaluator, ServiceSettings
from evolution_manager.graph.startup import Graph, GraphError
from evolution_manager.processes import exit_status, signals_as_interrupts
from evolution_manager.recording.bags import BagError, BagRecorder, finish_rewrites, rewrite_bag, topic_counts
from evolution_manager.viewing.results import write_results
from swarm_msgs.msg import ArchiveProgress, EvaluationResult
from swarm_ros.parameters import declare_dataclass
from swarm_sim.evaluation import Evaluator, evaluation_fields
from swarm_sim.tasks import world_parameters

EXIT_FAILED = 1
FLUSH_PERIOD = 1.0  # seconds between flushes of the run bag
EVALUATIONS_TOPIC = "/evaluations"
PROGRESS_TOPIC = "/progress"
EVALUATION_TYPE = "swarm_msgs/msg/EvaluationResult"
PROGRESS_TYPE = "swarm_msgs/msg/ArchiveProgress"


def build_parser() -> argparse.ArgumentParser:
    """The ``manager`` command line: ``evolve``'s run options, and where the evaluators come from."""
    parser = Parser(prog="manager", description=__doc__.split("\n")[0])
    parser.add_argument("--algorithm", choices=ALGORITHMS, help="gp (GP_o), gp-fnd (GP_fnd) or qd")
    parser.add_argument("--objective", choices=OBJECTIVES, help="the objective of gp and qd")
    parser.add_argument("--evaluations", type=positive_int, help="evaluation budget (default: as evolve)")
    parser.add_argument("--seed", type=seed_int, help="run seed in [0, 2**63 - 1] (default 0)")
    parser.add_argument("--trials", type=positive_int, help="trials per evaluation (default 10)")
    add_scenario_options(parser)
    add_task_options(parser)
    parser.add_argument("--out", type=Path, required=True, help="run directory (new, unless --resume)")
    parser.add_argument("--resume", action="store_true", help="continue the run in --out")
    parser.add_argument(
        "--evaluators", type=int, default=0, metavar="K", help="start K evaluator nodes (default 0)"
    )
    parser.add_argument(
        "--expect",
        type=positive_int,
        metavar="N",
        help="evaluators to wait for before starting (default 1 or K)",
    )
    parser.add_argument(
        "--wait",
        type=seconds,
        default=120.0,
        metavar="SECONDS",
        help="how long to wait for evaluators, at the start and whenever none is left (default 120)",
    )
    parser.add_argument(
        "--checkpoint-every", type=seconds, default=30.0, metavar="SECONDS", help="default 30"
    )
    parser.add_argument("--no-progress", action="store_true", help="no progress bar")
    parser.add_argument("--no-figures", action="store_true", help="write results but no figures")
    return parser


@dataclass(frozen=True)
class ManagerParameters:
    """The node's ROS parameters (read-only, read once at start; checked by ``ServiceSettings``)."""

    chunk_size: int = 50
    """Most requests in one goal sent to an evaluator."""
    timeout: float = 3.0
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

    def batch(self, run: Run) -> None:
        """Record the batch just told to the algorithm (``run.evaluations`` already counts it): every
        evaluation of it, in order, those answered from the run's cache marked ``cached``, and the
        repertoires' progress."""
        objective = self.config.objective or OBJECTIVES[0]
        for e in run.last_batch:
            request = e.request
            fields = evaluation_fields(
                request.tree,
                request.seed,
                request.trials,
                e.outcome,
                objective,
                profile=self.config.profile,
                cached=e.cached,
            )
            msg = EvaluationResult(**fields)
            self._emit(self.node.evaluations, EVALUATIONS_TOPIC, EVALUATION_TYPE, msg)
        for name in run.config.grids:
            grid = run.repertoire(name)
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


def bag_segments(out: Path) -> list[Path]:
    """The run's bags in order: ``run.bag``, then ``run.resume-<k>.bag`` for k = 1, 2, ..."""
    segments, path, k = [], out / "run.bag", 0
    while path.exists():
        segments.append(path)
        k += 1
        path = out / f"run.resume-{k}.bag"
    return segments


def bag_path(out: Path) -> Path:
    """``run.bag`` for a new run; ``run.resume-<k>.bag`` for the k-th resume."""
    k = len(bag_segments(out))
    return out / ("run.bag" if k == 0 else f"run.resume-{k}.bag")


def settle_bags(out: Path, evaluations: int) -> int:
    """Cut the run's bags back to the checkpoint: the messages of its first ``evaluations`` evaluations and
    the progress after them. A segment left by a killed manager is rewritten as a whole bag, and messages
    past the checkpoint (they will be recorded again) are dropped, so that the bags hold each evaluation
    once. Return how many evaluation messages the bags hold."""
    finish_rewrites(out)
    seen = 0
    for segment in bag_segments(out):
        start = seen
        state = {"evaluations": start}

        def keep(topic: str, msgtype: str, timestamp: int, data: bytes, state: dict = state) -> bool:
            if topic == EVALUATIONS_TOPIC:
                state["evaluations"] += 1
                return state["evaluations"] <= evaluations
            if topic == PROGRESS_TOPIC:
                return deserialize_message(data, ArchiveProgress).evaluations <= evaluations
            return True

        count: int | None = None  # unknown for a segment left by a killed manager
        if (segment / "metadata.yaml").exists():
            count = topic_counts(segment).get(EVALUATIONS_TOPIC, 0)
        if count is None or start + count > evaluations:
            rewrite_bag(segment, keep)
            count = min(state["evaluations"], evaluations) - start
        seen = start + count
    return seen


def _open_run(args: argparse.Namespace, evaluator: Evaluator) -> Run:
    directory = RunDirectory(args.out)
    if args.resume:
        if not directory.started():
            raise UsageError(f"--resume: {args.out} holds no run to continue (no config.json)")
        check_resume_options(args, directory.read_config())
        return Run.resume(args.out, evaluator)
    if directory.started():
        raise UsageError(f"{args.out} already holds a run: add --resume to continue it, or use another --out")
    return Run.start(config_from_args(args), args.out, evaluator, library_from_args(args))


class OwnedEvaluators:
    """The evaluator processes this manager started: one that dies is replaced at once by a new process under
    a new node name (``<name>_<life>``), and :meth:`dead` tells the service evaluator which services died."""

    def __init__(self, graph: Graph, log: Callable[[str, str], None], run: Run) -> None:
        self.graph = graph
        self.log = log
        # the run's model (profile, its task's world: every parameter the task sets, the trial length always)
        # and its copy of the primitive library
        world = run.config.world()
        self.parameters: dict[str, object] = {
            "profile": world.profile,
            "ticks": world.ticks,
            **world_parameters(world),
        }
        if run.library is not None:
            self.parameters["library"] = str(run.directory.library.absolute())
        self.lives: dict[str, int] = {}  # process name -> its base name
        self.replaced = 0

    def start(self, base: str, life: int = 1) -> None:
        name = base if life == 1 else f"{base}_{life}"
        self.graph.start(name, "swarm_sim", "evaluator", node_name=name, parameters=dict(self.parameters))
        self.lives[name] = life

    def dead(self) -> list[str]:
        """The services of the processes that died since the last call (each one replaced)."""
        services = []
        for name in self.graph.exited():
            code = self.graph.processes[name].returncode
            self.graph.forget(name)
            life = self.lives.pop(name, None)
            if life is None:
                continue
            base = name if life == 1 else name.rsplit("_", 1)[0]
            self.start(base, life + 1)
            self.replaced += 1
            self.log("warn", f"evaluator process {name} exited (code {code}); started {base}_{life + 1}")
            services.append(f"/{name}/evaluate")
        return services


def manage(argv: Sequence[str]) -> int:
    """Run the manager with ``argv`` (ROS arguments included); return the exit status."""
    try:
        args = build_parser().parse_args(remove_ros_args(list(argv))[1:])
        if args.evaluators < 0:
            raise UsageError(f"--evaluators must be 0 or more, got {args.evaluators}")
        if not args.resume:
            config_from_args(args)  # refuse bad options before anything starts
    except (UsageError, EvolutionError) as error:
        print(f"manager: error: {error}", file=sys.stderr)
        return EXIT_USAGE
    with signals_as_interrupts():
        return _manage(args, argv)


def _manage(args: argparse.Namespace, argv: Sequence[str]) -> int:
    rclpy.init(args=list(argv), signal_handler_options=SignalHandlerOptions.NO)
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
        return EXIT_USAGE
    graph = Graph(int(os.environ.get("ROS_DOMAIN_ID", "0")))
    try:
        try:
            run = _open_run(args, services)
        except OSError as error:  # an --out that cannot be created or written
            raise UsageError(f"{args.out}: {error.strerror or error}") from None
        services.profile = run.config.profile
        owned = OwnedEvaluators(graph, log, run)
        services.watch = owned.dead
        if args.evaluators:
            graph.log_dir = Path(args.out) / "logs"
            for i in range(1, args.evaluators + 1):
                # names of this manager's own: a killed manager's evaluators may linger in DDS for seconds
                owned.start(f"manager_{os.getpid()}_evaluator_{i}")
        expect = args.expect or max(args.evaluators, 1)
        ready = services.wait_for(expect, args.wait)
        graph.check()
        if not ready:
            raise DispatchError(
                f"no evaluator service found in ROS domain {graph.domain} within {args.wait:.0f} s: start "
                "evaluator nodes (ws/run swarm_sim evaluator) or use --evaluators K"
            )
        logger.info(f"ready: {len(ready)} evaluator(s): {', '.join(ready)}; run directory {args.out}")
        return _execute(args, node, run, services)
    except (DispatchError, GraphError, BagError) as error:
        print(f"manager: error: {error}; continue with --resume --out {args.out}", file=sys.stderr)
        return EXIT_FAILED
    except WriteError as error:  # a full disk: what was saved is whole
        print(
            f"manager: error: {error}; make room, then continue with --resume --out {args.out}",
            file=sys.stderr,
        )
        return EXIT_IO
    except (UsageError, EvolutionError) as error:
        print(f"manager: error: {error}", file=sys.stderr)
        return EXIT_USAGE
    except (KeyboardInterrupt, ExternalShutdownException) as error:
        signal.signal(signal.SIGINT, signal.SIG_IGN)  # stop the children cleanly, whatever comes now
        signal.signal(signal.SIGTERM, signal.SIG_IGN)
        print(f"manager: interrupted; continue with: manager --out {args.out} --resume", file=sys.stderr)
        return exit_status(error)
    finally:
        graph.stop()
        services.close()
        executor.shutdown()
        node.destroy_node()
        rclpy.try_shutdown()


def _execute(args: argparse.Namespace, node: ManagerNode, run: Run, services: ServiceEvaluator) -> int:
    out = Path(args.out)
    recorded = settle_bags(out, run.evaluations)
    if recorded < run.evaluations:
        node.get_logger().warning(
            f"the run's bags hold {recorded} of the {run.evaluations} evaluations of the checkpoint (a bag "
            "segment was removed or damaged, or was written before cached evaluations were recorded)"
        )
    bar = progress_bar(run.config, run.algorithm.produced, not args.no_progress)
    with BagRecorder(bag_path(out)) as recorder:
        recording = RunRecording(node, recorder, run.config)
        flushed = time.monotonic()

        def on_batch(done: int, total: int) -> None:
            nonlocal flushed
            recording.batch(run)
            if time.monotonic() - flushed >= FLUSH_PERIOD:
                recorder.flush()
                flushed = time.monotonic()
            if bar is not None:
                bar.update(done - bar.n)

        try:
            run.execute(
                on_batch=on_batch,
                checkpoint_interval=args.checkpoint_every,
                before_checkpoint=lambda: recorder.flush(sync=True),
            )
        finally:
            if bar is not None:
                bar.close()
    write_results(run, run_results(run, services), with_figures=not args.no_figures)
    dispatcher = services.dispatcher
    node.get_logger().info(
        f"{run.config.label}: {run.evaluations} evaluations in {args.out} "
        f"(requests re-sent: {dispatcher.resent}, duplicate results ignored: {dispatcher.duplicates})"
    )
    return 0


def main() -> None:
    """Console entry point of ``manager``."""
    sys.exit(manage(sys.argv))
