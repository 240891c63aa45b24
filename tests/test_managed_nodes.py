"""The graph's managed nodes and their ROS 2 interfaces, each shown with real node processes and real clients:
the simulator and the evaluator are managed (lifecycle) nodes driven through ``change_state``, report on
``/diagnostics``, and reject a goal they cannot run in the goal callback; the simulator's clock is ``/clock``
whatever its namespace; the footbot controller can publish ``geometry_msgs/TwistStamped`` (or ``Twist``) on
``cmd_vel`` (REP 103 units)."""

import time

import pytest
import rclpy
from builtin_interfaces.msg import Time
from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus
from geometry_msgs.msg import Twist, TwistStamped
from rclpy.action import ActionClient
from rclpy.executors import SingleThreadedExecutor
from rclpy.node import Node
from std_msgs.msg import Header

from bt_controller.language import ACTION_WHEELS, ACTIONS
from evolution_manager.graph.startup import Graph
from swarm_msgs.action import EvaluateBatch, RunTrial
from swarm_msgs.msg import GroundSensor, RangeAndBearingReadings, WheelCommand
from swarm_msgs.srv import StartTrial
from swarm_ros.isolation import reserved_domain
from swarm_ros.lifecycle import LifecycleClient
from swarm_ros.qos import RELIABLE
from swarm_ros.services import call_until_answered
from swarm_sim.evaluation import BatchEvaluator, EvaluationRequest, named_values
from swarm_sim.model import DEFAULT, OBJECTIVES

LONG = 300.0
"""Seconds to wait for anything a node does (starting Python processes is slow on a loaded machine)."""


class Ros:
    """A client node in the graph's domain, spun by the test."""

    def __init__(self, nodes: Graph, node: Node, executor: SingleThreadedExecutor) -> None:
        self.nodes, self.node, self.executor = nodes, node, executor

    def spin_until(self, done, what, timeout=LONG):
        deadline = time.monotonic() + timeout
        while not done():
            self.nodes.check()
            assert time.monotonic() < deadline, f"timed out waiting for {what}"
            self.executor.spin_once(timeout_sec=0.05)

    def spin_for(self, seconds):
        deadline = time.monotonic() + seconds
        while time.monotonic() < deadline:
            self.executor.spin_once(timeout_sec=0.05)

    def wait(self, future, seconds):
        deadline = time.monotonic() + seconds
        while not future.done() and time.monotonic() < deadline:
            self.nodes.check()
            self.executor.spin_once(timeout_sec=0.05)
        return future.done()

    def answer(self, future, what):
        self.spin_until(future.done, what)
        return future.result()

    def send(self, client, goal):
        """The goal handle of ``goal`` sent to ``client`` (accepted or not)."""
        return self.answer(client.send_goal_async(goal), "the goal's acceptance")

    def diagnostics(self, name):
        """The statuses of node ``name`` on /diagnostics, as they arrive (a list the subscription fills)."""
        statuses = []

        def take(msg):
            statuses.extend(s for s in msg.status if s.name == name)

        self.node.create_subscription(DiagnosticArray, "/diagnostics", take, 10)
        return statuses


def value(status, key):
    return {kv.key: kv.value for kv in status.values}[key]


@pytest.fixture
def ros(tmp_path):
    with reserved_domain() as domain, Graph(domain, log_dir=tmp_path / "logs") as nodes:
        context = rclpy.Context()
        rclpy.init(context=context, domain_id=domain)
        node = Node("habits_client", context=context)
        executor = SingleThreadedExecutor(context=context)
        executor.add_node(node)
        try:
            yield Ros(nodes, node, executor)
        finally:
            executor.shutdown()
            node.destroy_node()
            rclpy.shutdown(context=context)


def test_the_evaluator_is_driven_through_its_lifecycle_and_reports_it_on_diagnostics(ros):
    ros.nodes.start("evaluator", "swarm_sim", "evaluator", parameters={"autostart": "false", "slice": 5})
    statuses = ros.diagnostics("/evaluator")
    life = LifecycleClient(ros.node, "/evaluator")
    action = ActionClient(ros.node, EvaluateBatch, "/evaluator/evaluate")
    ros.spin_until(life.ready, "the evaluator's lifecycle services")
    assert life.state(ros.wait, LONG) == "unconfigured"
    ros.spin_until(lambda: statuses, "the evaluator's diagnostics")
    assert statuses[-1].level == DiagnosticStatus.WARN and value(statuses[-1], "state") == "unconfigured"
    assert not action.server_is_ready()  # nothing is offered before configure

    life.transition("configure", ros.wait, LONG)
    assert life.state(ros.wait, LONG) == "inactive"
    ros.spin_until(action.server_is_ready, "the evaluate action")
    goal = EvaluateBatch.Goal(trees=["forward", "sel(seq(in_nest, stop), forward)"], seeds=[1, 2], trials=2)
    goal.objective = "nest"
    assert not ros.send(action, goal).accepted  # inactive: rejected in the goal callback

    life.transition("activate", ros.wait, LONG)
    handle = ros.send(action, goal)
    assert handle.accepted
    result = ros.answer(handle.get_result_async(), "the batch's result")
    expected = BatchEvaluator().evaluate(
        [EvaluationRequest(t, s, 2) for t, s in zip(goal.trees, goal.seeds, strict=True)]
    )
    assert [named_values(r)["nest"] for r in result.result.results] == [r.fitness[1] for r in expected]
    ros.spin_until(
        lambda: value(statuses[-1], "state") == "active" and value(statuses[-1], "evaluations") == "2",
        "diagnostics counting the two evaluations",
    )
    assert statuses[-1].level == DiagnosticStatus.OK
    assert {"evaluations per second", "goals waiting", "evaluations left"} <= {
        kv.key for kv in statuses[-1].values
    }

    # deactivate stops a batch under way after its slice, with what it finished
    feedback = []
    trees = ["sel(seq(robot_left, forward_left), prob(forward, reverse_right))"] * 60
    big = EvaluateBatch.Goal(trees=trees, seeds=list(range(60)), trials=10, objective="food")
    handle = ros.answer(
        action.send_goal_async(big, feedback_callback=lambda m: feedback.append(m.feedback.done)),
        "acceptance",
    )
    ros.spin_until(lambda: feedback, "the big batch's first slice")
    life.transition("deactivate", ros.wait, LONG)
    stopped = ros.answer(handle.get_result_async(), "the deactivated batch's result")
    finished = len(stopped.result.results)
    assert stopped.status == 6  # action_msgs/GoalStatus STATUS_ABORTED
    assert stopped.result.message == f"deactivated after {finished} of 60 evaluations"
    assert feedback[0] <= finished < 60 and finished % 5 == 0  # slice 5
    assert not ros.send(action, goal).accepted
    ros.spin_until(lambda: value(statuses[-1], "state") == "inactive", "diagnostics saying inactive")
    life.transition("cleanup", ros.wait, LONG)
    ros.spin_until(lambda: not action.server_is_ready(), "the evaluate action withdrawn")
    life.transition("shutdown", ros.wait, LONG)
    assert life.state(ros.wait, LONG) == "finalized"


@pytest.mark.parametrize(
    ("fields", "why"),
    [
        ({"objective": "speed"}, f"objective must be one of {', '.join(OBJECTIVES)}, got 'speed'"),
        ({"seeds": [1]}, "got 2 trees but 1 seeds"),
        ({"trials": 0}, "trials must be in 1..10000, got 0"),
    ],
)
def test_the_evaluator_rejects_a_goal_it_cannot_run_in_the_goal_callback(ros, fields, why):
    ros.nodes.start("evaluator", "swarm_sim", "evaluator")
    action = ActionClient(ros.node, EvaluateBatch, "/evaluator/evaluate")
    ros.spin_until(action.server_is_ready, "the evaluate action")
    goal = EvaluateBatch.Goal(trees=["forward", "stop"], seeds=[1, 2], trials=1, objective="food")
    for name, given in fields.items():
        setattr(goal, name, given)
    assert not ros.send(action, goal).accepted
    ros.nodes.stop()
    assert f"rejected a goal: {why}" in (ros.nodes.log_dir / "evaluator.log").read_text()


def test_the_simulator_is_managed_its_clock_is_at_the_root_and_bad_goals_are_rejected(ros):
    ros.nodes.start(
        "simulator",
        "swarm_sim",
        "simulator",
        namespace="/swarm_a",
        parameters={"autostart": "false", "n_robots": 2, "answer_timeout": 1.0, "use_sim_time": "true"},
    )
    statuses = ros.diagnostics("/swarm_a/simulator")
    stamps = []
    ros.node.create_subscription(DiagnosticArray, "/diagnostics", lambda m: stamps.append(m.header.stamp), 10)
    life = LifecycleClient(ros.node, "/swarm_a/simulator")
    action = ActionClient(ros.node, RunTrial, "/swarm_a/simulator/run_trial")
    ros.spin_until(life.ready, "the simulator's lifecycle services")
    # under use_sim_time, with no /clock ticking yet, the diagnostics still come (a steady timer), stamped in
    # simulated time (0 before any trial), not wall time
    ros.spin_until(lambda: len(statuses) >= 2, "diagnostics while unconfigured under use_sim_time")
    assert value(statuses[0], "state") == "unconfigured"
    assert (stamps[0].sec, stamps[0].nanosec) == (0, 0)
    life.drive(["configure", "activate"], ros.wait, LONG)
    ros.spin_until(action.server_is_ready, "the run_trial action")

    def clock_publishers():
        return [(i.node_name, i.node_namespace) for i in ros.node.get_publishers_info_by_topic("/clock")]

    ros.spin_until(lambda: clock_publishers() == [("simulator", "/swarm_a")], "the simulator on /clock")
    assert ros.node.get_publishers_info_by_topic("/swarm_a/clock") == []

    # trial 5 opens the second block of chain_trials (5) trials: arena configuration 1 (docs/model.md)
    assert not ros.send(action, RunTrial.Goal(seed=1, trial=5, arena_configuration=0)).accepted
    assert not ros.send(action, RunTrial.Goal(seed=1, trial=0, arena_configuration=2)).accepted
    assert RunTrial.Goal().arena_configuration == -1  # the trial's own, when a goal leaves it out
    handle = ros.send(action, RunTrial.Goal(seed=1, trial=5))
    assert handle.accepted  # then abandoned: no controller answers start_trial
    result = ros.answer(handle.get_result_async(), "the abandoned trial's result").result
    assert not result.success and "start_trial service" in result.message
    ros.spin_until(
        lambda: statuses and value(statuses[-1], "trials run") == "1", "diagnostics counting the trial"
    )
    assert value(statuses[-1], "state") == "active" and "steps per second" in {
        kv.key for kv in statuses[-1].values
    }
    assert stamps[-1].sec < 3600  # simulated time (the trial was abandoned before its first steps)

    life.transition("deactivate", ros.wait, LONG)
    assert not ros.send(action, RunTrial.Goal(seed=1, trial=0, arena_configuration=-1)).accepted
    life.transition("shutdown", ros.wait, LONG)
    assert life.state(ros.wait, LONG) == "finalized"


def test_the_controller_publishes_each_step_on_cmd_vel_as_twist_stamped_or_twist_in_rep_103_units(ros):
    # footbot_2 with the default type (TwistStamped), footbot_3 with cmd_vel_type:=Twist, in one graph
    for name, extra in (("footbot_2", {}), ("footbot_3", {"cmd_vel_type": "Twist"})):
        ros.nodes.start(
            name,
            "bt_controller",
            "footbot_controller",
            namespace=f"/{name}",
            parameters={"commands": "both", "tree": "forward_left", **extra},
        )
    wheels, stamped, plain, wheels_3 = [], [], [], []
    ros.node.create_subscription(WheelCommand, "/footbot_2/wheels", wheels.append, RELIABLE)
    ros.node.create_subscription(TwistStamped, "/footbot_2/cmd_vel", stamped.append, RELIABLE)
    ros.node.create_subscription(WheelCommand, "/footbot_3/wheels", wheels_3.append, RELIABLE)
    ros.node.create_subscription(Twist, "/footbot_3/cmd_vel", plain.append, RELIABLE)
    c = DEFAULT
    request = StartTrial.Request(
        seed=3,
        trial=0,
        tree_key=7,
        profile=c.profile,
        steps_per_tick=c.steps_per_tick,
        ticks=c.ticks,
        initial_step=c.initial_step,
        chain_trials=c.chain_trials,
        trials=1,
        window=c.window,
        estimate_cap=c.estimate_cap,
        density_range=c.density_range,
        density_divisor=c.density_divisor,
        food_kinds=c.food_kinds,
        wheel_speed=c.wheel_speed / 1000,
        wheel_separation=c.wheel_separation / 1000,
    )
    steps = 3 * c.steps_per_tick
    for name in ("footbot_2", "footbot_3"):
        ground = ros.node.create_publisher(GroundSensor, f"/{name}/ground", RELIABLE)
        readings = ros.node.create_publisher(RangeAndBearingReadings, f"/{name}/range_and_bearing", RELIABLE)
        start = ros.node.create_client(StartTrial, f"/{name}/start_trial")
        ros.spin_until(start.service_is_ready, f"{name}'s start_trial service")
        # start_trial may be repeated (as the simulator does): an answer lost to discovery is asked again
        started = call_until_answered(start, request, ros.wait, LONG)
        assert started is not None and started.success, f"{name} did not start the trial"
        ros.spin_until(
            lambda g=ground, r=readings: g.get_subscription_count() and r.get_subscription_count(),
            "the subscriptions",
        )
        ros.spin_until(lambda n=name: ros.node.count_publishers(f"/{n}/cmd_vel"), "the cmd_vel publisher")
        for step in range(1, steps + 1):
            stamp = Time(sec=step // 8, nanosec=(step % 8) * 125_000_000)
            ground.publish(GroundSensor(header=Header(stamp=stamp), step=step))
            readings.publish(RangeAndBearingReadings(step=step))
    ros.spin_until(
        lambda: len(wheels) == len(stamped) == len(wheels_3) == len(plain) == steps,
        "every step's wheels and cmd_vel",
    )

    separation = c.wheel_separation / 1000  # m
    assert [t.twist for t in stamped] == plain  # the same velocities, stamped or not
    for wheel, twist in zip(wheels, stamped, strict=True):
        assert twist.header.frame_id == "footbot_2/base_link"  # the robot's own base frame (REP 105)
        assert twist.header.stamp == wheel.header.stamp  # the step's time
        velocity = twist.twist
        assert velocity.linear.x == pytest.approx((wheel.left + wheel.right) / 2)
        assert velocity.angular.z == pytest.approx((wheel.right - wheel.left) / separation)
        assert (velocity.linear.y, velocity.linear.z, velocity.angular.x, velocity.angular.y) == (0, 0, 0, 0)
    assert [w.header.stamp.nanosec for w in wheels][1] == 250_000_000  # step 2's stamp, passed through
    turning = [t.twist for w, t in zip(wheels, stamped, strict=True) if w.action_name == "forward_left"]
    assert turning, [w.action_name for w in wheels]
    speed = c.wheel_speed / 1000
    left, right = ACTION_WHEELS[ACTIONS.index("forward_left")]
    # forward_left drives the right wheel only: half the wheel speed forwards, turning anticlockwise (+z)
    assert (left, right) == (0, 1)
    assert turning[-1].linear.x == pytest.approx(speed / 2)
    assert turning[-1].angular.z == pytest.approx(speed / separation) and turning[-1].angular.z > 0
