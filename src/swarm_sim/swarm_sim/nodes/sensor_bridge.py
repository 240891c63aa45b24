"""The virtual-sensor bridge for real fleets: each robot's footbot senses from its tracked pose.

``ws/run swarm_sim sensor_bridge --ros-args -p task:=primitives [-p seed:=S -p trial:=K]
[-r __ns:=/fleet]`` gives free-running footbot controllers (``timing:=free``) their readings from the
robots' poses, as motion capture or another simulator publishes them, so that an evolved tree drives any
differential-drive fleet (``docs/robots.md``). The computing is ``virtual_sensors.VirtualSensors``, free of
ROS; this node only moves messages.

Parameters (read-only):
    task: the task whose arena (nest, food region) and robot count the readings are of: a registered name
        or a task file (default primitives).
    profile: the model's profile (paper or clean).
    seed, trial: the chain whose message losses are drawn, and the arena configuration (food gap) of
        ``trial``; with the seed and trial of a recorded trial, replayed poses give its readings.
    robots: the number of robots (default 0: the task's).
    loss, delay: a link worse than the model's radio (``virtual_sensors.Delivery``): each robot's pair of
        readings of a period is lost with probability ``loss`` (default 0), or held back up to ``delay``
        sensing periods (default 0), drawn from ``seed``.
    await_trial_start: no readings before the first ``trial_start`` (default false; a trial graph sets it:
        its poses can reach the bridge before the trial's ``trial_start``, and readings sensed then would
        be of the world before it and repeat the trial's first step numbers).

Subscriptions (``pose`` and ``wheels`` best effort, so a driver's ``qos_profile_sensor_data`` and reliable
publishers both match):
    trial_start (swarm_msgs/TrialStart, reliable and transient-local): in a trial graph whose simulator leaves
        the sensing to the bridge (``sensing:=external``), each trial's world, seed and trial replace the
        parameters', the broadcasts start again from the estimate cap and the steps from 1; readings the
        link still held back are dropped.
    <robot>/pose (geometry_msgs/PoseStamped): the robot's pose in the arena's frame (its centre, metres).
    <robot>/wheels (swarm_msgs/WheelCommand): its controller's answers, whose ``nest_estimate`` and
        ``food_estimate`` the robot broadcasts to the others (the estimate cap until the first).

Publishers (reliable, which best-effort subscribers take too), every sensing period (``step_dt``, 1/8 s,
on the node's clock: simulated time with ``use_sim_time``) once every robot has a pose:
    <robot>/ground (swarm_msgs/GroundSensor) and <robot>/range_and_bearing
        (swarm_msgs/RangeAndBearingReadings): sensing steps 1, 2, ... in the robot's ``<robot>/base_link``.

``<robot>`` is ``footbot_<i>`` for robot i of the task's robot count, under the node's namespace.
"""

from __future__ import annotations

import json
from dataclasses import replace
from functools import partial

from geometry_msgs.msg import PoseStamped
from rclpy.node import Node
from rclpy.qos import QoSProfile, ReliabilityPolicy

from bt_controller.model_settings import PROFILES
from swarm_msgs.msg import GroundSensor, RangeAndBearingReadings, TrialStart, WheelCommand
from swarm_ros.names import robot_frames, robot_namespaces
from swarm_ros.parameters import ANY, ParameterError, declare, descriptor, start_node
from swarm_ros.qos import LATCHED, RELIABLE
from swarm_ros.spinning import spin_until_shutdown
from swarm_sim.errors import ConfigError
from swarm_sim.model import DEFAULT, config_from_dict
from swarm_sim.nodes.simulator import reading_messages
from swarm_sim.nodes.virtual_sensors import Delivery, VirtualSensors
from swarm_sim.tasks import DEFAULT_TASK, TaskError, resolve_task

SENSOR_INPUT = QoSProfile(depth=10, reliability=ReliabilityPolicy.BEST_EFFORT)
"""The bridge's subscriptions: best effort, which both best-effort and reliable publishers match."""


class SensorBridgeNode(Node):
    """Poses and broadcasts in, every robot's readings out at each sensing period."""

    def __init__(self) -> None:
        super().__init__("sensor_bridge")
        task = declare(self, "task", DEFAULT_TASK, descriptor("task name or task file", read_only=True))
        profile = declare(self, "profile", DEFAULT.profile, descriptor("the model's profile", read_only=True))
        seed = declare(self, "seed", 0, descriptor("seed of the message losses", read_only=True))
        trial = declare(self, "trial", 0, descriptor("trial: its losses and its arena", read_only=True))
        if profile not in PROFILES:
            raise ParameterError(f"parameter profile := {profile!r}: expected one of {', '.join(PROFILES)}")
        robots = declare(self, "robots", 0, descriptor("robots (0: the task's)", read_only=True))
        loss = declare(
            self, "loss", 0.0, descriptor("probability a pair of readings is lost", read_only=True)
        )
        delay = declare(
            self, "delay", 0, descriptor("most sensing periods a pair is held back", read_only=True)
        )
        self.awaiting_trial_start = declare(
            self,
            "await_trial_start",
            False,
            descriptor("no readings before the first trial_start", read_only=True),
        )
        if trial < 0 or seed < 0 or robots < 0:
            raise ParameterError("parameters seed, trial and robots must not be negative")
        config = resolve_task(task).config(profile)
        if robots:
            config = replace(config, n_robots=robots)
        self.sensors = VirtualSensors(config, seed, trial)
        try:
            self.link = Delivery(loss, delay, seed)
        except ValueError as error:
            raise ParameterError(f"parameters loss and delay: {error}") from None
        self.namespaces = robot_namespaces(config.n_robots)
        self.frames = [base for _, base in robot_frames(self.get_namespace(), self.namespaces)]
        self.step = 0
        self._waiting_said = False
        self._ground = [
            self.create_publisher(GroundSensor, f"{ns}/ground", RELIABLE) for ns in self.namespaces
        ]
        self._readings = [
            self.create_publisher(RangeAndBearingReadings, f"{ns}/range_and_bearing", RELIABLE)
            for ns in self.namespaces
        ]
        for i, ns in enumerate(self.namespaces):
            self.create_subscription(PoseStamped, f"{ns}/pose", partial(self._on_pose, i), SENSOR_INPUT)
            self.create_subscription(WheelCommand, f"{ns}/wheels", partial(self._on_wheels, i), SENSOR_INPUT)
        self.create_subscription(TrialStart, "trial_start", self._on_trial_start, LATCHED)
        self.create_timer(config.step_dt, self._sense)
        self.get_logger().info(
            f"ready: {config.n_robots} robots ({self.namespaces[0]} .. {self.namespaces[-1]}), task {task}, "
            f"seed {seed}, trial {trial}; readings every {config.step_dt} s once every robot has a pose"
        )

    def _on_pose(self, robot: int, msg: PoseStamped) -> None:
        q = msg.pose.orientation
        self.sensors.set_pose_in_metres(robot, msg.pose.position.x, msg.pose.position.y, q.z, q.w)

    def _on_trial_start(self, msg: TrialStart) -> None:
        try:
            config = config_from_dict(json.loads(msg.world)) if msg.world else self.sensors.config
        except (ValueError, TypeError, ConfigError) as error:
            self.get_logger().error(f"trial_start: its world cannot be rebuilt ({error}); sensing as before")
            return
        if config.n_robots != len(self.namespaces):
            self.get_logger().error(
                f"trial_start: {config.n_robots} robots, the bridge senses {len(self.namespaces)}; "
                "sensing as before"
            )
            return
        poses = self.sensors.poses.copy()
        self.sensors = VirtualSensors(config, int(msg.seed), int(msg.trial))
        self.sensors.poses[:] = poses
        self.step = 0
        self.awaiting_trial_start = False
        # Readings the link still holds back are of the world before this trial, and numbered by its steps:
        # delivered now they would be stale, and repeat the new trial's step numbers.
        dropped = self.link.clear()
        held = f" ({dropped} held-back readings of the world before it dropped)" if dropped else ""
        self.get_logger().info(f"trial {msg.trial} of seed {msg.seed}: sensing its world from step 1{held}")

    def _on_wheels(self, robot: int, msg: WheelCommand) -> None:
        self.sensors.set_broadcast(robot, msg.nest_estimate, msg.food_estimate, *msg.other_food_estimates)

    def _sense(self) -> None:
        if self.awaiting_trial_start:
            return
        missing = self.sensors.missing()
        if missing:
            if not self._waiting_said:
                self._waiting_said = True
                names = ", ".join(self.namespaces[i] for i in missing)
                self.get_logger().warning(f"no pose yet of {names}: no readings until every robot has one")
            return
        self.step += 1
        stamp = self.get_clock().now().to_msg()
        ground, readings = reading_messages(self.sensors.sense(self.step), stamp, self.step, self.frames)
        for robot, pair in enumerate(zip(ground, readings, strict=True)):
            self.link.send(self.step, (robot, pair))
        for robot, (ground_message, readings_message) in self.link.due(self.step):
            self._ground[robot].publish(ground_message)
            self._readings[robot].publish(readings_message)


def main(args: list[str] | None = None) -> None:
    """Run the bridge until shut down; a bad parameter is a one-line error and exit status 2."""
    # shared=ANY: in a trial graph it reads the package's parameter file, which holds the simulator's names
    node = start_node("sensor_bridge", SensorBridgeNode, args, shared=ANY, errors=(TaskError, ConfigError))
    spin_until_shutdown(node)
