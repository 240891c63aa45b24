"""spin_until_shutdown with the events executor: a node spun so answers its services (Kilted's
EventsExecutor.spin() would not), stops when its context is shut down, and refuses an executor besides."""

import threading

import pytest
import rclpy
from rcl_interfaces.srv import ListParameters
from rclpy.executors import SingleThreadedExecutor
from rclpy.node import Node

from swarm_ros.isolation import reserved_domain
from swarm_ros.services import call_until_answered
from swarm_ros.spinning import spin_until_shutdown


def test_an_events_spun_node_answers_and_stops_at_shutdown():
    with reserved_domain() as domain:
        server_context, client_context = rclpy.Context(), rclpy.Context()
        rclpy.init(context=server_context, domain_id=domain)
        rclpy.init(context=client_context, domain_id=domain)
        try:
            server = Node("server", context=server_context)

            def answer(request, response):
                response.result.names = [f"depth {request.depth}"]
                return response

            server.create_service(ListParameters, "list", answer)
            spinner = threading.Thread(
                target=spin_until_shutdown, args=(server,), kwargs={"events": True}, daemon=True
            )
            spinner.start()
            client_node = Node("client", context=client_context)
            client = client_node.create_client(ListParameters, "list")
            assert client.wait_for_service(timeout_sec=30.0)
            executor = SingleThreadedExecutor(context=client_context)
            executor.add_node(client_node)

            def wait(future, seconds):
                executor.spin_until_future_complete(future, timeout_sec=seconds)
                return future.done()

            for depth in (3, 7):
                # Resent after a silence: "service ready" can come before the client has matched the
                # server's responses, and a first response lost so failed one CI run on a loaded machine.
                response = call_until_answered(client, ListParameters.Request(depth=depth), wait, 30.0)
                assert response is not None, f"the events-spun server did not answer request {depth}"
                assert list(response.result.names) == [f"depth {depth}"]
            server_context.shutdown()
            spinner.join(timeout=10.0)
            assert not spinner.is_alive(), "spin_until_shutdown did not stop when its context was shut down"
        finally:
            rclpy.try_shutdown(context=server_context)
            rclpy.try_shutdown(context=client_context)


def test_events_and_an_executor_are_refused_together():
    with reserved_domain() as domain:
        context = rclpy.Context()
        rclpy.init(context=context, domain_id=domain)
        try:
            node = Node("lonely", context=context)
            with pytest.raises(ValueError, match="not both"):
                spin_until_shutdown(node, SingleThreadedExecutor(context=context), events=True)
            node.destroy_node()
        finally:
            rclpy.try_shutdown(context=context)
