"""Run a node until it is asked to stop: the one ``main`` loop of every node executable of the workspace."""

from __future__ import annotations

import rclpy
from rclpy.executors import Executor, ExternalShutdownException, SingleThreadedExecutor
from rclpy.experimental import EventsExecutor
from rclpy.node import Node

EVENTS_WAKE = 1.0
"""Seconds an events executor's ``spin_once`` waits at most before the loop looks at the context again."""


def spin_until_shutdown(node: Node, executor: Executor | None = None, *, events: bool = False) -> None:
    """Spin ``node`` (with ``executor``, single-threaded by default) until Ctrl-C or an external shutdown,
    then destroy it and shut rclpy down. Kilted raises ``ExternalShutdownException`` on Ctrl-C besides
    ``KeyboardInterrupt``; both are a normal stop.

    ``events`` (no ``executor`` then): rclpy's experimental ``EventsExecutor`` (C++, woken by the middleware's
    events; it ignores callback groups, so only for a node whose callbacks run one at a time). It cost the
    lockstep footbot controllers about 40% less CPU per step than the Python single-threaded executor, which
    rebuilds its wait set for every callback. Its ``spin()`` took no callback at all in Kilted (rclpy
    9.1: a service was never answered, a subscription never called), while ``spin_once`` works: so it is
    spun one ``spin_once`` after another, and stops when the context is shut down (Ctrl-C: rclpy's signal
    handler shuts it down, which wakes the executor)."""
    if events and executor is not None:
        raise ValueError("spin_until_shutdown: give an executor or events=True, not both")
    if events:
        executor = EventsExecutor(context=node.context)
    executor = executor or SingleThreadedExecutor()
    executor.add_node(node)
    try:
        if events:
            while node.context.ok():
                executor.spin_once(timeout_sec=EVENTS_WAKE)
        else:
            executor.spin()
    except (KeyboardInterrupt, ExternalShutdownException):
        pass
    finally:
        executor.shutdown()
        node.destroy_node()
        rclpy.try_shutdown()
