"""Run one trial through the full node graph and record it.

``ws/run evolution_manager trial --tree TREE --seed S [--trial K] --bag DIR`` starts the simulator and one
footbot controller node per robot (all in one process, or a process each with ``--controller-processes
per-robot``), loads the tree into every controller (with ``--swarm
FILE``, a swarm layout of ``swarm_sim.model.swarm_layout``: each controller its own tree), runs trial K of
seed S in lockstep through the simulator's ``run_trial`` action, records every topic of the graph to a rosbag2
bag with MCAP storage, and prints the same JSON as ``ws/run swarm_sim evaluate --per-trial`` for that trial.
The bag's ``/trial_result`` keeps the swarm's tree as ``SwarmLayout.label``: the tree text of a homogeneous
swarm, the JSON list of the robots' trees of a heterogeneous one.

The graph runs in the caller's ROS domain (``ROS_DOMAIN_ID``, or ``--domain D``) so that a user can watch it
live with their own tools (RViz2, Foxglove, ``ros2 topic echo``); ``--namespace /swarm_a`` keeps it apart
from other graphs in the same domain. ``--params-file FILE`` hands a ROS parameter file to every node (for
instance ``src/swarm_sim/config/swarm_sim.yaml`` with a world setting changed). Node logs are kept in
``--logs DIR`` (default: ``<bag>.logs`` beside the bag).

``--task foraging`` runs the authors' 100 s foraging trials (default ``primitives``, 20 s); ``--task FILE``
a task file's world (``docs/tasks.md``): the simulator is given every world parameter the task sets.
``--library FILE`` (a primitive library, ``bt_controller.language.library``) is handed to every controller as
its ``library`` parameter: the tree may then name its primitives.

``--tree`` is tree text, or a file holding it when it names an existing file. Every node process dies with
this one, whatever kills it. Exit status: 0 done; 2 a bad tree or option, a bag that cannot be written or a
graph that failed; 130 interrupted (SIGINT), 143 terminated (SIGTERM).
"""

from __future__ import annotations

import argparse
import contextlib
import os
import shutil
import sys
import tempfile
import time
from collections.abc import Callable, Sequence
from dataclasses import replace
from pathlib import Path
from typing import Any

import rclpy
from rclpy.action import ActionClient
from rclpy.action.client import ClientGoalHandle
from rclpy.experimental import EventsExecutor
from rclpy.node import Node
from rclpy.signals import SignalHandlerOptions
from rclpy.task import Future

from bt_controller.errors import TreeError
from bt_controller.interpreters import (
    Network,
    controller_text,
    is_network_text,
    load_network,
    parse_controller,
)
from bt_controller.language import Library, LibraryError, load_library, to_text
from bt_controller.language import Node as TreeNode
from bt_controller.model_settings import PROFILES, chain_of_trial
from bt_controller.robot import timeline
from evolution_manager.arguments import (
    Parser,
    finite,
    non_negative_int,
    rate_argument,
    seed_in_range,
    tree_argument,
)
from evolution_manager.errors import TrialFailedError, UsageError
from evolution_manager.graph.nodes.recorder import GraphRecorder, graph_frames, trial_topics
from evolution_manager.graph.startup import (
    CONTROLLER_PROCESSES,
    Bridge,
    Graph,
    GraphError,
    start_trial_graph,
)
from evolution_manager.processes import exit_status, signals_as_interrupts
from evolution_manager.recording.bags import BagError, BagRecorder, check_new_bag, is_latched
from evolution_manager.recording.reproduce import RESULT_TOPIC
from swarm_msgs.action import RunTrial
from swarm_msgs.msg import GroundSensor, RangeAndBearingReadings, TreeStatus, TrialStart, WheelCommand
from swarm_msgs.srv import LoadTree
from swarm_ros.isolation import reserved_domain
from swarm_ros.lifecycle import LifecycleClient, LifecycleError
from swarm_ros.names import check_topic, graph_namespace, robot_namespaces
from swarm_ros.parameters import read_parameter_file
from swarm_ros.safe_paths import check_folder, describe
from swarm_ros.services import call_until_answered
from swarm_sim.core import TrialRecord
from swarm_sim.errors import ConfigError
from swarm_sim.evaluation import result_fields, trial_record_of
from swarm_sim.evaluation.cli import evaluation_json
from swarm_sim.model import DEFAULT, Config, LayoutError, SwarmLayout, apply_conditions, load_layout
from swarm_sim.nodes.settings import TIMINGS
from swarm_sim.nodes.simulator import check_parameter_file
from swarm_sim.tasks import DEFAULT_TASK, TaskSpec, add_task_option, resolve_task, world_parameters

MAX_DOMAIN = 232
"""Largest ROS_DOMAIN_ID (Fast DDS's port arithmetic; 0-101 are safe on Linux)."""
STARTUP_TIMEOUT = 600.0
"""Seconds to wait for a node's services and actions to appear. Starting the graph's Python processes that
load numba took about 40 s of CPU with a process per controller: on a loaded machine that is minutes of wall
time, and a node that dies while starting is noticed at once (``Graph.check``), so this only bounds a node
that hangs."""


GRAPH_CHECK_INTERVAL = 0.25
"""Seconds between two looks, while the runner waits, at whether a node's process has exited."""

PUBLISHERS_MATCH_SETTLE = 1.0
"""Seconds a new recorder waits at least after its subscriptions matched, for the publishers to match them
too; three times as long as its own side took when that was longer (on a loaded machine the publishers'
processes learn of the new subscriptions late too: with CI, an experiment and ARGoS on two cores, a
recorder lost a trial's first step on two robots after a 1 s wait)."""


def expected_messages(
    robots: int,
    namespace: str = "",
    trial: int = 0,
    config: Config = DEFAULT,
    clock: str = "/clock",
    timing: str = "lockstep",
    frames: bool = True,
    bridge: bool = False,
) -> dict[str, int]:
    """How many messages each topic of a trial graph (``trial_topics``) carries when it runs trial ``trial``:
    every step of the trial's chain up to ``trial`` is published (the earlier trials set the state it starts
    from, ``swarm_sim.roads.lockstep.run_with_controllers``) under ``config``'s timeline. Under free
    ``timing`` the controllers publish on their own clocks: their topics are expected to carry none (whatever
    came is recorded). ``frames``: whether the bag records odom, ``/tf`` and ``/tf_static``
    (``trial_topics``); ``bridge``: the readings come from the virtual-sensor bridge, on its own clock
    (expected: none)."""
    line = config.timeline
    trials = chain_of_trial(line, trial)[1] + 1
    steps = trials * timeline.trial_steps(line)
    per_trial = {TrialStart: 1, TreeStatus: trials * line.ticks}
    if timing == "free":
        per_trial.update({TreeStatus: 0, WheelCommand: 0})
    if bridge:
        per_trial.update({GroundSensor: 0, RangeAndBearingReadings: 0})
    return {
        topic: 1 if is_latched(topic) else per_trial.get(msg_class, steps)
        for topic, msg_class in trial_topics(robots, namespace, clock, frames)
    }


class TrialRunner:
    """A client node that loads trees into the controllers and sends trials to the simulator's action."""

    def __init__(
        self, context: rclpy.Context, graph: Graph, robots: int, timeout: float, namespace: str = ""
    ) -> None:
        self.graph = graph
        self.robots = robots
        self.timeout = timeout
        self.node = Node("trial_runner", namespace=namespace or "/", context=context)
        # rclpy's events executor: a recorder's callback (one for each of about 40 messages a step) cost a
        # third less CPU than under the single-threaded executor, which rebuilds its wait set of every
        # subscription for each. It is spun one spin_once at a time, as swarm_ros.spinning explains.
        self.executor = EventsExecutor(context=context)
        self.executor.add_node(self.node)
        self.load_clients: list[rclpy.client.Client] = [
            self.node.create_client(LoadTree, f"{robot}/load_tree") for robot in robot_namespaces(robots)
        ]
        self.trial_client: ActionClient[Any, Any, Any] = ActionClient(
            self.node, RunTrial, "simulator/run_trial"
        )
        self.simulator = LifecycleClient(self.node, "simulator")
        self.feedback: list[int] = []  # the steps reported by the last trial's feedback

    def activate(self) -> None:
        """Drive the simulator (a managed node started unconfigured) through configure and activate."""
        self.spin_until(self.simulator.ready, "the simulator's lifecycle services", STARTUP_TIMEOUT)

        def wait(future: Future, seconds: float) -> bool:
            try:
                self.spin_until(future.done, "the simulator's lifecycle", seconds)
            except TrialFailedError:
                return False
            return True

        try:
            self.simulator.drive(["configure", "activate"], wait, STARTUP_TIMEOUT)
        except LifecycleError as error:
            raise TrialFailedError(str(error)) from None

    def close(self) -> None:
        self.simulator.destroy()
        self.trial_client.destroy()
        self.executor.shutdown()
        self.node.destroy_node()

    def spin_until(self, done: Callable[[], bool], what: str, timeout: float | None = None) -> None:
        """Spin until ``done()``; raise ``TrialFailedError`` naming ``what`` on timeout or a dead node."""
        deadline = time.monotonic() + (self.timeout if timeout is None else timeout)
        checked = -GRAPH_CHECK_INTERVAL
        while not done():
            now = time.monotonic()
            if now - checked >= GRAPH_CHECK_INTERVAL:  # not at every message: it polls every process
                self.graph.check()
                checked = now
            if now > deadline:
                raise TrialFailedError(f"timed out waiting for {what}")
            self.executor.spin_once(timeout_sec=0.05)

    def spin_while_progressing(
        self, done: Callable[[], bool], progress: Callable[[], int], what: Callable[[], str]
    ) -> None:
        """Spin until ``done()`` while ``progress()`` keeps growing: raise ``TrialFailedError`` naming
        ``what()`` once it has not grown for the runner's timeout (a recorder trailing a loaded graph is slow,
        not stuck)."""
        seen = [progress()]

        def done_or_moved() -> bool:
            return done() or progress() != seen[0]

        while True:
            try:
                self.spin_until(done_or_moved, "")
            except TrialFailedError:
                raise TrialFailedError(f"timed out waiting for {what()}") from None
            if done():
                return
            seen[0] = progress()

    def spin_for(self, seconds: float) -> None:
        """Spin for ``seconds``."""
        deadline = time.monotonic() + seconds
        while time.monotonic() < deadline:
            self.executor.spin_once(timeout_sec=0.05)

    def call(self, client: rclpy.client.Client, request: object, what: str) -> Any:  # an untyped ROS response
        """Call an idempotent service, sending the request again while no answer comes
        (``swarm_ros.services``), up to the runner's timeout; raise ``TrialFailedError`` naming ``what``."""
        self.spin_until(client.service_is_ready, f"the {client.srv_name} service", STARTUP_TIMEOUT)

        def wait(future: Future, seconds: float) -> bool:
            try:
                self.spin_until(future.done, what, seconds)
            except TrialFailedError:
                return False
            return True

        response = call_until_answered(client, request, wait, self.timeout)
        if response is None:
            raise TrialFailedError(f"timed out waiting for {what}")
        return response

    def load_trees(self, trees: Sequence[str]) -> None:
        """Load robot ``i``'s tree ``trees[i]`` into its controller."""
        if len(trees) != len(self.load_clients):
            raise TrialFailedError(f"{len(trees)} trees for {len(self.load_clients)} controllers")
        for client, tree_text in zip(self.load_clients, trees, strict=True):
            response = self.call(
                client, LoadTree.Request(tree=tree_text), f"{client.srv_name} to load the tree"
            )
            if not response.success:
                raise TrialFailedError(f"{client.srv_name} refused the tree: {response.message}")

    def send_trial(self, seed: int, trial: int) -> ClientGoalHandle:
        """Send trial ``trial`` of ``seed`` to the simulator's action; return the accepted goal's handle."""
        self.spin_until(
            self.trial_client.server_is_ready, "the simulator's run_trial action", STARTUP_TIMEOUT
        )
        self.feedback = []
        goal = RunTrial.Goal(seed=seed, trial=trial, arena_configuration=-1)
        future = self.trial_client.send_goal_async(
            goal, feedback_callback=lambda msg: self.feedback.append(int(msg.feedback.step))
        )
        self.spin_until(future.done, f"the simulator to accept trial {trial} of seed {seed}")
        handle = future.result()
        if handle is None or not handle.accepted:
            raise TrialFailedError(f"the simulator refused trial {trial} of seed {seed}")
        return handle

    def result(self, handle: ClientGoalHandle, seed: int, trial: int) -> TrialRecord:
        """Wait for the goal ``handle``'s result; cancel it when the wait fails (freeing the simulator)."""
        future = handle.get_result_async()
        try:
            # The answer timeout bounds every step, not the trial: wait as long as steps keep coming.
            last = (-1, time.monotonic())

            def done_or_stalled() -> bool:
                nonlocal last
                if self.feedback and self.feedback[-1] != last[0]:
                    last = (self.feedback[-1], time.monotonic())
                if time.monotonic() - last[1] > self.timeout:
                    raise TrialFailedError(f"no step of trial {trial} of seed {seed} for {self.timeout} s")
                return future.done()

            self.spin_until(done_or_stalled, f"trial {trial} of seed {seed}", timeout=float("inf"))
        except BaseException:
            self.cancel(handle)
            raise
        answer = future.result()
        if answer is None:  # the future was cancelled or failed: no result came back
            raise TrialFailedError(f"the simulator gave no result for trial {trial} of seed {seed}")
        response = answer.result
        if not response.success:
            raise TrialFailedError(f"the simulator could not run the trial: {response.message}")
        return trial_record_of(response, trial)

    def cancel(self, handle: ClientGoalHandle) -> None:
        """Ask the simulator to cancel the goal; wait a little for its answer."""
        with contextlib.suppress(Exception):
            future = handle.cancel_goal_async()
            deadline = time.monotonic() + 5.0
            while not future.done() and time.monotonic() < deadline:
                self.executor.spin_once(timeout_sec=0.05)

    def run_trial(self, seed: int, trial: int) -> TrialRecord:
        return self.result(self.send_trial(seed, trial), seed, trial)


class TrialGraph:
    """A running trial graph (simulator and one controller process per robot) that runs any number of
    trials, each optionally recorded to a bag of its own. A context manager.

    ``domain``: the ROS domain (default: one reserved for this graph alone, so tests run side by side);
    ``namespace``: the graph's namespace (e.g. ``/swarm_a``); ``params_file``: a ROS parameter file for every
    node; ``log_dir``: where the node logs stay (default: a temporary directory, removed on exit);
    ``conditions`` (``NAME=VALUE`` texts, ``swarm_sim.model.conditions``) change the simulator's world, and a
    ``robots=N`` among them sets the number of controllers; ``profile`` is the model's profile
    (``docs/model.md``); ``clock``: the simulator's clock topic (``/clock``; two graphs in one domain need
    one each); ``library``: a primitive library every controller reads (a file); ``task``: the task whose
    world the simulator runs (``swarm_sim.tasks``; ``robots`` overrides its robot count); ``timing``:
    ``lockstep`` (exact) or ``free`` (the simulator steps at ``rate`` times real time, the controllers tick
    on their own timers in simulated time: ``startup.trial_graph_nodes``); ``frames``: whether a bag records
    odom, ``/tf`` and ``/tf_static`` too (``recorder.trial_topics``); ``bridge`` (free timing only): the
    readings come from the virtual-sensor bridge over its link (``startup.Bridge``), not the simulator;
    ``controller_processes``: the controllers all in ``one`` process (the default: the graph starts in about
    8 s less CPU) or one ``per-robot`` (``startup.CONTROLLER_PROCESSES``)."""

    def __init__(
        self,
        *,
        robots: int | None = None,
        timeout: float = 60.0,
        domain: int | None = None,
        namespace: str = "",
        params_file: Path | None = None,
        log_dir: Path | None = None,
        conditions: Sequence[str] = (),
        profile: str = DEFAULT.profile,
        clock: str = "/clock",
        library: Path | None = None,
        task: TaskSpec | str | None = None,
        timing: str = "lockstep",
        rate: float = 1.0,
        frames: bool = True,
        bridge: Bridge | None = None,
        controller_processes: str = "one",
    ) -> None:
        self.conditions = list(conditions)
        self.controller_processes = controller_processes
        self.frames = frames
        self.bridge = bridge
        self.timing = timing
        self.rate = rate
        self.clock = clock
        self.library = library
        self.task = resolve_task(DEFAULT_TASK if task is None else task)
        world = self.task.config(profile)
        self.world = world if robots is None else replace(world, n_robots=robots)
        self.config, _ = apply_conditions(self.conditions, self.world)
        self.robots = self.config.n_robots
        self.timeout = timeout
        self.domain = domain
        self.namespace = graph_namespace(namespace)
        self.params_file = params_file
        if params_file is not None:
            self._check_params_file(params_file)
        self.log_dir = log_dir
        self._stack = contextlib.ExitStack()
        self.runner: TrialRunner | None = None
        self.graph: Graph | None = None
        self.trials_run = 0
        self._temporary_logs: Path | None = None

    def _check_params_file(self, path: Path) -> None:
        """Refuse, before any node starts, a parameter file the graph cannot take (``check_params_file``)."""
        check_params_file(path, self.namespace, self.config)

    def __enter__(self) -> TrialGraph:
        stack = self._stack.__enter__()
        try:
            domain = self.domain if self.domain is not None else stack.enter_context(reserved_domain())
            logs = self.log_dir
            if logs is None:  # kept when the graph fails, since the error points to it
                logs = Path(tempfile.mkdtemp(prefix="swarm-trial-logs-"))
                self._temporary_logs = logs
            self.graph = stack.enter_context(Graph(domain, log_dir=logs))
            start_trial_graph(
                self.graph,
                self.robots,
                self.conditions,
                namespace=self.namespace,
                params_file=self.params_file,
                profile=self.config.profile,
                clock=self.clock,
                library=str(self.library.absolute()) if self.library is not None else "",
                world=world_parameters(self.world),
                timing=self.timing,
                rate=self.rate,
                bridge=self.bridge,
                controller_processes=self.controller_processes,
            )
            context = rclpy.Context()
            rclpy.init(context=context, domain_id=domain, signal_handler_options=SignalHandlerOptions.NO)
            stack.callback(rclpy.try_shutdown, context=context)
            self.runner = TrialRunner(context, self.graph, self.robots, self.timeout, self.namespace)
            stack.callback(self.runner.close)
            self.runner.activate()
        except BaseException:
            stack.close()
            raise
        return self

    def __exit__(self, *exc_info: Any) -> None:  # (type, value, traceback), passed on as received
        self._stack.__exit__(*exc_info)
        if self._temporary_logs is not None and exc_info[0] is None:
            shutil.rmtree(self._temporary_logs, ignore_errors=True)

    def run(
        self, tree_text: str | SwarmLayout, seed: int, trial: int, bag_path: Path | None = None
    ) -> TrialRecord:
        """Run trial ``trial`` of ``seed`` with ``tree_text`` on every robot, or a swarm layout's tree on
        each; record it to ``bag_path`` when given (a new directory); return its record."""
        runner = self.runner
        if runner is None:
            raise RuntimeError("the trial graph is not started: use it as a context manager")
        layout = (
            tree_text if isinstance(tree_text, SwarmLayout) else SwarmLayout.uniform(tree_text, self.robots)
        )
        runner.load_trees(layout.trees)
        # the bag keeps the trees its robots ran, primitives written out: it reproduces without the library
        if self.library:
            library = load_library(self.library)
            layout = SwarmLayout(
                tuple(
                    text if is_network_text(text) else to_text(library.parse(text)) for text in layout.trees
                )
            )
        recorded_tree = layout.label
        if bag_path is None:
            record = runner.run_trial(seed, trial)
            self.trials_run += 1
            return record
        node = Node("trial_recorder", context=runner.node.context)
        runner.executor.add_node(node)
        try:
            with BagRecorder(bag_path) as bag:
                topics = trial_topics(self.robots, self.namespace, self.clock, self.frames)
                recorder = GraphRecorder(
                    node, bag, topics, armed=False, frames=graph_frames(self.robots, self.namespace)
                )
                joining = time.monotonic()
                runner.spin_until(recorder.all_publishers_matched, "the graph's publishers")
                # Matching is seen from this side first: the publishers learn of the new subscriptions a
                # moment later, and a volatile writer does not resend what it wrote before. Without this
                # wait a trial lost its first ticks on one robot in about one run of ten.
                runner.spin_for(max(PUBLISHERS_MATCH_SETTLE, 3 * (time.monotonic() - joining)))
                # The latched topics hand over their last message on joining: the arena of the simulator's
                # start, and the start of any trial run before. Those belong to no trial of this bag.
                stale = {
                    f"{self.namespace}/markers": 1,
                    f"{self.namespace}/trial_start": min(self.trials_run, 1),
                    **({"/tf_static": 1} if self.frames else {}),
                }
                runner.spin_until(
                    lambda: all(recorder.received[t] >= n for t, n in stale.items()), "the latched topics"
                )
                recorder.arm()
                record = runner.run_trial(seed, trial)
                self.trials_run += 1
                expected = expected_messages(
                    self.robots,
                    self.namespace,
                    trial,
                    self.config,
                    self.clock,
                    self.timing,
                    self.frames,
                    self.bridge is not None,
                )
                # the recorder may trail the trial by many steps on a loaded machine (a chain's earlier
                # trials are recorded too): wait as long as for any step of the graph
                runner.spin_while_progressing(
                    lambda: all(recorder.counts[t] >= n for t, n in expected.items()),
                    lambda: sum(recorder.counts.values()),
                    lambda: (
                        "the last messages (recorded/expected: "
                        + ", ".join(
                            f"{t} {recorder.counts[t]}/{n}"
                            for t, n in expected.items()
                            if recorder.counts[t] < n
                        )
                        + ")"
                    ),
                )
                stamp = recorder.last_stamp + 1
                write_result(bag, recorded_tree, seed, record, stamp, self.namespace, self.config.profile)
            return record
        finally:
            runner.executor.remove_node(node)
            node.destroy_node()


def check_params_file(path: Path, namespace: str, config: Config) -> None:
    """Refuse, before any node starts, a parameter file that cannot be read, whose robot count is not the
    graph's (``config.n_robots``: the graph starts one controller per robot and gives the simulator
    ``n_robots`` on its command line, which would silently win over the file's), or that gives the
    simulator a value it would refuse at start-up (a mistyped value, one out of range, a world its checks
    refuse, an unknown name): one line, rather than a graph started to fail. The controllers check their
    own values as they start."""
    simulator = f"{graph_namespace(namespace)}/simulator"
    for section in read_parameter_file(path):
        count = section.parameters.get("n_robots")
        if count is not None and section.names(simulator) and count != config.n_robots:
            raise ValueError(
                f"--params-file {path}: n_robots {count!r} differs from this trial's {config.n_robots} "
                "robots; leave n_robots out of the file (the trial sets it: the condition robots=N)"
            )
    try:
        check_parameter_file(path, simulator, config)
    except ConfigError as error:
        raise ValueError(f"--params-file {error}") from None


def run_recorded_trial(
    tree_text: str | SwarmLayout,
    seed: int,
    trial: int,
    bag_path: Path,
    *,
    robots: int | None = None,
    timeout: float = 60.0,
    domain: int | None = None,
    namespace: str = "",
    params_file: Path | None = None,
    log_dir: Path | None = None,
    profile: str = DEFAULT.profile,
    clock: str = "/clock",
    library: Path | None = None,
    task: TaskSpec | str | None = None,
    timing: str = "lockstep",
    rate: float = 1.0,
    frames: bool = True,
    controller_processes: str = "one",
) -> TrialRecord:
    """Run trial ``trial`` of ``seed`` with ``tree_text`` (every robot's, or a swarm layout) through a fresh
    node graph, recording it to ``bag_path``; return its record (see ``TrialGraph`` for the other
    arguments)."""
    with TrialGraph(
        robots=robots,
        timeout=timeout,
        domain=domain,
        namespace=namespace,
        params_file=params_file,
        log_dir=log_dir,
        profile=profile,
        clock=clock,
        library=library,
        task=task,
        timing=timing,
        rate=rate,
        frames=frames,
        controller_processes=controller_processes,
    ) as graph:
        return graph.run(tree_text, seed, trial, bag_path)


def write_result(
    bag: BagRecorder,
    tree_text: str,
    seed: int,
    record: TrialRecord,
    stamp_ns: int,
    namespace: str = "",
    profile: str = DEFAULT.profile,
) -> None:
    """Close the trial's bag with its result (tree, seed, profile, six values), stamped ``stamp_ns``;
    ``tree_text`` is the swarm's ``SwarmLayout.label``."""
    fields = result_fields(tree_text, seed, 1, record.values, "food", profile=profile)
    bag.write(namespace + RESULT_TOPIC, bag.message("swarm_msgs/msg/EvaluationResult", **fields), stamp_ns)


def caller_domain() -> int:
    """The caller's ROS domain: ``ROS_DOMAIN_ID``, 0 when unset (as every ROS 2 tool does)."""
    text = os.environ.get("ROS_DOMAIN_ID", "").strip() or "0"
    try:
        return domain_id(text)
    except argparse.ArgumentTypeError as error:
        raise ValueError(f"ROS_DOMAIN_ID: {error}") from None


def domain_id(text: str) -> int:
    """A ROS domain id from the command line: an integer in 0..232."""
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected an integer in 0..{MAX_DOMAIN}, got {text!r}") from None
    if not 0 <= value <= MAX_DOMAIN:
        raise argparse.ArgumentTypeError(f"expected an integer in 0..{MAX_DOMAIN}, got {value}")
    return value


def main(argv: Sequence[str] | None = None) -> int:
    """``trial``: one trial through the node graph, recorded; prints the trial's JSON."""
    parser = Parser(prog="trial", description=__doc__.split("\n\n")[1])
    what = parser.add_mutually_exclusive_group(required=True)
    what.add_argument("--tree", help="every robot's tree, as text or a file holding it")
    what.add_argument(
        "--network",
        type=Path,
        metavar="FILE",
        help='every robot\'s network instead of a tree: a JSON file {"weights": [56 numbers]}',
    )
    what.add_argument(
        "--swarm",
        type=Path,
        metavar="FILE",
        help='a tree per robot: a JSON file {"trees": ["tree text", ...]} (one per robot, robot 0 first)',
    )
    parser.add_argument(
        "--seed", type=seed_in_range, default=0, help="seed of the evaluation, in [0, 2**63 - 1] (default 0)"
    )
    parser.add_argument(
        "--trial",
        type=non_negative_int,
        default=0,
        help="index of the trial (default 0); the earlier trials of its chain run (and are recorded) first",
    )
    parser.add_argument(
        "--profile",
        choices=PROFILES,
        default=DEFAULT.profile,
        help=f"the model's profile (docs/model.md; default {DEFAULT.profile})",
    )
    add_task_option(parser)
    parser.add_argument(
        "--library", type=Path, default=None, help="a primitive library (JSON) whose names the tree may use"
    )
    parser.add_argument("--bag", required=True, type=Path, help="new bag directory to record the trial to")
    parser.add_argument(
        "--timeout",
        type=finite(0.0, strictly=True, what="number of seconds"),
        default=60.0,
        help="seconds to wait for any step of the graph (default 60)",
    )
    parser.add_argument(
        "--domain",
        type=domain_id,
        default=None,
        help="ROS domain of the graph (default: $ROS_DOMAIN_ID or 0)",
    )
    parser.add_argument("--namespace", default="", help="namespace of the graph, e.g. /swarm_a (default: /)")
    parser.add_argument(
        "--clock",
        default="/clock",
        help="topic of the simulator's clock (default /clock; give each graph its own, e.g. /swarm_a/clock, "
        "to run two in one domain)",
    )
    parser.add_argument(
        "--params-file",
        type=Path,
        default=None,
        help="a ROS parameter file (YAML) for every node of the graph",
    )
    parser.add_argument(
        "--timing",
        choices=TIMINGS,
        default="lockstep",
        help="lockstep (default: every step waits for every controller, bit-exact with evaluate) or free: "
        "the simulator steps at --rate times real time with each robot's latest answer and the controllers "
        "tick on their own timers in simulated time, as on robots (docs/ros.md)",
    )
    parser.add_argument(
        "--rate",
        type=rate_argument,
        default=None,
        help="with --timing free: simulated seconds per second of wall time (default 1.0, real time)",
    )
    parser.add_argument(
        "--frames",
        action=argparse.BooleanOptionalAction,
        default=True,
        help="record each robot's odom, /tf and /tf_static in the bag (default); --no-frames leaves them out "
        "(a bag about a third smaller, docs/performance.md)",
    )
    parser.add_argument(
        "--controller-processes",
        choices=CONTROLLER_PROCESSES,
        default="one",
        help="one: every robot's controller node in one process (default; about 8 s less CPU to start nine); "
        "per-robot: a process each, as on robots. Same nodes, messages and result",
    )
    parser.add_argument(
        "--logs", type=Path, default=None, help="directory for the node logs (default <bag>.logs)"
    )
    try:
        args = parser.parse_args(sys.argv[1:] if argv is None else argv)
    except UsageError as error:
        print(f"trial: error: {error}", file=sys.stderr)
        return 2
    try:
        library: Library | None = load_library(args.library) if args.library is not None else None

        def canonical(tree: TreeNode | Network) -> str:
            if library is None or isinstance(tree, Network):
                return controller_text(tree)
            return library.fold(tree)

        shown: str | list[str]
        ran: str | SwarmLayout
        if args.swarm is not None:
            try:
                layout = load_layout(args.swarm, args.task.robots.count, library)
            except LayoutError as error:
                raise ValueError(f"--swarm: {error}") from None
            shown = [canonical(tree) for tree in layout.parsed(library)]
            ran = SwarmLayout(tuple(shown))
        elif args.network is not None:
            shown = controller_text(load_network(args.network))
            ran = shown
        else:
            shown = canonical(parse_controller(tree_argument(args.tree), library=library))
            ran = shown
        namespace = graph_namespace(args.namespace)  # a name ROS refuses: before any node starts
        check_topic(args.clock, "--clock")
        if args.rate is not None and args.timing != "free":
            raise ValueError("--rate applies to --timing free only")
        check_new_bag(args.bag)
        try:  # an unusable place fails here, at once
            args.bag.absolute().parent.mkdir(parents=True, exist_ok=True)
        except OSError as error:  # a place under a file said as such (it was "File exists")
            raise ValueError(f"--bag {describe(args.bag, error)}") from None
        if args.params_file is not None and not args.params_file.is_file():
            raise ValueError(f"--params-file {args.params_file}: no such file")
        if args.params_file is not None:  # before the graph starts, as the simulator would check it
            check_params_file(args.params_file, args.namespace, args.task.config(args.profile))
        domain = caller_domain() if args.domain is None else args.domain
        logs = args.logs or args.bag.with_name(args.bag.name + ".logs")
        check_folder(logs, "--logs")  # a link, a file or a place under a file: refused before the graph
        print(
            f"trial: graph in ROS domain {domain}, namespace {namespace or '/'}; node logs in {logs}",
            file=sys.stderr,
        )
        with signals_as_interrupts():
            record = run_recorded_trial(
                ran,
                args.seed,
                args.trial,
                args.bag,
                timeout=args.timeout,
                domain=domain,
                namespace=namespace,
                params_file=args.params_file,
                log_dir=logs,
                profile=args.profile,
                clock=args.clock,
                library=args.library,
                task=args.task,
                timing=args.timing,
                rate=1.0 if args.rate is None else args.rate,
                frames=args.frames,
                controller_processes=args.controller_processes,
            )
    except (TreeError, LibraryError, ValueError, BagError, GraphError, TrialFailedError, OSError) as error:
        print(f"trial: {error}", file=sys.stderr)
        return 2
    except KeyboardInterrupt as error:
        print("trial: interrupted", file=sys.stderr)
        return exit_status(error)
    print(
        evaluation_json(
            shown, args.seed, 1, record.values, [record], args.profile, library=library, task=args.task
        )
    )
    print(f"trial: recorded to {args.bag}", file=sys.stderr)
    return 0
