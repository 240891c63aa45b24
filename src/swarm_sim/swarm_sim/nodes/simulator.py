"""The simulator node: owns the world and runs trials in lockstep with the footbot controller nodes.

Node ``simulator``. Every name but ``/clock`` and ``/diagnostics`` is relative, so a whole graph can run under
a namespace (``__ns:=/swarm_a``, its robots then in ``/swarm_a/footbot_<i>``).

A managed (lifecycle) node (``swarm_ros.lifecycle``): ``configure`` compiles the world and makes its topics,
services and actions, ``activate`` lets it take trials, ``deactivate`` abandons the trial under way after
its step and refuses trials, ``cleanup`` and ``shutdown`` withdraw everything. It configures and activates
itself at start unless ``-p autostart:=false`` (the trial graph drives it).

Parameters (``ros2 param describe simulator <name>``; ``config/swarm_sim.yaml``; a bad value, type or name
stops the node with one line, exit status 2):
    every field of ``swarm_sim.model.config.Config`` (read-only: world, timing and perception settings such as
        ``arena_half``, ``gaps``, ``n_robots``, ``wheel_speed``, ``step_dt``, ``ticks``, ``window``), with the
        model's defaults; a bad value stops the node with a one-line error naming it.
    conditions (string, read-only): changes to the world, ``NAME=VALUE`` separated by spaces, e.g.
        ``dead-robots=2 message-loss=0.5`` (``swarm_sim.model.conditions``; default none), applied after the
        fields above. A ``robots=N`` among them must equal ``n_robots``.
    robot_namespaces (string array, read-only): the robots' namespaces, relative to the node's; robot ``i``
        is the i-th (default ``footbot_0`` .. ``footbot_<n_robots - 1>``).
    answer_timeout (float, seconds of wall time, may be changed at run time): how long to wait for the
        controllers at any step before the trial is abandoned with an error (default 60): it detects dead
        nodes; it is no speed limit.
    autostart (bool, read-only, default true): configure and activate at start.
    timing (string, read-only): ``lockstep`` (default): every step waits for every controller's answer, so a
        trial is bit-exact with the batch evaluator; ``free``: the world steps on its own, ``rate`` times real
        time, and each step takes every robot's latest answer, whatever step it answered (below).
    rate (float, read-only, free only): simulated seconds per second of wall time (default 1.0: real time).
    sensing (string, read-only): ``model`` (default): publish each robot's readings; ``external`` (free
        only): publish none; another node senses from the poses (``sensor_bridge``).

Publishers:
    /clock (rosgraph_msgs/Clock): simulated time, one step of 1/8 s per sensing step; at the root, where
        ``use_sim_time`` looks (remap it with ``-r /clock:=/swarm_a/clock`` to run two graphs in one domain).
    /diagnostics (diagnostic_msgs/DiagnosticArray): every second of steady (wall) time, stamped in simulated
        time: the lifecycle state, the trial under way, steps per second (over the last second), trials run
        and goals waiting.
    trial_start (swarm_msgs/TrialStart, transient-local): each trial's seed, index and the robots' stream
        keys.
    faults (swarm_msgs/RobotFaults, transient-local): each robot's fault kind ("" for none), at each trial's
        start and when faults injected through ``~/inject_faults`` strike (with the step they hold from).
    markers (visualization_msgs/MarkerArray, transient-local): walls, nest and food region of the trial's
        arena, frame ``arena``, metres.
    robot_markers (visualization_msgs/MarkerArray): every step, each robot's body, heading and label (index,
        namespace, current action).
    <robot>/ground (swarm_msgs/GroundSensor) and <robot>/range_and_bearing
        (swarm_msgs/RangeAndBearingReadings): each robot's readings, every sensing step, in the robot's frame
        ``<robot>/base_link``.
    <robot>/pose (geometry_msgs/PoseStamped): each robot's pose in frame ``arena`` (metres, radians).
    <robot>/odom (nav_msgs/Odometry): each robot's pose in its frame ``<robot>/odom`` (which coincides with
        ``arena``: the simulator's odometry is exact) and its velocity over the last step in
        ``<robot>/base_link`` (REP 105; ``<robot>``: the robot's full namespace without the leading slash).
    /tf (tf2_msgs/TFMessage): every step, each robot's ``<robot>/base_link`` in its ``<robot>/odom``; at the
        root, as tf2 expects, the frames being namespaced.
    /tf_static (tf2_msgs/TFMessage, transient-local): each robot's ``<robot>/odom`` in ``arena`` (identity),
        when the node is configured and again at each trial's start (as ``markers``), stamped then.
    swarm_state (swarm_msgs/SwarmState): the exact poses (mm), every sensing step, with whether each robot
        carries food and its deliveries in the trial, as it answered the step before.
    poses (geometry_msgs/PoseArray): the same poses in metres, frame ``arena``.

Subscriptions:
    <robot>/wheels (swarm_msgs/WheelCommand): each controller's answer to a step.
    <robot>/tree_status (swarm_msgs/TreeStatus): each tick's status, action and condition ticks.

Actions and services:
    ~/run_trial (swarm_msgs/action/RunTrial): run one trial, with the step as feedback; a goal with an arena
        configuration other than the trial's, or sent while the node is not active, is rejected at once. A
        cancel stops the trial after the step under way. Before its first step the simulator calls each
        controller's <robot>/start_trial (swarm_msgs/StartTrial).
    ~/run_trial (swarm_msgs/srv/RunTrial): the same without feedback or cancel, a thin wrapper.
    ~/inject_faults (swarm_msgs/srv/InjectFaults): per-robot faults (``ROBOT:KIND`` pairs) that replace the
        robots' faults from a given step of the trial under way (``LockstepChain.schedule_faults``; a step
        already begun: the next one), or from the next trial's start when none is under way, and stay for
        every later trial (live adaptation, ``evolution_manager``'s ``adapt-live``).
    ~/hold_step (swarm_msgs/srv/HoldStep): publish no step of the chain at or after a given step until a
        later hold replaces it (0 releases it; one left at the chain's end is dropped; one not replaced within
        ``answer_timeout`` abandons the trial): a client acts between two steps whatever the machine's speed
        (the adaptation node decides and swaps trees at each window's end).

Lockstep: after publishing a step's readings the simulator waits until every controller has answered that
step, so results do not depend on the machine's speed. The world itself is ``swarm_sim.roads.lockstep``.

Free (``timing:=free``, for free-running controllers, ``bt_controller``'s ``timing:=free`` under
``use_sim_time``): step ``j`` of a chain is published at ``j * step_dt / rate`` seconds of wall time after its
first, and the world then advances with each robot's latest ``wheels`` (its motors, broadcast and smoothed
values, carrying flag) whatever step it answered; a robot that has not answered yet is stopped and broadcasts
the model's initial values (``FreeAnswers``). The tree statuses received since the last tick step count at the
next tick step. Deliveries count from each trial's first step (a free controller keeps counting across a
chain's trials). A step the machine could not publish in time is published at once (``late steps`` on
``/diagnostics``, and a warning at the trial's end). The results depend on the machine's speed and load.
"""

from __future__ import annotations

import json
import threading
import time
from collections.abc import Sequence
from dataclasses import dataclass, fields, replace
from functools import partial
from pathlib import Path
from typing import Any

import numpy as np
from builtin_interfaces.msg import Time
from geometry_msgs.msg import PoseArray, PoseStamped
from nav_msgs.msg import Odometry
from rclpy.action import ActionServer, CancelResponse, GoalResponse
from rclpy.action.server import ServerGoalHandle
from rclpy.callback_groups import MutuallyExclusiveCallbackGroup, ReentrantCallbackGroup
from rclpy.client import Client
from rclpy.executors import MultiThreadedExecutor
from rclpy.lifecycle import LifecycleState, TransitionCallbackReturn
from rclpy.publisher import Publisher
from rclpy.qos import QoSProfile
from rclpy.subscription import Subscription
from rclpy.task import Future
from rosgraph_msgs.msg import Clock
from std_msgs.msg import Header
from visualization_msgs.msg import MarkerArray

from bt_controller.language import ACTIONS
from bt_controller.model_settings import chain_of_trial
from bt_controller.nodes.footbot_controller import ControllerSettings
from bt_controller.robot import Readings, timeline
from swarm_msgs.action import RunTrial as RunTrialAction
from swarm_msgs.msg import (
    GroundSensor,
    RangeAndBearing,
    RangeAndBearingReadings,
    RobotFaults,
    RobotPose,
    SwarmState,
    TreeStatus,
    TrialStart,
    WheelCommand,
)
from swarm_msgs.srv import HoldStep, InjectFaults, RunTrial, StartTrial
from swarm_ros.lifecycle import ManagedNode
from swarm_ros.names import NamespaceError, check_robot_namespaces, robot_frames, robot_namespaces
from swarm_ros.parameters import (
    ParameterError,
    check_file_values,
    declare,
    descriptor,
    field_names,
    start_node,
)
from swarm_ros.qos import LATCHED, NO_PUBLISHER_EVENTS, NO_SUBSCRIPTION_EVENTS, RELIABLE
from swarm_ros.services import call_until_answered
from swarm_ros.spinning import spin_until_shutdown
from swarm_sim.core import TrialRecord
from swarm_sim.errors import ConditionError, ConfigError, TrialAbandonedError
from swarm_sim.evaluation import fill, trial_fields
from swarm_sim.model import (
    DEFAULT,
    FAULT_FIELDS,
    Config,
    apply_conditions,
    carries_from_text,
    carries_to_text,
    fault_kinds_of,
    layout_from_text,
    layout_to_text,
    parse_fault_pairs,
)
from swarm_sim.nodes import visualisation
from swarm_sim.nodes.settings import RATE_RANGE, SENSINGS, TIMINGS, EvaluatorSettings
from swarm_sim.nodes.world_parameters import declare_world
from swarm_sim.roads import FreeAnswers, LockstepChain, RobotAnswer, warm_up
from tf2_msgs.msg import TFMessage

WORLD_RANGES = {
    "delivery_probability": (0.0, 1.0),
    "gain_low": (0.0, 10.0),
    "gain_step": (0.0, 1.0),
    "robot_types": (1, 2),
}
"""Closed ranges of world parameters beyond what ``Config`` checks itself."""
ANSWER_TIMEOUT_RANGE = (0.1, 86400.0)
"""Seconds the ``answer_timeout`` parameter may be."""
MATCH_WAIT = 2.0
"""Seconds a trial's start waits for the publishers to match every subscriber the graph knows of (a
recorder that has just joined), so that none misses the trial's first messages."""


class TrialCancelledError(RuntimeError):
    """The trial's goal was cancelled; the trial stopped after the step under way."""


@dataclass
class _Inbox:
    """The answers and tick statuses received for the step under way (filled by subscription callbacks)."""

    step: int = -1
    answers: dict[int, WheelCommand] | None = None
    statuses: dict[int, TreeStatus] | None = None


def _wait_for_future(future: Future, seconds: float) -> bool:
    """Wait up to ``seconds`` for ``future`` (another executor thread completes it); whether it is done."""
    done = threading.Event()
    future.add_done_callback(lambda _f: done.set())
    return done.wait(seconds)


class SimulatorNode(ManagedNode):
    """Owns the world; runs trials through the controllers over topics and services."""

    def __init__(self, config: Config = DEFAULT) -> None:
        super().__init__("simulator", "swarm_sim simulator")
        declared = declare_world(self, config, ranges=WORLD_RANGES)
        conditions: str = declare(
            self,
            "conditions",
            "",
            descriptor("changes to the world, NAME=VALUE separated by spaces", read_only=True),
        )
        self.config, self.conditions = apply_conditions(conditions.split(), declared)
        if self.config.n_robots != declared.n_robots:
            raise ConditionError(
                f"condition robots={self.config.n_robots} differs from n_robots ({declared.n_robots})"
            )
        self.robots: int = self.config.n_robots
        self.namespaces = check_robot_namespaces(
            declare(
                self,
                "robot_namespaces",
                robot_namespaces(self.robots),
                descriptor(
                    "the robots' namespaces, relative to the simulator's; robot i is the i-th", read_only=True
                ),
            )
        )
        if len(self.namespaces) != self.robots:
            raise NamespaceError(
                f"robot_namespaces names {len(self.namespaces)} robots but n_robots is {self.robots}: "
                "give one namespace per robot"
            )
        declare(
            self,
            "answer_timeout",
            60.0,
            descriptor(
                "seconds of wall time to wait for the controllers at any step (detects dead nodes)",
                read_only=False,
                value_range=ANSWER_TIMEOUT_RANGE,
            ),
        )
        self.timing: str = declare(
            self,
            "timing",
            "lockstep",
            descriptor(
                "lockstep: wait for every controller's answer to every step (exact); free: step at rate "
                "times real time with each robot's latest answer",
                read_only=True,
            ),
        )
        if self.timing not in TIMINGS:
            raise ParameterError(f"parameter timing := {self.timing!r}: expected one of {', '.join(TIMINGS)}")
        self.sensing: str = declare(
            self,
            "sensing",
            "model",
            descriptor(
                "model: publish each robot's readings; external: leave them to another node (the "
                "virtual-sensor bridge; free timing only)",
                read_only=True,
            ),
        )
        if self.sensing not in SENSINGS:
            raise ParameterError(
                f"parameter sensing := {self.sensing!r}: expected one of {', '.join(SENSINGS)}"
            )
        if self.sensing == "external" and self.timing != "free":
            raise ParameterError("parameter sensing := 'external' needs timing := 'free'")
        self.rate: float = declare(
            self,
            "rate",
            1.0,
            descriptor(
                "free timing: simulated seconds per second of wall time",
                read_only=True,
                value_range=RATE_RANGE,
            ),
        )
        self.free = FreeAnswers(self.robots, self.config.params().estimate_cap, self.config.regions)
        self.frames = robot_frames(self.get_namespace(), self.namespaces)
        """Each robot's (odom, base_link) frame ids, under its full namespace (REP 105)."""
        self._previous: list[tuple[float, float, float]] | None = None  # the step before's poses (odometry)
        self.late_steps = 0
        self._chain_start_ns = 0
        self.sim_time_ns = 0
        self.step_ns = round(self.config.step_dt * 1e9)
        self._lock = threading.Condition()
        self._busy = threading.Lock()  # one trial at a time, whether asked by the action or the service
        self._inbox = _Inbox()
        self._actions = ["stop"] * self.robots
        self._figures = threading.Lock()
        self.steps = 0
        self.trials = 0
        self.goals_waiting = 0
        self.trial_under_way = ""
        self._last = (time.monotonic(), 0)
        self._made: list[Any] = []  # what on_configure made, for release
        self._injected: tuple[int, Config] | None = None  # faults asked for, not yet taken by a chain
        self._chain_running = False
        self._hold = 0  # the first step of the chain not to publish (hold_step); 0: none
        self._action_server: ActionServer | None = None

    # --- lifecycle
    def on_configure(self, state: LifecycleState) -> TransitionCallbackReturn:
        warm_up(self.config)  # compile before offering the service, so no step waits for numba
        listeners = ReentrantCallbackGroup()
        publisher = self._publisher
        self._clock_publisher = publisher(Clock, "/clock")
        self._trial_start = publisher(TrialStart, "trial_start", LATCHED)
        self._markers = publisher(MarkerArray, "markers", LATCHED)
        self._robot_markers = publisher(MarkerArray, "robot_markers")
        self._state = publisher(SwarmState, "swarm_state")
        self._poses = publisher(PoseArray, "poses")
        self._tf = publisher(TFMessage, "/tf")
        self._tf_static = publisher(TFMessage, "/tf_static", LATCHED)
        self._faults = publisher(RobotFaults, "faults", LATCHED)
        self._ground: list[Publisher] = []
        self._readings: list[Publisher] = []
        self._pose: list[Publisher] = []
        self._odom: list[Publisher] = []
        self._start_clients: list[Client] = []
        for i, ns in enumerate(self.namespaces):
            self._ground.append(publisher(GroundSensor, f"{ns}/ground"))
            self._readings.append(publisher(RangeAndBearingReadings, f"{ns}/range_and_bearing"))
            self._pose.append(publisher(PoseStamped, f"{ns}/pose"))
            self._odom.append(publisher(Odometry, f"{ns}/odom"))
            for msg_class, topic, callback in (
                (WheelCommand, f"{ns}/wheels", self._on_wheels),
                (TreeStatus, f"{ns}/tree_status", self._on_status),
            ):
                subscription = self.create_subscription(
                    msg_class,
                    topic,
                    partial(callback, i),
                    RELIABLE,
                    callback_group=listeners,
                    event_callbacks=NO_SUBSCRIPTION_EVENTS,
                )
                self._made.append(subscription)
            self._start_clients.append(
                self.create_client(StartTrial, f"{ns}/start_trial", callback_group=listeners)
            )
        self._made += self._start_clients
        self._observers = [self._state, self._poses, self._tf, self._robot_markers, *self._pose, *self._odom]
        trials = MutuallyExclusiveCallbackGroup()
        self._made.append(
            self.create_service(RunTrial, "~/run_trial", self._on_run_trial, callback_group=trials)
        )
        self._made.append(
            self.create_service(
                InjectFaults, "~/inject_faults", self._on_inject_faults, callback_group=listeners
            )
        )
        self._made.append(
            self.create_service(HoldStep, "~/hold_step", self._on_hold_step, callback_group=listeners)
        )
        self._action_server = ActionServer(
            self,
            RunTrialAction,
            "~/run_trial",
            self._execute_trial,
            callback_group=trials,
            goal_callback=self._on_goal,
            cancel_callback=lambda _request: CancelResponse.ACCEPT,
        )
        self._markers.publish(visualisation.arena_markers(self.config, 0, self._stamp()))
        self._tf_static.publish(static_frames(self._stamp(), self.frames))
        self.get_logger().info(
            f"ready: {self.robots} robots in {', '.join(self.namespaces)}; run_trial action and service"
        )
        return TransitionCallbackReturn.SUCCESS

    def release(self) -> None:
        if self._action_server is not None:
            self._action_server.destroy()
            self._action_server = None
        for entity in reversed(self._made):
            if isinstance(entity, Publisher):
                self.destroy_publisher(entity)
            elif isinstance(entity, Subscription):
                self.destroy_subscription(entity)
            elif isinstance(entity, Client):
                self.destroy_client(entity)
            else:
                self.destroy_service(entity)
        self._made.clear()

    def diagnostics_stamp(self) -> Time:
        """Diagnostics are stamped in simulated time, as everything else the simulator publishes."""
        return self._stamp()

    def diagnostic_values(self) -> dict[str, str]:
        now = time.monotonic()
        with self._figures:
            (then, before), steps = self._last, self.steps
            self._last = (now, steps)
            values = {
                "trial": self.trial_under_way or "none",
                "trials run": str(self.trials),
                "goals waiting": str(self.goals_waiting),
                "timing": self.timing if self.timing == "lockstep" else f"free at {self.rate} x real time",
            }
            if self.timing == "free":
                values["late steps"] = str(self.late_steps)
        rate = (steps - before) / (now - then) if now > then else 0.0
        return {**values, "steps per second": f"{rate:.1f}"}

    def _publisher(self, msg_class: type, topic: str, qos: QoSProfile = RELIABLE) -> Publisher:
        # no rclpy default event handlers: they cost this many-topic node most of its CPU (swarm_ros.qos)
        publisher: Publisher = self.create_publisher(
            msg_class, topic, qos, event_callbacks=NO_PUBLISHER_EVENTS
        )
        self._made.append(publisher)
        return publisher

    @property
    def answer_timeout(self) -> float:
        """The ``answer_timeout`` parameter as it is now (it may be set while the node runs)."""
        return float(self.get_parameter("answer_timeout").value)

    # --- subscriptions
    def _on_wheels(self, robot: int, msg: WheelCommand) -> None:
        if msg.robot != robot:
            self._wrong_robot(robot, msg.robot)
            return
        with self._lock:
            inbox = self._inbox
            if self.timing == "free":
                if inbox.answers is not None and self._of_this_chain(msg.header):  # a chain is under way
                    self.free.answer(robot, robot_answer(msg))
                return
            if inbox.answers is not None and msg.step == inbox.step:
                inbox.answers[robot] = msg
                self._lock.notify_all()

    def _on_status(self, robot: int, msg: TreeStatus) -> None:
        if msg.robot != robot:
            self._wrong_robot(robot, msg.robot)
            return
        with self._lock:
            inbox = self._inbox
            if self.timing == "free":
                if inbox.statuses is not None and self._of_this_chain(msg.header):
                    self.free.status(robot, msg.condition_ticks, msg.action)
                return
            if inbox.statuses is not None and msg.step == inbox.step:
                inbox.statuses[robot] = msg
                self._lock.notify_all()

    def _of_this_chain(self, header: Header) -> bool:
        """Free timing: whether an answer was stamped in the chain under way (a free controller stamps with
        its clock, the graph's simulated time, which the chain's first step sets to its start): an answer of
        an earlier chain still in flight, its deliveries counted from that chain's start, is dropped."""
        return header.stamp.sec * 1_000_000_000 + header.stamp.nanosec >= self._chain_start_ns

    def _wrong_robot(self, robot: int, claimed: int) -> None:
        self.get_logger().error(
            f"the controller in {self.namespaces[robot]} says it is robot {claimed}, but robot_namespaces "
            f"puts robot {robot} there: start it with -p robot:={robot} or in the namespace of robot "
            f"{claimed}",
            throttle_duration_sec=5.0,
        )

    # --- the action and the service
    def arena_of(self, trial: int) -> int:
        """The arena configuration of trial ``trial`` (``docs/model.md``: blocks of ``chain_trials``)."""
        return self.config.arena_of_trial(trial)

    def goal_problem(self, request: Any) -> str:  # a RunTrial goal or request (generated, untyped)
        """Why the trial ``request`` asks for cannot be run, or ""."""
        if not self.active:
            return f"{self.get_name()} is not active ({self.state})"
        arena, trial = int(request.arena_configuration), int(request.trial)
        configurations = len(self.config.arena_layout)
        if arena not in (-1, *range(configurations)):
            return f"arena_configuration must be -1 or 0..{configurations - 1}, got {arena}"
        if arena >= 0 and arena != self.arena_of(trial):
            own = self.arena_of(trial)
            return f"trial {trial} uses arena configuration {own}, not {arena} (-1 means its own)"
        return ""

    def _on_goal(self, request: Any) -> GoalResponse:  # a RunTrial goal (generated, untyped)
        problem = self.goal_problem(request)
        if problem:
            self.get_logger().error(f"rejected a goal: {problem}")
            return GoalResponse.REJECT
        with self._figures:
            self.goals_waiting += 1
        return GoalResponse.ACCEPT

    def _run(self, request: Any, result: Any, goal: ServerGoalHandle | None = None) -> Any:  # ROS messages
        """Run the trial ``request`` asks for into ``result`` (the action's result or the service's
        response), with feedback and cancel when ``goal`` is the action's goal."""
        try:
            seed, trial = int(request.seed), int(request.trial)
            problem = self.goal_problem(request)
            if problem:
                raise TrialAbandonedError(problem)
            with self._busy:
                record = self.run_trial(seed, trial, goal)
        except (TrialAbandonedError, TrialCancelledError, ValueError) as error:
            result.success = False
            result.message = str(error)
            if isinstance(error, TrialCancelledError):
                self.get_logger().info(result.message)
            else:
                self.get_logger().error(result.message)
            return result
        return fill(result, trial_fields(record, RobotPose))

    def _on_inject_faults(
        self, request: InjectFaults.Request, response: InjectFaults.Response
    ) -> InjectFaults.Response:
        """Faults that strike from a step of the trial under way (or of the next one), and stay."""
        try:
            pairs = parse_fault_pairs(request.faults, self.robots)
        except ConfigError as error:
            response.success, response.message = False, f"inject_faults: {error}"
            self.get_logger().error(response.message)
            return response
        with self._lock:
            config = replace(self.config, fault_rate=0.0, fault_kinds=(), fault_robots=pairs)
            step = int(request.at_step)
            if not self._chain_running and step <= 1:
                self.config = config  # from the next trial's start
            else:
                self._injected = (step, config)
        self.get_logger().info(f"faults {request.faults or 'none'} from step {max(step, 1)}")
        response.success = True
        return response

    def _on_hold_step(self, request: HoldStep.Request, response: HoldStep.Response) -> HoldStep.Response:
        """Hold the chain before step ``request.step`` (0: release), replacing any hold."""
        with self._lock:
            self._hold = int(request.step)
            self._lock.notify_all()
        response.success = True
        return response

    def _wait_while_held(self, step: int, goal: ServerGoalHandle | None) -> None:
        """Wait while a hold forbids publishing ``step`` (``hold_step``); a cancel or deactivation ends the
        wait (the loop then stops the trial). TrialAbandonedError when no later hold came in
        ``answer_timeout``."""
        timeout = self.answer_timeout
        deadline = time.monotonic() + timeout
        with self._lock:
            while 0 < self._hold <= step:
                if (goal is not None and goal.is_cancel_requested) or not self.active:
                    return
                left = deadline - time.monotonic()
                if left <= 0:
                    raise TrialAbandonedError(
                        f"held before step {step} for {timeout} s: no later hold came (is the holder gone?)"
                    )
                self._lock.wait(min(0.1, left))  # woken by hold_step; a cancel is seen within 0.1 s

    def _publish_faults(self, world: LockstepChain, step: int, codes: np.ndarray) -> None:
        self._faults.publish(
            RobotFaults(
                header=self._header("arena"),
                seed=world.seed,
                trial=world.trial,
                step=step,
                kinds=fault_kinds_of([int(c) for c in codes]),
            )
        )

    def _on_run_trial(self, request: RunTrial.Request, response: RunTrial.Response) -> RunTrial.Response:
        return self._run(request, response)

    def _execute_trial(self, goal: ServerGoalHandle) -> RunTrialAction.Result:
        with self._figures:
            self.goals_waiting -= 1
        result = self._run(goal.request, RunTrialAction.Result(), goal)
        if goal.is_cancel_requested:
            goal.canceled()
        elif result.success:
            goal.succeed()
        else:
            goal.abort()
        return result

    def run_trial(self, seed: int, trial: int, goal: ServerGoalHandle | None = None) -> TrialRecord:
        """Run trial ``trial`` of ``seed`` through the controllers; return its record. As
        ``swarm_sim.roads.lockstep.run_with_controllers`` does in-process, the trial's chain is run from its
        first trial up to ``trial``, every step published. With the action's ``goal``, publish the step as
        feedback and stop with ``TrialCancelledError`` when it is cancelled."""
        chain, position = chain_of_trial(self.config.timeline, trial)
        world = LockstepChain(seed, chain, position + 1, self.config)
        with self._figures:
            self.trial_under_way = f"trial {trial} of seed {seed}"
        with self._lock:
            self._chain_running = True
        try:
            return self._run_chain(world, seed, trial, goal)
        finally:
            with self._lock:
                self._chain_running = False
                self._hold = 0
            with self._figures:
                self.trial_under_way = ""
                self.trials += 1

    def _run_chain(
        self, world: LockstepChain, seed: int, trial: int, goal: ServerGoalHandle | None
    ) -> TrialRecord:
        steps = world.last_step
        self._start_controllers(world, seed)
        self._actions = ["stop"] * self.robots
        self._wait_for_subscribers()
        self._markers.publish(visualisation.arena_markers(self.config, world.trial, self._stamp()))
        self._tf_static.publish(static_frames(self._stamp(), self.frames))
        with self._lock:
            self._inbox = _Inbox(step=world.step, answers={}, statuses={})
            self.free.regions = self.config.regions  # (the world may have changed since the last chain)
            self.free.start_chain()
            self._chain_start_ns = self.sim_time_ns
        self._trial_start.publish(
            trial_start_message(world, self._stamp(), seed, trial, self.robots, self.config)
        )
        self._publish_faults(world, world.step, world.setup.faults)
        record: TrialRecord | None = None
        late = 0
        started = time.monotonic()
        published = 0
        while not world.done:
            self._wait_while_held(world.step, goal)
            if goal is not None and goal.is_cancel_requested:
                with self._lock:
                    self._inbox = _Inbox()
                raise TrialCancelledError(f"trial {trial} of seed {seed} cancelled at step {world.step}")
            if not self.active:
                with self._lock:
                    self._inbox = _Inbox()
                raise TrialAbandonedError(
                    f"trial {trial} of seed {seed} abandoned at step {world.step}: the simulator was "
                    "deactivated"
                )
            if regions_change(world):  # a later trial of the chain on other regions
                self._markers.publish(visualisation.arena_markers(self.config, world.trial, self._stamp()))
            if self.timing == "free" and timeline.step_in_trial(world.line, world.step) == 1:
                with self._lock:
                    self.free.begin_trial()
            self._publish_step(world, seed)
            published += 1
            if goal is not None:
                goal.publish_feedback(RunTrialAction.Feedback(step=world.step, steps=steps))
            if self.timing == "free":
                late += not self._sleep_until(started + published * self.config.step_dt / self.rate)
                with self._lock:
                    robot_answers = self.free.answers(world.ticks_now())
            else:
                robot_answers = self._lockstep_answers(world.step, world.ticks_now())
            for i, answer in enumerate(robot_answers):
                if not 0 <= answer.action < len(ACTIONS):
                    raise TrialAbandonedError(
                        f"{self.namespaces[i]} answered step {world.step} with action {answer.action}; "
                        f"expected 0..{len(ACTIONS) - 1}"
                    )
            self._actions = [ACTIONS[a.action] for a in robot_answers]
            with self._lock:
                injected, self._injected = self._injected, None
            if injected is not None:
                world.schedule_faults(injected[1], injected[0])
            changes = len(world.fault_changes)
            record = world.advance(robot_answers)
            self.sim_time_ns += self.step_ns
            if len(world.fault_changes) > changes:  # injected faults struck at this new step
                self.config = world.config
                self._publish_faults(world, *world.fault_changes[-1])
            with self._figures:
                self.steps += 1
            with self._lock:
                self._inbox = _Inbox(step=world.step, answers={}, statuses={}) if not world.done else _Inbox()
        assert record is not None and record.trial == trial, "the chain's last record is the trial asked for"
        if late:
            with self._figures:
                self.late_steps += late
            self.get_logger().warning(
                f"free timing: {late} of {published} steps of trial {trial} of seed {seed} were published "
                f"late (this machine did not keep {self.rate} times real time)"
            )
        return record

    def _lockstep_answers(self, step: int, ticks: bool) -> list[RobotAnswer]:
        """Lockstep: every robot's answer to ``step`` (and its tree status at a tick step), waited for."""
        answers = self._await_answers(step)
        statuses = self._await_statuses(step) if ticks else None
        return [robot_answer(a, statuses[i] if statuses is not None else None) for i, a in enumerate(answers)]

    def _sleep_until(self, deadline: float) -> bool:
        """Free timing: wait until ``deadline`` (``time.monotonic``); whether it was still ahead."""
        ahead = deadline - time.monotonic()
        if ahead <= 0:
            return False
        with self._lock:  # woken early by nothing: the answers come in under the same lock meanwhile
            self._lock.wait_for(lambda: time.monotonic() >= deadline, ahead)
        return True

    # --- steps
    def _start_controllers(self, world: LockstepChain, seed: int) -> None:
        p = world.p
        futures = []
        for i, client in enumerate(self._start_clients):
            if not client.wait_for_service(timeout_sec=self.answer_timeout):
                raise TrialAbandonedError(
                    f"robot {i}'s start_trial service ({client.srv_name}) is not available: is its "
                    "controller running in that namespace?"
                )
            request = StartTrial.Request(
                seed=seed,
                trial=world.setup.first_trial,
                tree_key=int(world.setup.tree_keys[i]),
                profile=self.config.profile,
                steps_per_tick=p.steps_per_tick,
                ticks=p.ticks,
                initial_step=p.initial_step,
                chain_trials=p.chain_trials,
                trials=world.trials,
                window=p.window,
                estimate_cap=p.estimate_cap,
                density_range=p.density_range,
                density_divisor=p.density_divisor,
                food_kinds=p.regions - 1,
                authors_code=p.authors_code,
                wheel_speed=p.wheel_speed * visualisation.MM,
                wheel_separation=self.config.wheel_separation * visualisation.MM,
            )
            futures.append((client, request, client.call_async(request)))
        deadline = time.monotonic() + self.answer_timeout
        for i, (client, request, sent) in enumerate(futures):
            # start_trial may be repeated: a request without an answer is sent again (swarm_ros.services)
            timeout = max(0.0, deadline - time.monotonic())
            response = call_until_answered(client, request, _wait_for_future, timeout, sent=sent)
            if response is None:
                raise TrialAbandonedError(f"{self.namespaces[i]} did not answer start_trial")
            if not response.success:
                raise TrialAbandonedError(f"{self.namespaces[i]} cannot run the trial: {response.message}")

    def _wait_for_subscribers(self) -> None:
        """Wait (at most ``MATCH_WAIT`` s) until every publisher has matched each subscription the graph knows
        of, so that a recorder that joined just before the trial gets its first messages."""
        publishers = [self._clock_publisher, self._trial_start, self._state, *self._ground, *self._readings]
        deadline = time.monotonic() + MATCH_WAIT
        while time.monotonic() < deadline and any(
            p.get_subscription_count() < self.count_subscribers(p.topic_name) for p in publishers
        ):
            time.sleep(0.01)

    def _observed(self) -> bool:
        """Whether any subscription listens to what only observers read (the swarm's state, poses, frames
        and markers: a recorder, RViz, the virtual-sensor bridge). A trial nobody watches builds and
        publishes the robots' readings alone, about a third less of the simulator's work at a step."""
        return any(p.get_subscription_count() > 0 for p in self._observers)

    def _publish_step(self, world: LockstepChain, seed: int) -> None:
        stamp = self._stamp()
        self._clock_publisher.publish(Clock(clock=stamp))
        base_links = [b for _, b in self.frames]
        sensed: tuple[list[GroundSensor], list[RangeAndBearingReadings]] | None = None
        if self._observed():
            messages = step_messages(
                world, stamp, seed, self.namespaces, self._actions, self.config, base_links
            )
            self._state.publish(messages.state)
            self._poses.publish(messages.poses)
            for publisher, pose in zip(self._pose, messages.pose, strict=True):
                publisher.publish(pose)
            odometry, transforms, self._previous = frame_messages(
                world, stamp, self._previous, self.frames, self.config.step_dt
            )
            for publisher, odom in zip(self._odom, odometry, strict=True):
                publisher.publish(odom)
            self._tf.publish(transforms)
            self._robot_markers.publish(messages.robot_markers)
            sensed = messages.ground, messages.readings
        else:
            # the poses are kept all the same: a subscriber that joins at the next step gets its velocity
            self._previous = step_poses(world)
        if self.sensing == "external":  # another node senses (the virtual-sensor bridge)
            return
        ground, readings = sensed or reading_messages(world.readings(), stamp, world.step, base_links)
        for i in range(len(self.namespaces)):
            self._ground[i].publish(ground[i])
            self._readings[i].publish(readings[i])

    def _await_answers(self, step: int) -> list[WheelCommand]:
        with self._lock:
            answers = self._inbox.answers
            assert answers is not None, "answers are awaited only during a step"
            if not self._lock.wait_for(lambda: len(answers) == self.robots, self.answer_timeout):
                missing = sorted(set(range(self.robots)) - set(answers))
                raise TrialAbandonedError(
                    f"no answer to step {step} from {', '.join(self.namespaces[i] for i in missing)} "
                    f"in {self.answer_timeout} s"
                )
            return [answers[i] for i in range(self.robots)]

    def _await_statuses(self, step: int) -> list[TreeStatus]:
        """Every robot's tree status of the tick at ``step`` (published beside its answer, on another
        topic, so it may come after it)."""
        with self._lock:
            statuses = self._inbox.statuses
            assert statuses is not None, "statuses are awaited only during a step"
            if not self._lock.wait_for(lambda: len(statuses) == self.robots, self.answer_timeout):
                missing = sorted(set(range(self.robots)) - set(statuses))
                raise TrialAbandonedError(
                    f"no tree status of the tick at step {step} from "
                    f"{', '.join(self.namespaces[i] for i in missing)} in {self.answer_timeout} s"
                )
            return [statuses[i] for i in range(self.robots)]

    def _stamp(self) -> Time:
        return Time(sec=self.sim_time_ns // 1_000_000_000, nanosec=self.sim_time_ns % 1_000_000_000)

    def _header(self, frame: str) -> Header:
        return Header(stamp=self._stamp(), frame_id=frame)


def reading_messages(
    readings: Sequence[Readings], stamp: Time, step: int, frames: Sequence[str]
) -> tuple[list[GroundSensor], list[RangeAndBearingReadings]]:
    """Each robot's ``ground`` and ``range_and_bearing`` messages of sensing step ``step`` from its
    ``readings``, stamped ``stamp`` in its frame (``frames``: each robot's ``base_link``). The simulator and
    the virtual-sensor bridge publish these."""
    ground: list[GroundSensor] = []
    readings_of: list[RangeAndBearingReadings] = []
    for i, sensed in enumerate(readings):
        header = Header(stamp=stamp, frame_id=frames[i])
        inside = [bool(g) for g in sensed.ground]
        ground.append(
            GroundSensor(
                header=header,
                step=step,
                in_nest=inside[0],
                on_food=inside[1],
                on_other_food=inside[2:],
                footing=[] if sensed.footing is None else [bool(f) for f in sensed.footing],
            )
        )
        messages = [
            RangeAndBearing(
                sender=int(s),
                range=r,
                bearing=b,
                nest_estimate=v[0],
                food_estimate=v[1],
                other_food_estimates=v[2:],
            )
            for s, r, b, v in zip(
                sensed.senders.tolist(),
                sensed.ranges.tolist(),
                sensed.bearings.tolist(),
                sensed.values.tolist(),
                strict=True,
            )
        ]
        readings_of.append(RangeAndBearingReadings(header=header, step=step, readings=messages))
    return ground, readings_of


def robot_answer(msg: WheelCommand, status: TreeStatus | None = None) -> RobotAnswer:
    """A controller's ``wheels`` message as the world takes it, with its tick's ``status`` if it ticked (the
    kind-1 fields, then those of the other food kinds)."""
    return RobotAnswer(
        action=int(msg.action),
        broadcast=(msg.nest_estimate, msg.food_estimate, *msg.other_food_estimates),
        smoothed=(msg.smoothed_nest, msg.smoothed_food, msg.smoothed_density, *msg.smoothed_other_food),
        condition_ticks=status.condition_ticks if status is not None else 0,
        started=status.action if status is not None else -1,
        carrying=(bool(msg.carrying), *(bool(c) for c in msg.carrying_other_food)),
        deliveries=(int(msg.deliveries), *(int(d) for d in msg.other_food_deliveries)),
    )


def carrying_any(carrying: np.ndarray) -> list[bool]:
    """Per robot, whether it carries food of any kind (``carrying``: robots x food kinds)."""
    return [bool(row.any()) for row in carrying]


@dataclass(frozen=True)
class StepMessages:
    """What the simulator publishes at one step besides the clock: the swarm's state, its poses (all, and
    per robot), the robots' markers, and each robot's ground sensor and range-and-bearing readings."""

    state: SwarmState
    poses: PoseArray
    pose: list[PoseStamped]
    robot_markers: MarkerArray
    ground: list[GroundSensor]
    readings: list[RangeAndBearingReadings]


def step_messages(
    world: LockstepChain,
    stamp: Time,
    seed: int,
    namespaces: Sequence[str],
    actions: Sequence[str],
    config: Config,
    frames: Sequence[str],
) -> StepMessages:
    """The messages of the step ``world`` is at, stamped ``stamp``; ``actions``: each robot's action of the
    step before (its marker's label); ``frames``: each robot's ``base_link`` frame id
    (``swarm_ros.names.robot_frames``),
    the frame of its readings. The node publishes these; ``replay --verify`` compares a recording with those
    of a re-run."""
    poses = world.poses()
    listed = poses.tolist()
    state = SwarmState(
        header=Header(stamp=stamp, frame_id="arena"),
        seed=seed,
        trial=world.trial,
        step=world.step,
        poses=[RobotPose(x=x, y=y, theta=t) for x, y, t in listed],
        carrying=carrying_any(world.carrying),
        deliveries=[int(d) for d in world.deliveries.sum(axis=1)],
    )
    arena_poses = PoseArray(
        header=Header(stamp=stamp, frame_id=visualisation.FRAME),
        poses=[visualisation.pose_in_metres(*q) for q in listed],
    )
    markers = visualisation.robot_markers(
        config,
        stamp,
        listed,
        list(namespaces),
        list(actions),
        carrying_any(world.carrying),
        [int(d) for d in world.deliveries.sum(axis=1)],
        [int(row.argmax()) + 1 if row.any() else 0 for row in world.carrying],
    )
    ground, readings_of = reading_messages(world.readings(), stamp, world.step, frames)
    return StepMessages(
        state,
        arena_poses,
        [visualisation.pose_stamped(stamp, *q) for q in listed],
        markers,
        ground,
        readings_of,
    )


def static_frames(stamp: Time, frames: Sequence[tuple[str, str]]) -> TFMessage:
    """The ``/tf_static`` message: each robot's ``odom`` frame in ``arena``, the identity (the simulator's
    odometry does not drift)."""
    return TFMessage(
        transforms=[
            visualisation.transform(stamp, visualisation.FRAME, odom, 0.0, 0.0, 0.0) for odom, _ in frames
        ]
    )


Poses = list[tuple[float, float, float]]
"""Each robot's (x mm, y mm, heading rad)."""


def step_poses(world: LockstepChain) -> Poses:
    """Each robot's pose at the step ``world`` is at."""
    return [(x, y, t) for x, y, t in world.poses().tolist()]


def frame_messages(
    world: LockstepChain, stamp: Time, previous: Poses | None, frames: Sequence[tuple[str, str]], dt: float
) -> tuple[list[Odometry], TFMessage, Poses]:
    """Each robot's odometry and the ``/tf`` message of the step ``world`` is at, stamped ``stamp``, and the
    poses to pass as ``previous`` at the next step. A robot's velocity is over the step from ``previous``
    (``dt`` seconds), zero at a trial's first step (the robots are placed) or without ``previous``. The node
    publishes these; ``replay --verify`` compares a recording with those of a re-run."""
    poses = step_poses(world)
    placed = timeline.step_in_trial(world.line, world.step) == 1  # teleported: no velocity
    odometry = [
        visualisation.odometry(
            stamp, pose, None if placed or previous is None else previous[i], dt, odom, base
        )
        for i, (pose, (odom, base)) in enumerate(zip(poses, frames, strict=True))
    ]
    transforms = TFMessage(
        transforms=[
            visualisation.transform(stamp, odom, base, *pose)
            for (odom, base), pose in zip(frames, poses, strict=True)
        ]
    )
    return odometry, transforms, poses


def regions_change(world: LockstepChain) -> bool:
    """Whether the current step starts a later trial of the chain on other regions than the trial before
    (``Config.arena_entry``): the simulator then publishes the new regions' markers (a chain's first ones go
    out at its start)."""
    config = world.config
    return (
        world.step > 1
        and timeline.step_in_trial(world.line, world.step) == 1
        and config.arena_entry(world.trial) != config.arena_entry(world.trial - 1)
    )


def trial_start_message(
    world: LockstepChain, stamp: Time, seed: int, trial: int, robots: int, config: Config
) -> TrialStart:
    """The latched message that opens trial ``trial`` of ``seed`` (published before its first step)."""
    return TrialStart(
        header=Header(stamp=stamp, frame_id="arena"),
        seed=seed,
        trial=trial,
        arena_configuration=config.arena_of_trial(trial),
        robots=robots,
        tree_keys=[int(k) for k in world.setup.tree_keys],
        ticks=world.p.ticks,
        world=json.dumps(config.as_dict()),
    )


SHARED = field_names(EvaluatorSettings) | field_names(ControllerSettings)
"""Parameters of the graph's other nodes that a ``/**`` section of a shared parameter file may hold."""


def check_parameter_file(path: Path, fully_qualified_name: str, config: Config) -> Config:
    """Check, before any node starts, what the parameter file ``path`` gives the simulator node
    ``fully_qualified_name`` whose world would otherwise be ``config``: every value of a parameter it
    declares, its type and range, the world it makes (``Config``'s checks), and names it does not declare,
    as the node checks them when it starts (``ParameterError`` or ``ConfigError`` in one line); return
    that world."""
    declared: dict[str, tuple[Any, tuple[float, float] | None]] = {
        f.name: (getattr(config, f.name), WORLD_RANGES.get(f.name))
        for f in fields(config)
        if f.name not in FAULT_FIELDS
    }
    declared["layout"] = (layout_to_text(config.layout), None)
    declared["carries"] = (carries_to_text(config.carries), None)
    declared["conditions"] = ("", None)
    declared["robot_namespaces"] = (tuple(robot_namespaces(config.n_robots)), None)
    declared["answer_timeout"] = (60.0, ANSWER_TIMEOUT_RANGE)
    declared["timing"] = ("lockstep", None)
    declared["rate"] = (1.0, RATE_RANGE)
    given = check_file_values(path, fully_qualified_name, declared, SHARED)
    world: dict[str, Any] = {
        name: tuple(value) if isinstance(value, list) else value
        for name, value in given.items()
        if name in {f.name for f in fields(config)} - set(FAULT_FIELDS)
    }
    try:
        if "layout" in world:
            world["layout"] = layout_from_text(world["layout"])
        if "carries" in world:
            world["carries"] = carries_from_text(world["carries"])
        return replace(config, **world)
    except ConfigError as error:
        raise ConfigError(f"{path}: {error}") from None


def main(args: list[str] | None = None) -> None:
    """Run the simulator node until shut down; a bad parameter is a one-line error and exit status 2."""
    errors = (ConfigError, ConditionError, NamespaceError)
    node = start_node("simulator", SimulatorNode, args, shared=SHARED, errors=errors)
    node.start()
    spin_until_shutdown(node, MultiThreadedExecutor(num_threads=4))
