"""The footbot controller with ``timing:=free``, as a real rclpy node in its own context and domain: it ticks
on its own timer whatever the readings do (dropped, delayed, duplicated), stops the robot after a sensing
timeout and says so (a warning on /rosout, a WARN on /diagnostics), ticks again when readings come back, and
takes best-effort publishers (``qos_profile_sensor_data``, a driver's usual choice) as well as reliable ones;
with ``sensor_qos:=best_effort`` so does a lockstep controller."""

import time

import pytest
import rclpy
from builtin_interfaces.msg import Time
from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus
from rcl_interfaces.msg import Log
from rclpy.executors import SingleThreadedExecutor
from rclpy.node import Node
from rclpy.parameter import Parameter
from rclpy.qos import qos_profile_sensor_data
from rosgraph_msgs.msg import Clock

from bt_controller.nodes.footbot_controller import FootbotControllerNode
from swarm_msgs.msg import GroundSensor, RangeAndBearingReadings, TreeStatus, WheelCommand
from swarm_msgs.srv import StartTrial
from swarm_ros.isolation import reserved_domain
from swarm_ros.qos import RELIABLE
from swarm_ros.services import call_until_answered

SPEED = 0.05  # m/s, the controller's default wheel speed
WAIT = 120.0  # seconds for anything to arrive (a loaded machine)


class Bench:
    """A free-running controller under test and a node that feeds and watches it, spun in one executor."""

    def __init__(self, context, controller, sensor_qos=qos_profile_sensor_data):
        self.controller = controller
        self.node = Node("bench", context=context)
        self.executor = SingleThreadedExecutor(context=context)
        self.executor.add_node(controller)
        self.executor.add_node(self.node)
        ns = controller.get_namespace()
        self.ground = self.node.create_publisher(GroundSensor, f"{ns}/ground", sensor_qos)
        self.rab = self.node.create_publisher(RangeAndBearingReadings, f"{ns}/range_and_bearing", sensor_qos)
        self.wheels: list[tuple[float, WheelCommand]] = []
        self.ticks: list[TreeStatus] = []
        self.warnings: list[str] = []
        self.statuses: list[DiagnosticStatus] = []
        sub = self.node.create_subscription
        sub(WheelCommand, f"{ns}/wheels", lambda m: self.wheels.append((time.monotonic(), m)), RELIABLE)
        sub(TreeStatus, f"{ns}/tree_status", self.ticks.append, RELIABLE)
        name = controller.get_fully_qualified_name()
        sub(
            Log,
            "/rosout",
            lambda m: (
                self.warnings.append(m.msg)
                if m.level == Log.WARN and m.name.endswith(name[1:].replace("/", "."))
                else None
            ),
            100,
        )
        sub(
            DiagnosticArray,
            "/diagnostics",
            lambda m: self.statuses.extend(s for s in m.status if s.name == name),
            10,
        )

    def spin_until(self, done, what, timeout=WAIT):
        deadline = time.monotonic() + timeout
        while not done():
            assert time.monotonic() < deadline, f"timed out waiting for {what}"
            self.executor.spin_once(timeout_sec=0.02)

    def spin_for(self, seconds):
        deadline = time.monotonic() + seconds
        while time.monotonic() < deadline:
            self.executor.spin_once(timeout_sec=0.02)

    def wait(self, future, seconds):
        """Spin up to ``seconds`` for ``future``; whether it is done (``call_until_answered``'s wait)."""
        deadline = time.monotonic() + seconds
        while not future.done() and time.monotonic() < deadline:
            self.executor.spin_once(timeout_sec=0.02)
        return future.done()

    def send(self, step, ground=True, rab=True, in_nest=False):
        if ground:
            self.ground.publish(GroundSensor(step=step, in_nest=in_nest))
        if rab:
            self.rab.publish(RangeAndBearingReadings(step=step))

    def connected(self):
        return (
            self.ground.get_subscription_count()
            and self.rab.get_subscription_count()
            and (self.node.count_publishers(f"{self.controller.get_namespace()}/wheels"))
        )

    def close(self):
        self.executor.shutdown()
        self.node.destroy_node()
        self.controller.destroy_node()


@pytest.fixture
def context():
    with reserved_domain() as domain:
        ctx = rclpy.Context()
        rclpy.init(context=ctx, domain_id=domain)
        try:
            yield ctx
        finally:
            rclpy.shutdown(context=ctx)


def controller(context, robot=3, **parameters):
    overrides = [Parameter(k, value=v) for k, v in parameters.items()]
    return FootbotControllerNode(
        context=context, namespace=f"/footbot_{robot}", parameter_overrides=overrides
    )


FREE = {"timing": "free", "tick_rate": 10.0, "sensing_timeout": 0.5, "tree": "forward"}


def test_dropped_delayed_and_duplicated_readings_never_stall_it_and_a_timeout_stops_the_robot(context):
    bench = Bench(context, controller(context, **FREE))
    try:
        bench.spin_until(bench.connected, "the controller's topics")
        # readings at 8 Hz with a step dropped, one delayed past a newer one, one duplicated
        schedule = [1, 2, 4, 3, 5, 5, 6, 8, 9, 10, 11, 12]  # 7 dropped, 3 late, 5 twice
        start = len(bench.wheels)
        for step in schedule:
            bench.send(step)
            bench.spin_for(0.125)
        counts = bench.controller.free.counts
        assert (counts.lost, counts.late, counts.duplicated) == (
            2,
            2,
            2,
        )  # 3 and 7 lost; 3 late (x2 readings)
        during = [m for _, m in bench.wheels[start:]]
        assert len(during) >= 8, "the controller did not tick at its own rate"  # 1.5 s at 10 Hz
        moving = [m for m in during if (m.left, m.right) == (SPEED, SPEED)]
        assert moving and during[-1].action_name == "forward" and during[-1].step == 12
        assert bench.ticks and bench.ticks[-1].step == 12

        # no more readings: after the timeout, a zero command at every tick, a warning and a WARN
        silence = time.monotonic()
        bench.spin_until(lambda: any("sensing timeout" in w for w in bench.warnings), "the timeout's warning")
        bench.spin_until(
            lambda: bench.statuses and bench.statuses[-1].level == DiagnosticStatus.WARN, "a WARN diagnostic"
        )
        assert "sensing timeout" in bench.statuses[-1].message
        values = {kv.key: kv.value for kv in bench.statuses[-1].values}
        assert values["steps lost"] == "2" and values["newest step"] == "12"
        stopped = [(t, m) for t, m in bench.wheels if t > silence and (m.left, m.right) == (0.0, 0.0)]
        assert stopped and stopped[-1][1].action_name == "stop"
        assert stopped[0][0] - silence >= 0.4  # not before the timeout (0.5 s after the last reading)
        ticks_stopped = len(bench.ticks)
        bench.spin_for(0.5)
        assert len(bench.ticks) == ticks_stopped  # the tree is not ticked without sensing
        assert (bench.wheels[-1][1].left, bench.wheels[-1][1].right) == (0.0, 0.0)  # still commanded to stop
        assert len([w for w in bench.warnings if "sensing timeout" in w]) == 1  # once per outage

        # readings come back: ticking and moving again, and the diagnostics say OK
        for step in range(20, 26):
            bench.send(step)
            bench.spin_for(0.125)
        bench.spin_until(lambda: bench.wheels[-1][1].left == SPEED, "moving again")
        bench.spin_until(lambda: bench.statuses[-1].level == DiagnosticStatus.OK, "an OK diagnostic")
    finally:
        bench.close()


def test_a_free_controller_takes_reliable_publishers_too_and_a_lockstep_one_best_effort_on_request(context):
    reliable = Bench(context, controller(context, robot=4, **FREE), sensor_qos=RELIABLE)
    try:
        reliable.spin_until(reliable.connected, "the controller's topics")
        for step in (1, 2, 3):
            reliable.send(step)
            reliable.spin_for(0.125)
        reliable.spin_until(lambda: reliable.ticks and reliable.ticks[-1].step == 3, "a tick on step 3")
    finally:
        reliable.close()

    # lockstep with sensor_qos:=best_effort answers every step a sensor-data publisher sends
    lockstep = Bench(context, controller(context, robot=5, tree="forward", sensor_qos="best_effort"))
    try:
        lockstep.spin_until(lockstep.connected, "the controller's topics")
        start_lockstep(lockstep)
        for step in range(1, 9):
            lockstep.send(step)
        lockstep.spin_until(lambda: len(lockstep.wheels) == 8, "an answer to each of 8 steps")
        assert [m.step for _, m in lockstep.wheels] == list(range(1, 9))
    finally:
        lockstep.close()


def start_lockstep(bench):
    """Start a one-trial chain on the bench's lockstep controller, as the simulator does."""
    ns = bench.controller.get_namespace()
    start = bench.node.create_client(StartTrial, f"{ns}/start_trial")
    bench.spin_until(start.service_is_ready, "start_trial")
    request = StartTrial.Request(
        tree_key=1,
        profile="paper",
        steps_per_tick=4,
        ticks=40,
        initial_step=1,
        chain_trials=5,
        trials=1,
        window=7,
        estimate_cap=5000.0,
        density_range=10000.0,
        density_divisor=6642.0,
        food_kinds=1,
        wheel_speed=SPEED,
        wheel_separation=0.14,
    )
    # start_trial may be repeated, as the simulator does: an answer lost to discovery is asked again
    started = call_until_answered(start, request, bench.wait, WAIT)
    assert started is not None, "no answer to start_trial"
    assert started.success, started.message


def test_a_lockstep_controller_says_when_a_lost_reading_stalls_it(context):
    bench = Bench(context, controller(context, robot=8, tree="forward"), sensor_qos=RELIABLE)
    try:
        bench.spin_until(bench.connected, "the controller's topics")
        start_lockstep(bench)
        bench.send(1)
        bench.spin_until(lambda: len(bench.wheels) == 1, "the answer to step 1")
        bench.send(2, rab=False)  # step 2's range-and-bearing reading is lost
        bench.send(3)
        bench.send(4)
        bench.spin_until(lambda: bench.warnings, "a warning")
        assert bench.warnings == [
            "lockstep stalled at step 2: its range_and_bearing reading never came, and step 3 has; a "
            "lockstep controller answers steps in order (timing:=free takes lost readings)"
        ]
        bench.spin_for(0.5)
        assert len(bench.wheels) == 1 and len(bench.warnings) == 1  # stalled, and said once
    finally:
        bench.close()


def test_a_lockstep_controller_stays_reliable_by_default(context):
    node = controller(context, robot=6, tree="forward")
    try:
        infos = node.get_subscriptions_info_by_topic("/footbot_6/ground")
        assert [i.qos_profile.reliability.name for i in infos] == ["RELIABLE"]
    finally:
        node.destroy_node()


def test_under_use_sim_time_it_ticks_and_times_out_in_simulated_time(context):
    bench = Bench(context, controller(context, robot=7, use_sim_time=True, **FREE))
    clock = bench.node.create_publisher(Clock, "/clock", 10)
    try:
        bench.spin_until(bench.connected, "the controller's topics")
        bench.spin_until(lambda: clock.get_subscription_count(), "the controller on /clock")

        def at(seconds):
            clock.publish(Clock(clock=Time(sec=int(seconds), nanosec=round(seconds % 1 * 1e9))))
            bench.spin_for(0.05)

        at(100.0)  # the simulated clock starts at 100 s: the timeout counts from there, not from 0
        bench.send(1)
        bench.spin_for(0.2)
        for k in range(1, 6):  # half a simulated second at 10 Hz
            at(100.0 + 0.1 * k)
        bench.spin_until(lambda: bench.ticks, "a tick in simulated time")
        ticks, wheels = len(bench.ticks), len(bench.wheels)
        bench.spin_for(1.0)  # a wall second with the simulated clock still: no tick, no timeout
        assert (len(bench.ticks), len(bench.wheels)) == (ticks, wheels)
        assert not bench.warnings
        for k in range(6, 14):  # the simulated clock runs on without readings: a timeout after 0.5 s
            at(100.0 + 0.1 * k)
        bench.spin_until(lambda: any("sensing timeout" in w for w in bench.warnings), "the timeout")
        assert (bench.wheels[-1][1].left, bench.wheels[-1][1].right) == (0.0, 0.0)
        assert bench.wheels[-1][1].header.stamp.sec == 101  # stamped in simulated time
    finally:
        bench.close()
