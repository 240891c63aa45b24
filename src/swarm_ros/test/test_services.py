"""call_until_answered: a request whose response is lost is sent again and answered; without any answer the
call gives up after its timeout; a request already sent is the first one waited for."""

import threading
import time

import pytest
import rclpy
from rcl_interfaces.srv import ListParameters
from rclpy.executors import SingleThreadedExecutor
from rclpy.node import Node

from swarm_ros.isolation import reserved_domain
from swarm_ros.services import call_until_answered


@pytest.fixture
def graph():
    """A server node counting the requests it answers, and a client node, spun by a background thread."""
    with reserved_domain() as domain:
        context = rclpy.Context()
        rclpy.init(context=context, domain_id=domain)
        server, client_node = Node("server", context=context), Node("client", context=context)
        answered = []

        def answer(request, response):
            answered.append(request.depth)
            response.result.names = [f"answer {len(answered)}"]
            return response

        server.create_service(ListParameters, "list", answer)
        client = client_node.create_client(ListParameters, "list")
        executor = SingleThreadedExecutor(context=context)
        executor.add_node(server)
        executor.add_node(client_node)
        spinner = threading.Thread(target=executor.spin, daemon=True)
        spinner.start()
        try:
            assert client.wait_for_service(timeout_sec=30.0)
            yield client, answered
        finally:
            executor.shutdown()
            rclpy.shutdown(context=context)
            spinner.join(timeout=10.0)


def waiting(lost: int):
    """A wait that treats the first ``lost`` responses as lost (gives up on them at once)."""
    calls = []

    def wait(future, seconds):
        calls.append(seconds)
        if len(calls) <= lost:
            return False
        deadline = time.monotonic() + seconds
        while not future.done() and time.monotonic() < deadline:
            time.sleep(0.01)
        return future.done()

    return wait, calls


def test_a_lost_response_is_sent_again_and_the_answer_returned(graph):
    client, answered = graph
    wait, calls = waiting(lost=2)
    response = call_until_answered(client, ListParameters.Request(depth=7), wait, 30.0, resend_after=5.0)
    assert len(calls) == 3
    assert response is not None and response.result.names[-1] == f"answer {len(answered)}"
    assert answered[-1] == 7 and 1 <= len(answered) <= 3  # the lost ones may still have reached the server


def test_without_an_answer_the_call_gives_up_after_its_timeout(graph):
    client, _ = graph
    calls = []

    def never(future, seconds):
        calls.append(seconds)
        time.sleep(seconds)
        return False

    started = time.monotonic()
    assert call_until_answered(client, ListParameters.Request(), never, 1.0, resend_after=0.3) is None
    assert 1.0 <= time.monotonic() - started < 5.0
    assert len(calls) >= 4 and all(s <= 0.3 for s in calls)


def test_a_request_already_sent_is_waited_for_first(graph):
    client, answered = graph
    sent = client.call_async(ListParameters.Request(depth=3))
    wait, calls = waiting(lost=0)
    response = call_until_answered(client, ListParameters.Request(depth=4), wait, 30.0, sent=sent)
    assert response is not None and answered == [3] and len(calls) == 1
