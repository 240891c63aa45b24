"""Managed nodes: a ``ManagedNode`` driven through every transition by a ``LifecycleClient`` over the real
``change_state`` and ``get_state`` services, reporting its state on ``/diagnostics``; a transition the node
refuses is one clear error; ``autostart`` configures and activates it by itself."""

import threading
import time

import pytest
import rclpy
from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus
from rclpy.executors import MultiThreadedExecutor
from rclpy.lifecycle import TransitionCallbackReturn
from rclpy.node import Node
from rclpy.parameter import Parameter
from std_msgs.msg import String

from swarm_ros.isolation import reserved_domain
from swarm_ros.lifecycle import LifecycleClient, LifecycleError, ManagedNode


class Toy(ManagedNode):
    """A managed node that makes one publisher in configure and counts its releases."""

    def __init__(self, **options):
        super().__init__("toy", "test hardware", **options)
        self.released = 0
        self.publisher = None

    def on_configure(self, state):
        self.publisher = self.create_publisher(String, "said", 10)
        return TransitionCallbackReturn.SUCCESS

    def release(self):
        if self.publisher is not None:
            self.destroy_publisher(self.publisher)
            self.publisher = None
        self.released += 1

    def diagnostic_values(self):
        return {"publisher": "yes" if self.publisher is not None else "no"}


def wait(future, seconds):
    done = threading.Event()
    future.add_done_callback(lambda _f: done.set())
    return done.wait(seconds)


def eventually(check, seconds=60.0):
    deadline = time.monotonic() + seconds
    while not check():
        assert time.monotonic() < deadline, "timed out"
        time.sleep(0.05)


@pytest.fixture
def graph():
    """A toy managed node started with ``autostart:=false`` and a client node, spun in a thread; the statuses
    the client receives on /diagnostics."""
    with reserved_domain() as domain:
        context = rclpy.Context()
        rclpy.init(context=context, domain_id=domain)
        executor = MultiThreadedExecutor(num_threads=2, context=context)
        toy = Toy(context=context, parameter_overrides=[Parameter("autostart", value=False)])
        client = Node("lifecycle_test_client", context=context)
        statuses = []
        client.create_subscription(DiagnosticArray, "/diagnostics", lambda m: statuses.extend(m.status), 10)
        executor.add_node(toy)
        executor.add_node(client)
        thread = threading.Thread(target=executor.spin, daemon=True)
        thread.start()
        try:
            yield toy, client, statuses
        finally:
            executor.shutdown()
            thread.join(timeout=10)
            rclpy.shutdown(context=context)


def test_a_client_drives_a_managed_node_through_every_transition(graph):
    toy, client, statuses = graph
    toy.start()  # autostart is false: nothing happens
    assert toy.state == "unconfigured" and not toy.autostart
    life = LifecycleClient(client, "/toy")
    eventually(life.ready)
    assert life.state(wait, 30) == "unconfigured"
    with pytest.raises(LifecycleError, match="/toy could not activate: it refused it and is unconfigured"):
        life.transition("activate", wait, 30)
    with pytest.raises(ValueError, match="no lifecycle transition 'start'"):
        life.transition("start", wait, 30)

    life.transition("configure", wait, 30)
    assert toy.publisher is not None and not toy.active and life.state(wait, 30) == "inactive"
    life.transition("activate", wait, 30)
    assert toy.active and life.state(wait, 30) == "active"
    eventually(lambda: statuses and statuses[-1].values[0].value == "active")
    last = statuses[-1]
    assert (last.name, last.level, last.hardware_id) == ("/toy", DiagnosticStatus.OK, "test hardware")
    assert {kv.key: kv.value for kv in last.values} == {"state": "active", "publisher": "yes"}

    life.drive(["deactivate", "cleanup"], wait, 30)
    assert not toy.active and toy.publisher is None and toy.released == 1
    eventually(lambda: statuses[-1].values[0].value == "unconfigured")
    assert (
        statuses[-1].level == DiagnosticStatus.WARN and statuses[-1].message == "unconfigured: takes no work"
    )
    life.transition("shutdown", wait, 30)
    assert life.state(wait, 30) == "finalized" and toy.released == 2


def test_a_configure_sent_before_the_node_was_there_is_sent_again():
    """A request can be lost as well as its answer (a CI run: "simulator could not configure: it did not
    answer and is unconfigured"); here the first request goes out before the node exists, so nobody gets it.
    The client finds the node still unconfigured and asks again."""
    with reserved_domain() as domain:
        context = rclpy.Context()
        rclpy.init(context=context, domain_id=domain)
        executor = MultiThreadedExecutor(num_threads=2, context=context)
        client = Node("lifecycle_test_client", context=context)
        executor.add_node(client)
        thread = threading.Thread(target=executor.spin, daemon=True)
        thread.start()
        try:
            life = LifecycleClient(client, "/toy")
            done = []
            asking = threading.Thread(
                target=lambda: done.append(life.transition("configure", wait, 60, resend_after=1.0))
            )
            asking.start()
            time.sleep(0.5)  # the first configure is out, to no one
            toy = Toy(context=context, parameter_overrides=[Parameter("autostart", value=False)])
            executor.add_node(toy)
            toy.start()
            asking.join(timeout=60)
            assert done == [None] and toy.publisher is not None and life.state(wait, 30) == "inactive"
        finally:
            executor.shutdown()
            thread.join(timeout=10)
            rclpy.shutdown(context=context)


def test_autostart_configures_and_activates_the_node():
    with reserved_domain() as domain:
        context = rclpy.Context()
        rclpy.init(context=context, domain_id=domain)
        try:
            toy = Toy(context=context)
            assert toy.autostart and toy.state == "unconfigured"
            toy.start()
            assert toy.state == "active" and toy.active and toy.publisher is not None
            toy.destroy_node()
        finally:
            rclpy.shutdown(context=context)
