"""The footbot controller node: one footbot's perception and behaviour tree, in the robot's namespace.

Node ``footbot_controller``, started in the robot's namespace: ``--ros-args -r __ns:=/footbot_<i>`` (or
``/<graph>/footbot_<i>``); every name it uses is relative to it.

Parameters (``config/bt_controller.yaml``; ``ControllerSettings``; a bad value, type or name stops the node
with one line, exit status 2):
    robot (int, read-only): the robot's index i, its position in the simulator's ``robot_namespaces``.
        Default -1: taken from the namespace, whose last part must then be ``footbot_<i>``. When both are
        given they must agree: ``__ns:=/footbot_4 -p robot:=0`` stops the node with an error saying so.
    tree (string, read-only): a tree to load at start (default: none; use the load_tree service).
    library (string, read-only): a primitive library file (``bt_controller.library``) whose primitives'
        names the trees may use (default: none). A path: the library is fixed for the node's life, as its
        other parameters; a library that cannot be read stops the node with one line, exit status 2.
    commands (string, read-only): what each step's answer is published as: ``wheels`` (default; what the
        simulator waits for), ``cmd_vel``, or ``both``.

Subscriptions (relative names, in the robot's namespace):
    ground (swarm_msgs/GroundSensor) and range_and_bearing (swarm_msgs/RangeAndBearingReadings): the
        simulator's readings; a step is answered once both of its messages have arrived.

Publishers:
    wheels (swarm_msgs/WheelCommand): the answer to every sensing step: the action under way (index and
        name), its wheel speeds in m/s, the broadcast and smoothed estimates, whether it carries food and its
        deliveries in the trial so far.
    cmd_vel (geometry_msgs/Twist, with ``commands`` cmd_vel or both): the same step's wheel speeds as a
        velocity of the robot's base (REP 103): ``linear.x = (left + right) / 2`` in m/s and
        ``angular.z = (right - left) / wheel_separation`` in rad/s, anticlockwise positive, with the wheel
        separation the trial's ``start_trial`` gives; a differential-drive robot can be driven by it.
    tree_status (swarm_msgs/TreeStatus): the result of every tick (2 Hz in simulated time).

Services:
    load_tree (swarm_msgs/LoadTree): parse, validate and load a tree (a clear error for a bad one).
    start_trial (swarm_msgs/StartTrial): reset for a chain of trials (called by the simulator).

The node keeps the 7-sample smoothing and the blackboard from its topics and ticks its tree with the reference
interpreter; the logic is ``bt_controller.controller``.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from geometry_msgs.msg import Twist, Vector3
from rclpy.node import Node as RosNode
from std_msgs.msg import Header

from bt_controller.controller import FootbotController, StepOutcome
from bt_controller.errors import TreeError
from bt_controller.library import Library, LibraryError, load_library
from bt_controller.perception import PerceptionParams, Readings, warm_up
from bt_controller.timeline import Timeline, profile_number
from bt_controller.tree import Node, parse, to_text
from bt_controller.vocabulary import ACTIONS
from swarm_msgs.msg import GroundSensor, RangeAndBearingReadings, TreeStatus, WheelCommand
from swarm_msgs.srv import LoadTree, StartTrial
from swarm_ros.names import NamespaceError, robot_index
from swarm_ros.parameters import ANY, ParameterError, declare_dataclass, start_node
from swarm_ros.qos import RELIABLE
from swarm_ros.spinning import spin_until_shutdown

COMMANDS = ("wheels", "cmd_vel", "both")
"""What a controller can publish each step's answer as (its ``commands`` parameter)."""


@dataclass(frozen=True)
class ControllerSettings:
    """The footbot controller's parameters."""

    robot: int = -1
    """Index of this footbot in the simulator's robot_namespaces; -1: from the namespace (footbot_<i>)."""
    tree: str = ""
    """Tree to load at start (tree text); empty: wait for the load_tree service."""
    library: str = ""
    """A primitive library file whose names the trees may use (each use its own success copy); empty:
    none."""
    commands: str = "wheels"
    """What each step's answer is published as: wheels (swarm_msgs/WheelCommand, what the simulator waits
    for), cmd_vel (geometry_msgs/Twist, REP 103 units, to drive a differential-drive robot) or both."""

    def __post_init__(self) -> None:
        if self.commands not in COMMANDS:
            raise ParameterError(
                f"parameter commands := {self.commands!r}: expected one of {', '.join(COMMANDS)}"
            )


CONTROLLER_RANGES = {"robot": (-1, 2**31 - 1)}
"""Closed ranges of the controller's parameters."""


def twist(left: float, right: float, separation: float) -> Twist:
    """The base velocity of a differential drive whose wheels run at ``left`` and ``right`` m/s,
    ``separation`` metres apart (REP 103: x forward, z up, so a positive ``angular.z`` turns left)."""
    return Twist(linear=Vector3(x=(left + right) / 2.0), angular=Vector3(z=(right - left) / separation))


class FootbotControllerNode(RosNode):
    """One footbot's controller: answers every sensing step, ticks at the schedule's steps."""

    def __init__(self) -> None:
        super().__init__("footbot_controller")
        self.settings = declare_dataclass(
            self, ControllerSettings(), read_only=True, ranges=CONTROLLER_RANGES
        )
        self.robot = robot_index(self.get_namespace(), self.settings.robot)
        self.library: Library | None = load_library(self.settings.library) if self.settings.library else None
        initial_tree = self.settings.tree
        self.controller = FootbotController()
        self.wheel_speed = 0.0  # m/s, from each trial's StartTrial
        self.wheel_separation = 0.0  # m, from each trial's StartTrial
        warm_up()  # compile before offering services, so no step waits for numba
        self._ground: dict[int, GroundSensor] = {}
        self._readings: dict[int, RangeAndBearingReadings] = {}
        commands = self.settings.commands
        self._wheels = (
            self.create_publisher(WheelCommand, "wheels", RELIABLE) if commands != "cmd_vel" else None
        )
        self._cmd_vel = self.create_publisher(Twist, "cmd_vel", RELIABLE) if commands != "wheels" else None
        self._status = self.create_publisher(TreeStatus, "tree_status", RELIABLE)
        self.create_subscription(GroundSensor, "ground", self._on_ground, RELIABLE)
        self.create_subscription(RangeAndBearingReadings, "range_and_bearing", self._on_readings, RELIABLE)
        self.create_service(LoadTree, "load_tree", self._on_load_tree)
        self.create_service(StartTrial, "start_trial", self._on_start_trial)
        self.loaded = ""
        if initial_tree:
            tree = parse(initial_tree, library=self.library)
            self.controller.load(tree)
            self.loaded = self._text(tree)

    def _text(self, tree: Node) -> str:
        """The canonical text of ``tree``, with the library's names where it has one."""
        return to_text(tree) if self.library is None else self.library.fold(tree)

    def announce(self) -> None:
        """Log that the node is ready (once its parameters are checked)."""
        self.get_logger().info(
            f"ready: robot {self.robot} in {self.get_namespace()}"
            + (f" with tree {self.loaded}" if self.loaded else "; waiting for load_tree")
        )

    def _on_load_tree(self, request: LoadTree.Request, response: LoadTree.Response) -> LoadTree.Response:
        try:
            tree = parse(request.tree, library=self.library)
        except TreeError as error:
            response.success = False
            response.message = str(error)
            self.get_logger().error(f"refused a tree: {error}")
            return response
        self.controller.load(tree)
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
            )
            perception = PerceptionParams(
                request.window,
                request.estimate_cap,
                request.density_range,
                request.density_divisor,
                line.profile,  # robot_left with nobody heard differs between the profiles
            )
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
        response.success = True
        return response

    def _on_ground(self, msg: GroundSensor) -> None:
        self._ground[msg.step] = msg
        self._answer_ready_steps()

    def _on_readings(self, msg: RangeAndBearingReadings) -> None:
        self._readings[msg.step] = msg
        self._answer_ready_steps()

    def _answer_ready_steps(self) -> None:
        controller = self.controller
        while (
            controller.in_trial
            and controller.next_step in self._ground
            and controller.next_step in self._readings
        ):
            ground = self._ground.pop(controller.next_step)
            rab = self._readings.pop(controller.next_step).readings
            readings = Readings(
                in_nest=ground.in_nest,
                on_food=ground.on_food,
                senders=np.array([m.sender for m in rab], dtype=np.int64),
                ranges=np.array([m.range for m in rab], dtype=np.float64),
                bearings=np.array([m.bearing for m in rab], dtype=np.float64),
                nest=np.array([m.nest_estimate for m in rab], dtype=np.float64),
                food=np.array([m.food_estimate for m in rab], dtype=np.float64),
            )
            outcome = controller.on_step(ground.step, readings)
            status, wheels = answer_messages(outcome, ground.header, self.robot, self.wheel_speed)
            if status is not None:
                self._status.publish(status)
            if self._cmd_vel is not None:
                self._cmd_vel.publish(twist(wheels.left, wheels.right, self.wheel_separation))
            if self._wheels is None:
                continue
            self._wheels.publish(wheels)


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
    nest, food, density = outcome.smoothed
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
        nest_estimate=outcome.broadcast[0],
        food_estimate=outcome.broadcast[1],
        smoothed_nest=nest,
        smoothed_food=food,
        smoothed_density=density,
        carrying=outcome.carrying,
        deliveries=outcome.deliveries,
    )
    return status, wheels


class InitialTreeError(ValueError):
    """The ``tree`` parameter is not a valid tree, or the ``library`` parameter not a library."""


def make_node() -> FootbotControllerNode:
    """A controller node; a ``tree`` parameter that does not parse, or a ``library`` that cannot be read,
    raises ``InitialTreeError``."""
    try:
        return FootbotControllerNode()
    except TreeError as error:
        raise InitialTreeError(f"the tree parameter is not a valid tree: {error}") from None
    except LibraryError as error:
        raise InitialTreeError(f"the library parameter: {error}") from None


def main(args: list[str] | None = None) -> None:
    """Run one footbot controller node until shut down; a bad parameter is a one-line error and exit status 2.
    A ``/**`` section of a parameter file may hold any name (the world's, for the simulator): the controller
    takes its own and leaves the others to the graph's other nodes, which refuse a name none declares."""
    node = start_node(
        "footbot_controller", make_node, args, shared=ANY, errors=(InitialTreeError, NamespaceError)
    )
    node.announce()
    spin_until_shutdown(node)
