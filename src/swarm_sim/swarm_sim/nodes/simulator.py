"""The simulator node: owns the world and runs trials in lockstep with the footbot controller nodes.

Node ``simulator``.

Parameters:
    robots (int, read-only): number of footbots, footbot_0 .. footbot_<robots - 1> (default 9).
    answer_timeout (float, seconds of wall time): how long to wait for the controllers at any step before the
        trial is abandoned with an error (default 60): it detects dead nodes; it is no speed limit.

Publishers:
    /clock (rosgraph_msgs/Clock): simulated time, one step of 1/8 s per sensing step.
    /trial_start (swarm_msgs/TrialStart): each trial's seed, index and the robots' stream
        keys.
    /footbot_<i>/ground (swarm_msgs/GroundSensor) and /footbot_<i>/range_and_bearing
        (swarm_msgs/RangeAndBearingReadings): each robot's readings, every sensing step.
    /swarm_state (swarm_msgs/SwarmState): the exact poses (mm), every sensing step.
    /poses (geometry_msgs/PoseArray): the same poses in metres, for visualisation tools.

Subscriptions:
    /footbot_<i>/wheels (swarm_msgs/WheelCommand): each controller's answer to a step.
    /footbot_<i>/tree_status (swarm_msgs/TreeStatus): each tick's status, action and condition ticks.

Services:
    ~/run_trial (swarm_msgs/RunTrial): run one trial; before its first step the simulator calls each
        controller's /footbot_<i>/start_trial (swarm_msgs/StartTrial).

Lockstep: after publishing a step's readings the simulator waits until every controller has answered that
step, so results do not depend on the machine's speed. The world itself is ``swarm_sim.lockstep``.
"""

from __future__ import annotations

import math
import threading
from dataclasses import dataclass, replace

import numpy as np
import rclpy
from builtin_interfaces.msg import Time
from geometry_msgs.msg import Pose, PoseArray
from rcl_interfaces.msg import ParameterDescriptor
from rclpy.callback_groups import MutuallyExclusiveCallbackGroup, ReentrantCallbackGroup
from rclpy.client import Client
from rclpy.executors import MultiThreadedExecutor
from rclpy.node import Node
from rclpy.publisher import Publisher
from rclpy.qos import QoSProfile, ReliabilityPolicy
from rosgraph_msgs.msg import Clock
from std_msgs.msg import Header

from bt_controller.nodes.spinning import spin_until_shutdown
from swarm_msgs.msg import (
    GroundSensor,
    RangeAndBearing,
    RangeAndBearingReadings,
    RobotPose,
    SwarmState,
    TreeStatus,
    TrialStart,
    WheelCommand,
)
from swarm_msgs.srv import RunTrial, StartTrial
from swarm_sim.config import DEFAULT, Config
from swarm_sim.errors import TrialAbandonedError
from swarm_sim.lockstep import LockstepTrial, RobotAnswer, action_of_wheels, warm_up
from swarm_sim.trial_data import VALUE_NAMES, TrialRecord

RELIABLE = QoSProfile(depth=100, reliability=ReliabilityPolicy.RELIABLE)


@dataclass
class _Inbox:
    """The answers and tick statuses received for the trial under way (filled by subscription callbacks)."""

    step: int = -1
    answers: dict[int, WheelCommand] | None = None
    counts: np.ndarray | None = None
    statuses: int = 0


class SimulatorNode(Node):
    """Owns the world; runs trials through the controllers over topics and services."""

    def __init__(self, config: Config = DEFAULT) -> None:
        super().__init__("simulator")
        self.config = config
        self.robots: int = self.declare_parameter(
            "robots",
            config.n_robots,
            ParameterDescriptor(description="number of footbots", read_only=True),
        ).value
        if self.robots != config.n_robots:
            self.config = replace(config, n_robots=self.robots)
        self.answer_timeout: float = self.declare_parameter(
            "answer_timeout",
            60.0,
            ParameterDescriptor(
                description="seconds to wait for the controllers at any step (detects dead nodes)"
            ),
        ).value
        self.sim_time_ns = 0
        warm_up(self.config)  # compile before offering the service, so no step waits for numba
        self.step_ns = round(self.config.step_dt * 1e9)

        self._lock = threading.Condition()
        self._inbox = _Inbox()
        listeners = ReentrantCallbackGroup()
        self._clock_publisher = self.create_publisher(Clock, "/clock", RELIABLE)
        self._trial_start = self.create_publisher(TrialStart, "/trial_start", RELIABLE)
        self._state = self.create_publisher(SwarmState, "/swarm_state", RELIABLE)
        self._poses = self.create_publisher(PoseArray, "/poses", RELIABLE)
        self._ground: list[Publisher] = []
        self._readings: list[Publisher] = []
        self._start_clients: list[Client] = []
        for i in range(self.robots):
            ns = f"/footbot_{i}"
            self._ground.append(self.create_publisher(GroundSensor, f"{ns}/ground", RELIABLE))
            self._readings.append(
                self.create_publisher(RangeAndBearingReadings, f"{ns}/range_and_bearing", RELIABLE)
            )
            self.create_subscription(
                WheelCommand, f"{ns}/wheels", self._on_wheels, RELIABLE, callback_group=listeners
            )
            self.create_subscription(
                TreeStatus, f"{ns}/tree_status", self._on_status, RELIABLE, callback_group=listeners
            )
            self._start_clients.append(
                self.create_client(StartTrial, f"{ns}/start_trial", callback_group=listeners)
            )
        self.create_service(
            RunTrial, "~/run_trial", self._on_run_trial, callback_group=MutuallyExclusiveCallbackGroup()
        )

    # --- subscriptions
    def _on_wheels(self, msg: WheelCommand) -> None:
        with self._lock:
            inbox = self._inbox
            if inbox.answers is not None and msg.step == inbox.step and msg.robot < self.robots:
                inbox.answers[msg.robot] = msg
                self._lock.notify_all()

    def _on_status(self, msg: TreeStatus) -> None:
        with self._lock:
            inbox = self._inbox
            if inbox.counts is not None and msg.robot < self.robots:
                inbox.counts[msg.robot, 0] += msg.condition_ticks
                if msg.action >= 0:
                    inbox.counts[msg.robot, 1 + msg.action] += 1
                inbox.statuses += 1
                self._lock.notify_all()

    # --- the service
    def _on_run_trial(self, request: RunTrial.Request, response: RunTrial.Response) -> RunTrial.Response:
        try:
            arena = int(request.arena_configuration)
            if arena not in (-1, *range(len(self.config.gaps))):
                raise TrialAbandonedError(
                    f"arena_configuration must be -1 or 0..{len(self.config.gaps) - 1}, got {arena}"
                )
            own = request.trial % len(self.config.gaps)
            if arena >= 0 and arena != own:
                raise TrialAbandonedError(
                    f"trial {request.trial} uses arena configuration {own}, not {arena} (-1 means its own)"
                )
            record = self.run_trial(int(request.seed), int(request.trial))
        except (TrialAbandonedError, ValueError) as error:
            response.success = False
            response.message = str(error)
            self.get_logger().error(response.message)
            return response
        response.success = True
        for name, value in zip(VALUE_NAMES, record.values, strict=True):
            setattr(response, name, value)
        response.start_poses = [RobotPose(x=p[0], y=p[1], theta=p[2]) for p in record.start_poses.tolist()]
        response.end_poses = [RobotPose(x=p[0], y=p[1], theta=p[2]) for p in record.end_poses.tolist()]
        return response

    def run_trial(self, seed: int, trial: int) -> TrialRecord:
        """Run trial ``trial`` of ``seed`` through the controllers; return its record."""
        world = LockstepTrial(seed, trial, self.config)
        p = world.p
        self._start_controllers(world, seed, trial)
        with self._lock:
            self._inbox = _Inbox(step=0, answers={}, counts=np.zeros((self.robots, 8), np.int64))
        self._trial_start.publish(
            TrialStart(
                header=self._header("arena"),
                seed=seed,
                trial=trial,
                arena_configuration=trial % len(self.config.gaps),
                robots=self.robots,
                tree_keys=[int(k) for k in world.setup.tree_keys],
            )
        )
        while not world.done:
            self._publish_step(world, seed, trial)
            answers = self._await_answers(world.step)
            world.advance(
                [
                    RobotAnswer(
                        action=action_of_wheels(a.left, a.right),
                        broadcast=(a.nest_estimate, a.food_estimate),
                        smoothed=(a.smoothed_nest, a.smoothed_food, a.smoothed_density),
                    )
                    for a in answers
                ]
            )
            if not world.done:
                self.sim_time_ns += self.step_ns
                with self._lock:
                    self._inbox.step = world.step
                    self._inbox.answers = {}
        counts = self._await_statuses(self.robots * p.ticks)
        self.sim_time_ns += self.step_ns
        return world.record(counts)

    # --- steps
    def _start_controllers(self, world: LockstepTrial, seed: int, trial: int) -> None:
        p = world.p
        futures = []
        for i, client in enumerate(self._start_clients):
            if not client.wait_for_service(timeout_sec=self.answer_timeout):
                raise TrialAbandonedError(f"footbot_{i}'s start_trial service is not available")
            request = StartTrial.Request(
                seed=seed,
                trial=trial,
                tree_key=int(world.setup.tree_keys[i]),
                settle_steps=p.settle_steps,
                steps_per_tick=p.steps_per_tick,
                ticks=p.ticks,
                window=p.window,
                estimate_cap=p.estimate_cap,
                density_range=p.density_range,
                density_divisor=p.density_divisor,
            )
            futures.append(client.call_async(request))
        for i, future in enumerate(futures):
            done = threading.Event()
            future.add_done_callback(lambda _f, done=done: done.set())  # type: ignore[misc]  # rclpy is untyped
            response = future.result() if done.wait(self.answer_timeout) else None
            if response is None:
                raise TrialAbandonedError(f"footbot_{i} did not answer start_trial")
            if not response.success:
                raise TrialAbandonedError(f"footbot_{i} cannot run the trial: {response.message}")

    def _publish_step(self, world: LockstepTrial, seed: int, trial: int) -> None:
        stamp = self._stamp()
        self._clock_publisher.publish(Clock(clock=stamp))
        poses = world.poses()
        self._state.publish(
            SwarmState(
                header=Header(stamp=stamp, frame_id="arena"),
                seed=seed,
                trial=trial,
                step=world.step,
                poses=[RobotPose(x=x, y=y, theta=t) for x, y, t in poses.tolist()],
            )
        )
        self._poses.publish(
            PoseArray(header=Header(stamp=stamp, frame_id="arena"), poses=[_pose(q) for q in poses])
        )
        for i, readings in enumerate(world.readings()):
            header = Header(stamp=stamp, frame_id=f"footbot_{i}")
            self._ground[i].publish(
                GroundSensor(
                    header=header, step=world.step, in_nest=readings.in_nest, on_food=readings.on_food
                )
            )
            messages = [
                RangeAndBearing(sender=int(s), range=r, bearing=b, nest_estimate=n, food_estimate=f)
                for s, r, b, n, f in zip(
                    readings.senders.tolist(),
                    readings.ranges.tolist(),
                    readings.bearings.tolist(),
                    readings.nest.tolist(),
                    readings.food.tolist(),
                    strict=True,
                )
            ]
            self._readings[i].publish(
                RangeAndBearingReadings(header=header, step=world.step, readings=messages)
            )

    def _await_answers(self, step: int) -> list[WheelCommand]:
        with self._lock:
            answers = self._inbox.answers
            assert answers is not None, "answers are awaited only during a step"
            if not self._lock.wait_for(lambda: len(answers) == self.robots, self.answer_timeout):
                missing = sorted(set(range(self.robots)) - set(answers))
                raise TrialAbandonedError(
                    f"no answer to step {step} from footbot(s) {missing} in {self.answer_timeout} s"
                )
            return [answers[i] for i in range(self.robots)]

    def _await_statuses(self, expected: int) -> np.ndarray:
        with self._lock:
            if not self._lock.wait_for(lambda: self._inbox.statuses >= expected, self.answer_timeout):
                raise TrialAbandonedError(f"received {self._inbox.statuses} of {expected} tree statuses")
            assert self._inbox.counts is not None, "statuses are awaited only during a trial"
            counts = self._inbox.counts.copy()
            self._inbox = _Inbox()
            return counts

    def _stamp(self) -> Time:
        return Time(sec=self.sim_time_ns // 1_000_000_000, nanosec=self.sim_time_ns % 1_000_000_000)

    def _header(self, frame: str) -> Header:
        return Header(stamp=self._stamp(), frame_id=frame)


def _pose(pose: np.ndarray) -> Pose:
    """A PoseArray entry in metres from (x mm, y mm, heading rad)."""
    out = Pose()
    out.position.x = float(pose[0]) / 1000.0
    out.position.y = float(pose[1]) / 1000.0
    out.orientation.z = math.sin(float(pose[2]) / 2.0)
    out.orientation.w = math.cos(float(pose[2]) / 2.0)
    return out


def main(args: list[str] | None = None) -> None:
    """Run the simulator node until shut down."""
    rclpy.init(args=args)
    spin_until_shutdown(SimulatorNode(), MultiThreadedExecutor(num_threads=4))
