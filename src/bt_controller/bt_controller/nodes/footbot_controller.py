"""The footbot controller node: one footbot's perception and behaviour tree, in the robot's namespace.

Node ``footbot_controller``, started in the robot's namespace: ``--ros-args -r __ns:=/footbot_<i>`` (or
``/<graph>/footbot_<i>``); every name it uses is relative to it. Executable ``footbot_controller`` runs one
node; ``footbot_controllers --node --ros-args ... --node --ros-args ...`` runs several in one process, each
with only its own arguments (``main_many``: what ``trial`` starts by default).

Parameters (``config/bt_controller.yaml``; ``ControllerSettings``; a bad value, type or name stops the node
with one line, exit status 2):
    robot (int, read-only): the robot's index i, its position in the simulator's ``robot_namespaces``.
        Default -1: taken from the namespace, whose last part must then be ``footbot_<i>``. When both are
        given they must agree: ``__ns:=/footbot_4 -p robot:=0`` stops the node with an error saying so.
    tree (string, read-only): a tree to load at start (default: none; use the load_tree service); a network's
        text, ``nn(w1, ..., w56)`` (``bt_controller.interpreters.network``), loads that network instead (so
        does the load_tree service's).
    network (string, read-only): a network file (JSON ``{"weights": [56 numbers]}``) to load at start
        (default: none); not with ``tree``. A file that cannot be used stops the node with one line, exit
        status 2.
    library (string, read-only): a primitive library file (``bt_controller.language.library``) whose
    primitives'
        names the trees may use (default: none). A path: the library is fixed for the node's life, as its
        other parameters; a library that cannot be read stops the node with one line, exit status 2.
    commands (string, read-only): what each step's answer is published as: ``wheels`` (default; what the
        simulator waits for), ``cmd_vel``, or ``both``.
    cmd_vel_type (string, read-only): ``TwistStamped`` (default, what ros2_control's diff_drive_controller
        takes since Jazzy) or ``Twist`` (older bases).
    timing (string, read-only): ``lockstep`` (default): answer every sensing step of the simulator, exactly;
        ``free``: tick on the node's own timer at ``tick_rate`` against the latest sensing, as on a robot
        (``bt_controller.robot.free_running``: the policy for lost, late and duplicated readings), the timer
        on the node's clock (simulated time under ``use_sim_time``, else wall time).
    tick_rate (float, Hz, read-only, free only): the tree's ticks per second (default 2.0).
    sensing_timeout (float, s, read-only, free only): after this long without a complete sensing step the
        robot is stopped (zero command every tick), with a warning and a WARN on ``/diagnostics`` (default
        1.0: eight sensing periods).
    sensor_qos (string, read-only): reliability of the ``ground`` and ``range_and_bearing`` subscriptions:
        ``reliable``, ``best_effort`` (takes both reliable and best-effort publishers, e.g. a driver's
        ``qos_profile_sensor_data``), or ``auto`` (default: reliable in lockstep, where no reading may be
        lost; best-effort when free).
    default_wheel_speed, default_wheel_separation (float, m/s and m, read-only, free only): the wheels'
        speed and separation until a ``start_trial`` gives the trial's (defaults 0.05 and 0.14, the
        footbot's; not ``wheel_speed``, the simulator's, in mm/s).

Subscriptions (relative names, in the robot's namespace):
    ground (swarm_msgs/GroundSensor) and range_and_bearing (swarm_msgs/RangeAndBearingReadings): the
        simulator's readings; in lockstep a step is answered once both of its messages have arrived (a
        reading of a later step while one is missing is logged as a stall, once); free, a step is sensed once
        both are in and the tree ticks on the timer.

Publishers:
    wheels (swarm_msgs/WheelCommand): the answer to every sensing step: the action under way (index and
        name), its wheel speeds in m/s, the broadcast and smoothed estimates, whether it carries food and its
        deliveries in the trial so far. Its header (and ``tree_status``'s) is the answered ground reading's
        in lockstep, the tick's time in the robot's ``<namespace>/base_link`` when free: the same frame.
    cmd_vel (geometry_msgs/TwistStamped, or Twist with ``cmd_vel_type:=Twist``; with ``commands`` cmd_vel or
        both): the same step's wheel speeds as a velocity of the robot's base (REP 103): ``linear.x = (left +
        right) / 2`` in m/s and ``angular.z = (right - left) / wheel_separation`` in rad/s, anticlockwise
        positive, with the wheel separation the trial's ``start_trial`` gives; a differential-drive robot can
        be driven by it. Stamped with the step's time (lockstep) or the tick's (free), in the robot's base
        frame ``<namespace>/base_link`` (``swarm_ros.names.robot_frame``).
    tree_status (swarm_msgs/TreeStatus): the result of every tick (2 Hz in simulated time).
    /diagnostics (diagnostic_msgs/DiagnosticArray, free only): every second of steady time, and at once when
        the sensing times out: OK while sensing, WARN when timed out or before the first reading; the steps
        used, lost, late and duplicated, and the seconds since the newest one.

Services:
    load_tree (swarm_msgs/LoadTree): parse, validate and load a tree (a clear error for a bad one); with
        ``from_step`` N > 0 (lockstep), swap it in from step N of the chain under way (live adaptation:
        ``FootbotController.swap_at``).
    start_trial (swarm_msgs/StartTrial): reset for a chain of trials (called by the simulator).

The node keeps the 7-sample smoothing and the blackboard from its topics and ticks its tree with the reference
interpreter; the logic is ``bt_controller.robot.controller``.
"""

from __future__ import annotations

import sys
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus, KeyValue
from geometry_msgs.msg import Twist, TwistStamped, Vector3
from rclpy.clock import Clock, ClockType
from rclpy.node import Node as RosNode
from rclpy.qos import QoSProfile, ReliabilityPolicy
from std_msgs.msg import Header

from bt_controller.errors import TreeError
from bt_controller.interpreters import (
    Network,
    NetworkError,
    controller_text,
    load_network,
    parse_controller,
)
from bt_controller.language import ACTIONS, MAX_FOOD_KINDS, Library, LibraryError, Node, load_library
from bt_controller.model_settings import PerceptionParams, Timeline, check_authors_code, profile_number
from bt_controller.robot import (
    FootbotController,
    FreeRunningController,
    FreeTick,
    Readings,
    StepOutcome,
    warm_up,
)
from swarm_msgs.msg import GroundSensor, RangeAndBearingReadings, TreeStatus, WheelCommand
from swarm_msgs.srv import LoadTree, StartTrial
from swarm_ros.names import NamespaceError, robot_frame, robot_index
from swarm_ros.parameters import (
    ANY,
    EXIT_BAD_PARAMETER,
    ParameterError,
    declare_dataclass,
    start_node,
    start_nodes,
)
from swarm_ros.qos import RELIABLE
from swarm_ros.spinning import spin_until_shutdown

COMMANDS = ("wheels", "cmd_vel", "both")
"""What a controller can publish each step's answer as (its ``commands`` parameter)."""
TIMINGS = ("lockstep", "free")
"""How a controller is clocked (its ``timing`` parameter)."""
SENSOR_QOS = ("auto", "reliable", "best_effort")
"""The reliability of its sensor subscriptions (its ``sensor_qos`` parameter)."""
CMD_VEL_TYPES = ("TwistStamped", "Twist")
"""The message types it can publish on ``cmd_vel`` (its ``cmd_vel_type`` parameter)."""

BEST_EFFORT_SENSING = QoSProfile(depth=10, reliability=ReliabilityPolicy.BEST_EFFORT)
"""Free-running sensor subscriptions: best effort matches reliable and best-effort publishers alike."""


@dataclass(frozen=True)
class ControllerSettings:
    """The footbot controller's parameters."""

    robot: int = -1
    """Index of this footbot in the simulator's robot_namespaces; -1: from the namespace (footbot_<i>)."""
    tree: str = ""
    """Tree to load at start (tree text, or a network's ``nn(...)``); empty: wait for load_tree."""
    network: str = ""
    """A network file (``{"weights": [...]}``) to load at start; empty: none (not with ``tree``)."""
    library: str = ""
    """A primitive library file whose names the trees may use (each use its own success copy); empty:
    none."""
    commands: str = "wheels"
    """What each step's answer is published as: wheels (swarm_msgs/WheelCommand, what the simulator waits
    for), cmd_vel (geometry_msgs/TwistStamped, REP 103 units, to drive a differential-drive robot) or both."""
    cmd_vel_type: str = "TwistStamped"
    """The type published on cmd_vel: TwistStamped (ros2_control's diff_drive_controller since Jazzy) or
    Twist (older bases)."""
    timing: str = "lockstep"
    """lockstep: answer every sensing step of the simulator (exact); free: tick on the node's own timer
    against the latest sensing (simulated time under use_sim_time, else wall time), stopping after a sensing
    timeout."""
    tick_rate: float = 2.0
    """Free timing: the tree's ticks per second."""
    sensing_timeout: float = 1.0
    """Free timing: seconds without a complete sensing step after which the robot is stopped, with a
    warning."""
    sensor_qos: str = "auto"
    """Reliability of the sensor subscriptions: reliable, best_effort (takes reliable and best-effort
    publishers), or auto (reliable in lockstep, best_effort when free)."""
    default_wheel_speed: float = 0.05
    """Free timing: the wheel speed in m/s until a start_trial gives the trial's."""
    default_wheel_separation: float = 0.14
    """Free timing: the wheel separation in m until a start_trial gives the trial's."""

    def __post_init__(self) -> None:
        for name, allowed in (
            ("commands", COMMANDS),
            ("cmd_vel_type", CMD_VEL_TYPES),
            ("timing", TIMINGS),
            ("sensor_qos", SENSOR_QOS),
        ):
            value = getattr(self, name)
            if value not in allowed:
                raise ParameterError(f"parameter {name} := {value!r}: expected one of {', '.join(allowed)}")

    @property
    def free(self) -> bool:
        """Whether the controller ticks on its own timer."""
        return self.timing == "free"

    @property
    def best_effort(self) -> bool:
        """Whether the sensor subscriptions are best effort."""
        return self.sensor_qos == "best_effort" or (self.sensor_qos == "auto" and self.free)


CONTROLLER_RANGES = {
    "robot": (-1, 2**31 - 1),
    "tick_rate": (0.01, 1000.0),
    "sensing_timeout": (0.001, 3600.0),
    "default_wheel_speed": (0.0, 100.0),
    "default_wheel_separation": (0.001, 100.0),
}
"""Closed ranges of the controller's parameters."""


def twist(left: float, right: float, separation: float) -> Twist:
    """The base velocity of a differential drive whose wheels run at ``left`` and ``right`` m/s,
    ``separation`` metres apart (REP 103: x forward, z up, so a positive ``angular.z`` turns left)."""
    return Twist(linear=Vector3(x=(left + right) / 2.0), angular=Vector3(z=(right - left) / separation))


class FootbotControllerNode(RosNode):
    """One footbot's controller: answers every sensing step, ticks at the schedule's steps."""

    def __init__(self, **node_options: Any) -> None:
        """``node_options``: rclpy's (``context``, ``parameter_overrides``, ...), for tests."""
        super().__init__("footbot_controller", **node_options)
        self.settings = declare_dataclass(
            self, ControllerSettings(), read_only=True, ranges=CONTROLLER_RANGES
        )
        self.robot = robot_index(self.get_namespace(), self.settings.robot)
        self.library: Library | None = load_library(self.settings.library) if self.settings.library else None
        initial_tree = self.settings.tree
        if self.settings.network:
            if initial_tree:
                raise ParameterError("parameters tree and network: give one controller, not both")
            initial_tree = controller_text(load_network(self.settings.network))
        self.controller = FootbotController()
        self.wheel_speed = self.settings.default_wheel_speed  # m/s, from each trial's StartTrial
        self.wheel_separation = self.settings.default_wheel_separation  # m, from each trial's StartTrial
        self.free: FreeRunningController | None = None  # free timing: made when a tree is loaded
        self._tree: Node | Network | None = None
        self._timed_out = False
        self._stall_warned = 0  # lockstep: the step a stall was last reported at
        warm_up()  # compile before offering services, so no step waits for numba
        self._ground: dict[int, GroundSensor] = {}
        self._readings: dict[int, RangeAndBearingReadings] = {}
        commands = self.settings.commands
        self._wheels = (
            self.create_publisher(WheelCommand, "wheels", RELIABLE) if commands != "cmd_vel" else None
        )
        self.base_frame = robot_frame(self.get_namespace(), "base_link")
        stamped = self.settings.cmd_vel_type == "TwistStamped"
        self._cmd_vel = (
            self.create_publisher(TwistStamped if stamped else Twist, "cmd_vel", RELIABLE)
            if commands != "wheels"
            else None
        )
        self._status = self.create_publisher(TreeStatus, "tree_status", RELIABLE)
        sensing = BEST_EFFORT_SENSING if self.settings.best_effort else RELIABLE
        self.create_subscription(GroundSensor, "ground", self._on_ground, sensing)
        self.create_subscription(RangeAndBearingReadings, "range_and_bearing", self._on_readings, sensing)
        if self.settings.free:
            self._diagnostics = self.create_publisher(DiagnosticArray, "/diagnostics", 10)
            self.create_timer(1.0 / self.settings.tick_rate, self._on_tick)  # the node's clock
            self.create_timer(1.0, self._publish_diagnostics, clock=Clock(clock_type=ClockType.STEADY_TIME))
        self.create_service(LoadTree, "load_tree", self._on_load_tree)
        self.create_service(StartTrial, "start_trial", self._on_start_trial)
        self.loaded = ""
        if initial_tree:
            tree = parse_controller(initial_tree, library=self.library)
            self._load(tree)
            self.loaded = self._text(tree)

    def _load(self, tree: Node | Network) -> None:
        self.controller.load(tree)
        self._tree = tree
        if self.settings.free:
            self._start_free(0, PerceptionParams())

    def _start_free(self, tree_key: int, perception: PerceptionParams) -> None:
        """Free timing: a fresh controller on the loaded tree, its timeout counted from now (from the first
        tick or reading when a simulated clock has not started yet: its time is then 0)."""
        if self._tree is not None:
            now = self._now()
            self.free = FreeRunningController(
                self._tree, tree_key, perception, self.settings.sensing_timeout, now if now > 0 else None
            )

    def _now(self) -> float:
        """The node's clock in seconds (simulated under use_sim_time)."""
        return self.get_clock().now().nanoseconds / 1e9

    def _text(self, tree: Node | Network) -> str:
        """The canonical text of ``tree`` (a network's ``nn(...)``), with the library's names where it has
        one."""
        if self.library is None or isinstance(tree, Network):
            return controller_text(tree)
        return self.library.fold(tree)

    def announce(self) -> None:
        """Log that the node is ready (once its parameters are checked)."""
        self.get_logger().info(
            f"ready: robot {self.robot} in {self.get_namespace()}"
            + (f" with tree {self.loaded}" if self.loaded else "; waiting for load_tree")
        )

    def _on_load_tree(self, request: LoadTree.Request, response: LoadTree.Response) -> LoadTree.Response:
        try:
            tree = parse_controller(request.tree, library=self.library)
        except TreeError as error:
            response.success = False
            response.message = str(error)
            self.get_logger().error(f"refused a tree: {error}")
            return response
        if request.from_step > 0:  # live adaptation: swapped in during the chain under way
            try:
                if self.settings.free:
                    raise ValueError("a tree swapped in at a step needs timing lockstep")
                self.controller.swap_at(tree, int(request.from_step))
            except ValueError as error:
                response.success = False
                response.message = str(error)
                self.get_logger().warning(f"refused to swap a tree in at step {request.from_step}: {error}")
                return response
            self.loaded = self._text(tree)
            self.get_logger().info(f"swapping in {self.loaded} at step {request.from_step}")
        else:
            self._load(tree)
        response.success = True
        response.canonical_tree = self._text(tree)
        return response

    def _on_start_trial(
        self, request: StartTrial.Request, response: StartTrial.Response
    ) -> StartTrial.Response:
        try:
            line = Timeline(
                profile_number(request.profile),
                request.steps_per_tick,
                request.ticks,
                request.initial_step,
                request.chain_trials,
                check_authors_code(request.authors_code),
            )
            perception = PerceptionParams(
                request.window,
                request.estimate_cap,
                request.density_range,
                request.density_divisor,
                line.profile,  # robot_left with nobody heard differs between the profiles
                1 + request.food_kinds,
                line.authors_code,  # and between the authors' codes, as the trial's end does
            )
            if not 1 <= request.food_kinds <= MAX_FOOD_KINDS:
                kinds = f"food_kinds must be 1 to {MAX_FOOD_KINDS} (the world's food kinds)"
                raise ValueError(f"{kinds}, got {request.food_kinds}")
            self.controller.start_chain(request.tree_key, line, perception, request.trials)
        except (ValueError, RuntimeError) as error:
            response.success = False
            response.message = str(error)
            self.get_logger().error(f"cannot start trial {request.trial} of seed {request.seed}: {error}")
            return response
        self.wheel_speed = float(request.wheel_speed)
        self.wheel_separation = float(request.wheel_separation)
        self._ground.clear()
        self._readings.clear()
        self._stall_warned = 0
        if self.settings.free:
            self._start_free(int(request.tree_key), perception)
        response.success = True
        return response

    def _on_ground(self, msg: GroundSensor) -> None:
        if self.settings.free:
            if self.free is not None:
                self.free.offer_ground(msg.step, ground_of(msg), self._now(), footing_of(msg))
            return
        self._ground[msg.step] = msg
        self._answer_ready_steps()

    def _on_readings(self, msg: RangeAndBearingReadings) -> None:
        if self.settings.free:
            if self.free is not None:
                unknown = [False] * self.free.view.regions  # (the ground message brings them)
                self.free.offer_range_and_bearing(msg.step, readings_of(unknown, msg), self._now())
            return
        self._readings[msg.step] = msg
        self._answer_ready_steps()

    def _on_tick(self) -> None:
        """Free timing: one tick of the tree on the latest sensing, or a stop after a sensing timeout."""
        if self.free is None:
            return
        now = self.get_clock().now()
        outcome = self.free.tick(now.nanoseconds / 1e9)
        if outcome.timed_out and not self._timed_out:
            self._timed_out = True
            self.get_logger().warning(
                f"sensing timeout: no complete sensing step for {outcome.silence:.2f} s (newest step "
                f"{outcome.step}); the robot is stopped until readings come back"
            )
            self._publish_diagnostics()
        elif not outcome.timed_out and self._timed_out and outcome.tick >= 0:
            self._timed_out = False
            self.get_logger().info(f"sensing back at step {outcome.step}: ticking again")
            self._publish_diagnostics()
        header = Header(stamp=now.to_msg(), frame_id=self.base_frame)
        status, wheels = free_messages(outcome, self.free, header, self.robot, self.wheel_speed)
        if status is not None:
            self._status.publish(status)
        self._publish_cmd_vel(wheels)
        if self._wheels is not None:
            self._wheels.publish(wheels)

    def _publish_cmd_vel(self, wheels: WheelCommand) -> None:
        """The wheel command as the base's velocity on ``cmd_vel`` (when it is published), stamped as the
        command, in the robot's base frame when the type has a header."""
        if self._cmd_vel is None:
            return
        velocity = twist(wheels.left, wheels.right, self.wheel_separation)
        if self.settings.cmd_vel_type == "Twist":
            self._cmd_vel.publish(velocity)
        else:
            header = Header(stamp=wheels.header.stamp, frame_id=self.base_frame)
            self._cmd_vel.publish(TwistStamped(header=header, twist=velocity))

    def _publish_diagnostics(self) -> None:
        """Free timing: the sensing's state on /diagnostics."""
        free = self.free
        if free is None:
            level, message, values = DiagnosticStatus.WARN, "no tree loaded", {}
        else:
            now = self._now()
            counts = free.counts
            values = {
                "timing": "free",
                "steps used": str(counts.used),
                "steps lost": str(counts.lost),
                "readings late": str(counts.late),
                "readings duplicated": str(counts.duplicated),
                "newest step": str(free.newest),
                "seconds since it": f"{free.silence(now):.3f}",
            }
            if free.timed_out(now):
                level, message = DiagnosticStatus.WARN, "sensing timeout: the robot is stopped"
            elif free.view.latest is None:
                level, message = DiagnosticStatus.WARN, "waiting for the first sensing step"
            else:
                level, message = DiagnosticStatus.OK, "sensing"
        status = DiagnosticStatus(
            level=level,
            name=self.get_fully_qualified_name(),
            message=message,
            hardware_id=f"footbot {self.robot}",
            values=[KeyValue(key=k, value=v) for k, v in values.items()],
        )
        self._diagnostics.publish(
            DiagnosticArray(header=Header(stamp=self.get_clock().now().to_msg()), status=[status])
        )

    def _answer_ready_steps(self) -> None:
        controller = self.controller
        while (
            controller.in_trial
            and controller.next_step in self._ground
            and controller.next_step in self._readings
        ):
            ground = self._ground.pop(controller.next_step)
            rab = self._readings.pop(controller.next_step)
            readings = readings_of(ground_of(ground), rab, footing_of(ground))
            outcome = controller.on_step(ground.step, readings)
            status, wheels = answer_messages(outcome, ground.header, self.robot, self.wheel_speed)
            if status is not None:
                self._status.publish(status)
            self._publish_cmd_vel(wheels)
            if self._wheels is None:
                continue
            self._wheels.publish(wheels)
        self._warn_if_stalled()

    def _warn_if_stalled(self) -> None:
        """Lockstep: a reading of a later step while step N is incomplete means a reading of step N was lost
        (the simulator publishes a step only once every robot answered the one before): the lockstep stalls
        here. Say so once per stalled step, rather than wait without a word."""
        controller = self.controller
        waiting = controller.next_step
        if not controller.in_trial or waiting == self._stall_warned:
            return
        later = [s for s in (*self._ground, *self._readings) if s > waiting]
        if later:
            self._stall_warned = waiting
            missing = [
                name
                for name, pending in (("ground", self._ground), ("range_and_bearing", self._readings))
                if waiting not in pending
            ]
            self.get_logger().warning(
                f"lockstep stalled at step {waiting}: its {' and '.join(missing)} reading never came, and "
                f"step {min(later)} has; a lockstep controller answers steps in order (timing:=free takes "
                "lost readings)"
            )


def ground_of(msg: GroundSensor) -> list[bool]:
    """A ground message's regions in perception's order: the nest, food kind 1, the other food kinds."""
    return [bool(msg.in_nest), bool(msg.on_food), *(bool(f) for f in msg.on_other_food)]


def footing_of(msg: GroundSensor) -> list[bool] | None:
    """Where a ground message says the robot really stands (its ``footing``, given when the ground sensor is
    faulty), in perception's order; None when it gives none (the reading is true)."""
    return [bool(f) for f in msg.footing] if len(msg.footing) else None


def readings_of(
    inside: Sequence[bool], msg: RangeAndBearingReadings, footing: Sequence[bool] | None = None
) -> Readings:
    """The perception's readings of one step: its ground values (``ground_of``), its range-and-bearing
    message (the nest, food kind 1, then the other food kinds the world has) and where it really stands
    (``footing_of``; None: where it reads)."""
    rab = msg.readings
    return Readings(
        footing=None if footing is None else np.array(footing, dtype=np.bool_),
        ground=np.array(inside, dtype=np.bool_),
        senders=np.array([m.sender for m in rab], dtype=np.int64),
        ranges=np.array([m.range for m in rab], dtype=np.float64),
        bearings=np.array([m.bearing for m in rab], dtype=np.float64),
        values=np.array(
            [[m.nest_estimate, m.food_estimate, *m.other_food_estimates] for m in rab], dtype=np.float64
        ).reshape(len(rab), len(inside)),
    )


def _kind_fields(
    broadcast: Sequence[float], smoothed: Sequence[float], carrying: Sequence[bool], deliveries: Sequence[int]
) -> dict[str, object]:
    """A wheel command's estimate, smoothed, carrying and delivery fields: kind 1's, then the other kinds'."""
    return {
        "nest_estimate": float(broadcast[0]),
        "food_estimate": float(broadcast[1]),
        "other_food_estimates": [float(v) for v in broadcast[2:]],
        "smoothed_nest": float(smoothed[0]),
        "smoothed_food": float(smoothed[1]),
        "smoothed_density": float(smoothed[2]),
        "smoothed_other_food": [float(v) for v in smoothed[3:]],
        "carrying": bool(carrying[0]),
        "carrying_other_food": [bool(c) for c in carrying[1:]],
        "deliveries": int(deliveries[0]),
        "other_food_deliveries": [int(d) for d in deliveries[1:]],
    }


def free_messages(
    outcome: FreeTick, free: FreeRunningController, header: Header, robot: int, wheel_speed: float
) -> tuple[TreeStatus | None, WheelCommand]:
    """What a free-running controller publishes at a timer tick: the tree's status when it ticked, and the
    wheel command (zero after a sensing timeout); ``step`` is the newest sensing step used."""
    status = None
    if outcome.tick >= 0:
        status = TreeStatus(
            header=header,
            robot=robot,
            step=outcome.step,
            tick=outcome.tick,
            status=outcome.status,
            action=outcome.started,
            condition_ticks=outcome.condition_ticks,
        )
    wheels = WheelCommand(
        header=header,
        robot=robot,
        step=outcome.step,
        action=outcome.action,
        action_name=ACTIONS[outcome.action],
        left=float(outcome.wheels[0]) * wheel_speed,
        right=float(outcome.wheels[1]) * wheel_speed,
        **_kind_fields(
            outcome.broadcast, outcome.smoothed, free.view.carrying.tolist(), free.view.deliveries.tolist()
        ),
    )
    return status, wheels


def answer_messages(
    outcome: StepOutcome, header: Header, robot: int, wheel_speed: float
) -> tuple[TreeStatus | None, WheelCommand]:
    """What a controller publishes of its answer to a step (``header``: the step's ground reading's): the
    tree's status when it ticked, and the wheel command (``wheel_speed`` in m/s). The node publishes these;
    ``replay --verify`` compares a recording with those of a re-run."""
    status = None
    if outcome.tick is not None:
        status = TreeStatus(
            header=header,
            robot=robot,
            step=outcome.step,
            tick=outcome.tick.tick,
            status=outcome.tick.status,
            action=outcome.tick.started,
            condition_ticks=outcome.tick.condition_ticks,
        )
    left, right = float(outcome.wheels[0]), float(outcome.wheels[1])
    action = int(outcome.action)
    left, right = left * wheel_speed, right * wheel_speed
    wheels = WheelCommand(
        header=header,
        robot=robot,
        step=outcome.step,
        action=action,
        action_name=ACTIONS[action],
        left=left,
        right=right,
        **_kind_fields(outcome.broadcast, outcome.smoothed, outcome.carrying, outcome.deliveries),
    )
    return status, wheels


class InitialTreeError(ValueError):
    """The ``tree`` parameter is not a valid tree, the ``network`` parameter not a network file, or the
    ``library`` parameter not a library."""


def make_node(**node_options: Any) -> FootbotControllerNode:
    """A controller node (``node_options``: rclpy's); a ``tree`` parameter that does not parse, or a
    ``library`` that cannot be read, raises ``InitialTreeError``."""
    try:
        return FootbotControllerNode(**node_options)
    except TreeError as error:
        raise InitialTreeError(f"the tree parameter is not a valid tree: {error}") from None
    except LibraryError as error:
        raise InitialTreeError(f"the library parameter: {error}") from None
    except NetworkError as error:
        raise InitialTreeError(f"the network parameter: {error}") from None


def main(args: list[str] | None = None) -> None:
    """Run one footbot controller node until shut down; a bad parameter is a one-line error and exit status 2.
    A ``/**`` section of a parameter file may hold any name (the world's, for the simulator): the controller
    takes its own and leaves the others to the graph's other nodes, which refuse a name none declares."""
    node = start_node(
        "footbot_controller", make_node, args, shared=ANY, errors=(InitialTreeError, NamespaceError)
    )
    # lockstep has no timer and one callback at a time: the events executor serves it for less CPU per step;
    # free timing keeps the single-threaded executor, whose timers follow a simulated clock
    spin_until_shutdown(node, events=not node.settings.free, on_ready=node.announce)


NODE_MARK = "--node"
"""What starts each node's arguments on ``footbot_controllers``' command line."""


def node_arguments(args: Sequence[str]) -> list[list[str]]:
    """The arguments of each node of ``footbot_controllers ARGS``: the words after each ``--node`` up to the
    next; ``ValueError`` when there is none, or words before the first."""
    if not args or args[0] != NODE_MARK:
        raise ValueError(
            "expected one '--node --ros-args ...' per controller, each with the arguments its own "
            f"footbot_controller process would take; got {' '.join(args) or 'no arguments'}"
        )
    groups: list[list[str]] = []
    for word in args:
        if word == NODE_MARK:
            groups.append([])
        else:
            groups[-1].append(word)
    return groups


def main_many(args: list[str] | None = None) -> None:
    """``footbot_controllers --node --ros-args ... [--node --ros-args ...]``: several footbot controller nodes
    in one process, as a ROS 2 component container holds nodes; each node takes only its own arguments (the
    ones its own ``footbot_controller`` process would take: namespace, parameters, parameter files, remaps).
    A trial graph's nine controllers start in about 1 s of CPU so, against about 1 s each as processes of
    their own. The nodes share one executor: the events executor when every one is lockstep, else the
    single-threaded one. A bad parameter of any node is one line naming its arguments, exit status 2."""
    argv = list(sys.argv[1:] if args is None else args)
    if argv in (["-h"], ["--help"]):
        print(main_many.__doc__)
        return
    try:
        groups = node_arguments(argv)
    except ValueError as error:
        print(f"footbot_controllers: {error}", file=sys.stderr)
        raise SystemExit(EXIT_BAD_PARAMETER) from None
    nodes = start_nodes(
        "footbot_controllers", make_node, groups, shared=ANY, errors=(InitialTreeError, NamespaceError)
    )

    def announce() -> None:
        for node in nodes:
            node.announce()

    spin_until_shutdown(nodes, events=not any(node.settings.free for node in nodes), on_ready=announce)
