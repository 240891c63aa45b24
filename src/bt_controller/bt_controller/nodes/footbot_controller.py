"""The footbot controller node: one footbot's perception and behaviour tree, in the robot's namespace.

Node ``footbot_controller``, started as ``--ros-args -r __ns:=/footbot_<i> -p robot:=<i>``.

Parameters:
    robot (int, read-only): the robot's index i (default 0).
    tree (string, read-only): a tree to load at start (default: none; use the load_tree service).

Subscriptions (relative names, in the robot's namespace):
    ground (swarm_msgs/GroundSensor) and range_and_bearing (swarm_msgs/RangeAndBearingReadings): the
        simulator's readings; a step is answered once both of its messages have arrived.

Publishers:
    wheels (swarm_msgs/WheelCommand): the answer to every sensing step: wheels, broadcast and smoothed
        estimates.
    tree_status (swarm_msgs/TreeStatus): the result of every tick (2 Hz in simulated time).

Services:
    load_tree (swarm_msgs/LoadTree): parse, validate and load a tree (a clear error for a bad one).
    start_trial (swarm_msgs/StartTrial): reset for a trial (called by the simulator).

The node keeps the 7-sample smoothing and the blackboard from its topics and ticks its tree with the reference
interpreter; the logic is ``bt_controller.controller``.
"""

from __future__ import annotations

import sys

import numpy as np
import rclpy
from rcl_interfaces.msg import ParameterDescriptor
from rclpy.node import Node
from rclpy.qos import QoSProfile, ReliabilityPolicy

from bt_controller.controller import FootbotController, Schedule
from bt_controller.errors import TreeError
from bt_controller.nodes.spinning import spin_until_shutdown
from bt_controller.perception import PerceptionParams, Readings, warm_up
from bt_controller.tree import parse, to_text
from swarm_msgs.msg import GroundSensor, RangeAndBearingReadings, TreeStatus, WheelCommand
from swarm_msgs.srv import LoadTree, StartTrial

RELIABLE = QoSProfile(depth=100, reliability=ReliabilityPolicy.RELIABLE)


class FootbotControllerNode(Node):
    """One footbot's controller: answers every sensing step, ticks at the schedule's steps."""

    def __init__(self) -> None:
        super().__init__("footbot_controller")
        self.robot: int = self.declare_parameter(
            "robot", 0, ParameterDescriptor(description="index of this footbot", read_only=True)
        ).value
        initial_tree: str = self.declare_parameter(
            "tree", "", ParameterDescriptor(description="tree to load at start", read_only=True)
        ).value
        self.controller = FootbotController()
        warm_up()  # compile before offering services, so no step waits for numba
        self._ground: dict[int, GroundSensor] = {}
        self._readings: dict[int, RangeAndBearingReadings] = {}
        self._wheels = self.create_publisher(WheelCommand, "wheels", RELIABLE)
        self._status = self.create_publisher(TreeStatus, "tree_status", RELIABLE)
        self.create_subscription(GroundSensor, "ground", self._on_ground, RELIABLE)
        self.create_subscription(RangeAndBearingReadings, "range_and_bearing", self._on_readings, RELIABLE)
        self.create_service(LoadTree, "load_tree", self._on_load_tree)
        self.create_service(StartTrial, "start_trial", self._on_start_trial)
        if initial_tree:
            self.controller.load(parse(initial_tree))

    def _on_load_tree(self, request: LoadTree.Request, response: LoadTree.Response) -> LoadTree.Response:
        try:
            tree = parse(request.tree)
        except TreeError as error:
            response.success = False
            response.message = str(error)
            return response
        self.controller.load(tree)
        response.success = True
        response.canonical_tree = to_text(tree)
        return response

    def _on_start_trial(
        self, request: StartTrial.Request, response: StartTrial.Response
    ) -> StartTrial.Response:
        try:
            schedule = Schedule(request.settle_steps, request.steps_per_tick, request.ticks)
            perception = PerceptionParams(
                request.window, request.estimate_cap, request.density_range, request.density_divisor
            )
            self.controller.start_trial(request.tree_key, schedule, perception)
        except (ValueError, RuntimeError) as error:
            response.success = False
            response.message = str(error)
            return response
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
            if outcome.tick is not None:
                self._status.publish(
                    TreeStatus(
                        header=ground.header,
                        robot=self.robot,
                        tick=outcome.tick.tick,
                        status=outcome.tick.status,
                        action=outcome.tick.started,
                        condition_ticks=outcome.tick.condition_ticks,
                    )
                )
            nest, food, density = outcome.smoothed
            self._wheels.publish(
                WheelCommand(
                    header=ground.header,
                    robot=self.robot,
                    step=outcome.step,
                    left=float(outcome.wheels[0]),
                    right=float(outcome.wheels[1]),
                    nest_estimate=outcome.broadcast[0],
                    food_estimate=outcome.broadcast[1],
                    smoothed_nest=nest,
                    smoothed_food=food,
                    smoothed_density=density,
                )
            )


def main(args: list[str] | None = None) -> None:
    """Run one footbot controller node until shut down."""
    rclpy.init(args=args)
    try:
        node = FootbotControllerNode()
    except TreeError as error:
        print(f"footbot_controller: the tree parameter is not a valid tree: {error}", file=sys.stderr)
        rclpy.try_shutdown()
        raise SystemExit(2) from None
    spin_until_shutdown(node)
