"""ROS 2 messaging between processes: two real nodes in separate processes exchange swarm_msgs messages and a
service call over Fast DDS, in a domain of their own."""

import subprocess
import sys
import time
from pathlib import Path

import pytest
import rclpy
from rclpy.node import Node

from swarm_msgs.msg import RangeAndBearing, RangeAndBearingReadings, WheelCommand
from swarm_msgs.srv import LoadTree
from swarm_ros.isolation import domain_environment, reserved_domain
from swarm_ros.services import call_until_answered

RELAY = Path(__file__).parent / "nodes" / "relay_node.py"


@pytest.fixture
def domain():
    with reserved_domain() as domain_id:
        yield domain_id


@pytest.fixture
def relay(domain):
    process = subprocess.Popen(
        [sys.executable, str(RELAY)], env=domain_environment(domain), stdout=subprocess.PIPE, text=True
    )
    try:
        assert process.stdout.readline().strip() == "relay ready"
        yield process
    finally:
        process.terminate()
        try:
            process.wait(timeout=30)
        except subprocess.TimeoutExpired:  # a heavily loaded machine: never leave the relay behind
            process.kill()
            process.wait()


@pytest.fixture
def node(domain):
    context = rclpy.Context()
    rclpy.init(context=context, domain_id=domain)
    node = Node("foundation_test", context=context)
    executor = rclpy.executors.SingleThreadedExecutor(context=context)
    executor.add_node(node)
    try:
        yield node, executor
    finally:
        executor.shutdown()
        node.destroy_node()
        rclpy.shutdown(context=context)


def spin_until(executor, predicate, timeout):
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline and not predicate():
        executor.spin_once(timeout_sec=0.05)
    return predicate()


def test_messages_and_service_cross_processes(relay, node):
    node, executor = node
    replies = []
    node.create_subscription(WheelCommand, "/footbot_0/wheels", replies.append, 10)
    publisher = node.create_publisher(RangeAndBearingReadings, "/footbot_0/range_and_bearing", 10)
    client = node.create_client(LoadTree, "/footbot_0/load_tree")
    assert client.wait_for_service(timeout_sec=20), "the relay's load_tree service never appeared"

    # load_tree is idempotent, so a request whose answer was lost to discovery is sent again (within the
    # 10 s the single request had).
    loaded = call_until_answered(
        client,
        LoadTree.Request(tree="sel(  seq(in_nest,\n stop), forward)"),
        lambda future, seconds: spin_until(executor, future.done, seconds),
        10.0,
        resend_after=5.0,
    )
    assert loaded is not None, "no answer to load_tree"
    assert loaded.success
    assert loaded.canonical_tree == "sel( seq(in_nest, stop), forward)"

    readings = RangeAndBearingReadings(step=7)
    readings.readings = [
        RangeAndBearing(sender=3, range=250.0, bearing=0.5, nest_estimate=1000.0, food_estimate=5000.0),
        RangeAndBearing(sender=5, range=900.0, bearing=-2.0, nest_estimate=0.0, food_estimate=4000.0),
    ]
    # Publish until the subscription has matched and the relay has answered.
    answered = spin_until(executor, lambda: publisher.publish(readings) or replies, 20)
    assert answered, "no wheel command came back"
    reply = replies[0]
    assert (reply.robot, reply.step, reply.left, reply.right) == (0, 7, 1.0, -1.0)
    assert reply.nest_estimate == 900.0


def test_other_domains_do_not_see_the_graph(relay, domain):
    """A node in another domain finds no trace of the relay."""
    with reserved_domain() as other:
        assert other != domain
        context = rclpy.Context()
        rclpy.init(context=context, domain_id=other)
        try:
            outsider = Node("outsider", context=context)
            client = outsider.create_client(LoadTree, "/footbot_0/load_tree")
            assert not client.wait_for_service(timeout_sec=3)
            assert "relay" not in outsider.get_node_names()
            outsider.destroy_node()
        finally:
            rclpy.shutdown(context=context)


def test_reserved_domains_are_exclusive_across_processes(domain):
    """A second process reserving a domain never gets the one this test holds."""
    code = "from swarm_ros.isolation import reserved_domain\nwith reserved_domain() as d: print(d)"
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert int(out.stdout) != domain
