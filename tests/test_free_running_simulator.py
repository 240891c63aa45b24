"""The free-running trial graph (``trial --timing free``): the simulator steps on its own clock without
waiting for the controllers, which tick on their own timers in simulated time; a trial completes, recorded,
and the robots drive; a plain rclpy subscriber (no tf2) sees each robot's ``nav_msgs/Odometry`` and ``/tf``
and ``/tf_static`` with every robot frame under its graph's and robot's namespace (REP 105).
What ``--timing`` and ``--rate`` refuse, in one line, before any node starts."""

from __future__ import annotations

import threading

import numpy as np
import pytest
import rclpy
from nav_msgs.msg import Odometry
from rclpy.executors import SingleThreadedExecutor
from rclpy.node import Node
from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy

from evolution_manager.graph.nodes.trial import TrialGraph
from evolution_manager.graph.nodes.trial import main as trial_main
from evolution_manager.recording.bags import read_bag
from swarm_ros.isolation import reserved_domain
from tf2_msgs.msg import TFMessage

LATCHED = QoSProfile(
    depth=100, reliability=ReliabilityPolicy.RELIABLE, durability=DurabilityPolicy.TRANSIENT_LOCAL
)
"""How tf2's listeners subscribe to ``/tf_static``."""


def test_a_free_running_trial_completes_recorded_and_its_robots_drive(tmp_path):
    bag = tmp_path / "free"
    odometry: list[Odometry] = []
    tf: list[TFMessage] = []
    tf_static: list[TFMessage] = []
    with reserved_domain() as domain:
        context = rclpy.Context()
        rclpy.init(context=context, domain_id=domain)
        node = Node("plain_listener", context=context)
        node.create_subscription(Odometry, "/swarm_a/footbot_1/odom", odometry.append, 1000)
        node.create_subscription(TFMessage, "/tf", tf.append, 1000)
        node.create_subscription(TFMessage, "/tf_static", tf_static.append, LATCHED)
        executor = SingleThreadedExecutor(context=context)
        executor.add_node(node)
        spinning = threading.Thread(target=executor.spin, daemon=True)
        spinning.start()
        try:
            with TrialGraph(
                robots=3, timing="free", rate=2.0, timeout=300.0, domain=domain, namespace="/swarm_a"
            ) as graph:
                record = graph.run("forward", 5, 0, bag)
        finally:
            executor.shutdown()
            node.destroy_node()
            rclpy.shutdown(context=context)
            spinning.join(timeout=10)
    assert record.trial == 0
    moved = np.hypot(*(record.end_poses[:, :2] - record.start_poses[:, :2]).T)  # mm
    assert (moved > 50.0).any(), moved  # driven by the controllers' own ticks: forward, 50 mm/s

    messages = list(read_bag(bag))
    steps = [m.message.step for m in messages if m.topic == "/swarm_a/swarm_state"]
    assert steps == list(range(1, 161))  # every step of the trial, in order, without waiting for answers
    for robot in range(3):
        wheels = [m.message for m in messages if m.topic == f"/swarm_a/footbot_{robot}/wheels"]
        assert wheels, f"footbot_{robot} never answered"
        assert {w.action_name for w in wheels} <= {"stop", "forward"}
        assert "forward" in {w.action_name for w in wheels}
        # a free controller answers the newest sensing step it used, never a step still to come
        assert all(0 <= w.step <= 160 for w in wheels)
        # every message names the robot by its frame on /tf: readings, answers and statuses alike
        frame = f"swarm_a/footbot_{robot}/base_link"
        for name in ("ground", "range_and_bearing", "wheels", "tree_status"):
            named = {
                m.message.header.frame_id for m in messages if m.topic == f"/swarm_a/footbot_{robot}/{name}"
            }
            assert named == {frame}, (name, named)
    # the bag holds what a ROS user replays: each robot's odometry, /tf every step, /tf_static once
    recorded = {m.topic: sum(1 for n in messages if n.topic == m.topic) for m in messages}
    assert recorded["/tf"] == recorded["/swarm_a/footbot_2/odom"] == 160 and recorded["/tf_static"] == 1

    # odometry (REP 105): the robot's own frames, under its namespace; metres per second forward
    assert odometry, "no odometry on /swarm_a/footbot_1/odom"
    assert {(m.header.frame_id, m.child_frame_id) for m in odometry} == {
        ("swarm_a/footbot_1/odom", "swarm_a/footbot_1/base_link")
    }
    assert max(m.twist.twist.linear.x for m in odometry) > 0.01  # forward, about 0.05 m/s when free
    assert all(abs(m.twist.twist.linear.x) < 0.2 for m in odometry)  # m/s, not mm/s

    # /tf and /tf_static: arena -> <robot>/odom (static, identity) -> <robot>/base_link (every step)
    robots = [f"swarm_a/footbot_{i}" for i in range(3)]
    (static,) = {tuple((t.header.frame_id, t.child_frame_id) for t in m.transforms) for m in tf_static}
    assert static == tuple(("arena", f"{r}/odom") for r in robots)
    assert tf, "nothing on /tf"
    for message in tf:
        assert [(t.header.frame_id, t.child_frame_id) for t in message.transforms] == [
            (f"{r}/odom", f"{r}/base_link") for r in robots
        ]
    last = {o.header.stamp.sec * 10**9 + o.header.stamp.nanosec: o for o in odometry}
    for message in tf:  # the same pose as the odometry of the same step, in metres
        moved = message.transforms[1]
        stamp = moved.header.stamp.sec * 10**9 + moved.header.stamp.nanosec
        if stamp in last:
            position = last[stamp].pose.pose.position
            assert (moved.transform.translation.x, moved.transform.translation.y) == (position.x, position.y)


@pytest.mark.parametrize(
    ("options", "error"),
    [
        (["--rate", "2"], "trial: --rate applies to --timing free only"),
        (["--timing", "free", "--rate", "0"], "expected a number in 0.01..100, got '0'"),
        (["--timing", "free", "--rate", "fast"], "expected a number in 0.01..100, got 'fast'"),
        (["--timing", "loose"], "invalid choice: 'loose'"),
    ],
)
def test_bad_timing_options_are_one_line_before_any_node_starts(tmp_path, capsys, options, error):
    status = trial_main(["--tree", "forward", "--bag", str(tmp_path / "b"), *options])
    lines = capsys.readouterr().err.strip().splitlines()
    assert status == 2
    assert len(lines) == 1 and error in lines[0], lines
    assert not (tmp_path / "b").exists()
