"""A trial bag keeps its own graph's frames: ``/tf`` and ``/tf_static`` are at the root, shared by every graph
of a domain, and the recorder writes only the messages that move one of its graph's frames."""

import time

import rclpy
from geometry_msgs.msg import TransformStamped
from rclpy.executors import SingleThreadedExecutor
from rclpy.node import Node
from std_msgs.msg import Header

from evolution_manager.graph.nodes.recorder import GraphRecorder, graph_frames
from evolution_manager.recording.bags import BagRecorder, read_bag
from swarm_ros.isolation import reserved_domain
from swarm_ros.qos import RECORDING
from tf2_msgs.msg import TFMessage


def moving(child: str, sec: int) -> TFMessage:
    header = Header(frame_id=child.rsplit("/", 1)[0] + "/odom")
    header.stamp.sec = sec
    return TFMessage(transforms=[TransformStamped(header=header, child_frame_id=child)])


def test_graph_frames_are_each_robots_odom_and_base_link_under_the_graphs_namespace():
    assert graph_frames(2, "/swarm_a") == {
        "swarm_a/footbot_0/odom",
        "swarm_a/footbot_0/base_link",
        "swarm_a/footbot_1/odom",
        "swarm_a/footbot_1/base_link",
    }
    assert "footbot_1/base_link" in graph_frames(2)


def test_the_recorder_writes_only_its_own_graphs_transforms(tmp_path):
    with reserved_domain() as domain:
        context = rclpy.Context()
        rclpy.init(context=context, domain_id=domain)
        try:
            node = Node("recorder", context=context)
            with BagRecorder(tmp_path / "bag") as bag:
                recorder = GraphRecorder(node, bag, [("/tf", TFMessage)], frames=graph_frames(9, "/swarm_a"))
                publisher = node.create_publisher(TFMessage, "/tf", RECORDING)
                executor = SingleThreadedExecutor(context=context)
                executor.add_node(node)
                deadline = time.monotonic() + 30
                while not recorder.all_publishers_matched() and time.monotonic() < deadline:
                    executor.spin_once(timeout_sec=0.05)
                publisher.publish(moving("swarm_b/footbot_3/base_link", 5))  # another swarm's robot
                publisher.publish(moving("swarm_a/footbot_3/base_link", 7))
                while recorder.counts["/tf"] < 1 and time.monotonic() < deadline:
                    executor.spin_once(timeout_sec=0.05)
                executor.spin_once(timeout_sec=0.2)
                executor.shutdown()
            node.destroy_node()
        finally:
            rclpy.try_shutdown(context=context)
    (kept,) = list(read_bag(tmp_path / "bag"))
    assert kept.message.transforms[0].child_frame_id == "swarm_a/footbot_3/base_link"
    assert kept.timestamp_ns == 7_000_000_000
    assert recorder.received["/tf"] == 1
