"""Run a node until it is asked to stop: the one ``main`` loop of every node executable of the workspace."""

from __future__ import annotations

import rclpy
from rclpy.executors import Executor, ExternalShutdownException, SingleThreadedExecutor
from rclpy.node import Node


def spin_until_shutdown(node: Node, executor: Executor | None = None) -> None:
    """Spin ``node`` (with ``executor``, single-threaded by default) until Ctrl-C or an external shutdown,
    then destroy it and shut rclpy down. Kilted raises ``ExternalShutdownException`` on Ctrl-C besides
    ``KeyboardInterrupt``; both are a normal stop."""
    executor = executor or SingleThreadedExecutor()
    executor.add_node(node)
    try:
        executor.spin()
    except (KeyboardInterrupt, ExternalShutdownException):
        pass
    finally:
        executor.shutdown()
        node.destroy_node()
        rclpy.try_shutdown()
