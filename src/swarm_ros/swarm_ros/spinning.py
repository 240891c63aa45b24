"""Run a node until it is asked to stop: the one ``main`` loop of every node executable of the workspace."""

from __future__ import annotations

from collections.abc import Callable, Sequence

import rclpy
from rclpy.executors import Executor, ExternalShutdownException, SingleThreadedExecutor
from rclpy.experimental import EventsExecutor
from rclpy.impl.implementation_singleton import rclpy_implementation
from rclpy.node import Node

EVENTS_WAKE = 1.0
"""Seconds an events executor's ``spin_once`` waits at most before the loop looks at the context again."""


def spin_until_shutdown(
    nodes: Node | Sequence[Node],
    executor: Executor | None = None,
    *,
    events: bool = False,
    on_ready: Callable[[], None] | None = None,
) -> None:
    """Spin ``nodes`` (one node, or several sharing the process and the executor: ``start_nodes``; with
    ``executor``, single-threaded by default) until Ctrl-C or an external shutdown, then destroy them and
    shut rclpy down; ``on_ready`` (a node saying it is ready) is called once the executor holds them. Ctrl-C
    at any moment of that is a normal stop, not a traceback (Kilted raises ``ExternalShutdownException``
    besides ``KeyboardInterrupt``).

    ``events`` (no ``executor`` then): rclpy's experimental ``EventsExecutor`` (C++, woken by the middleware's
    events; it ignores callback groups, so only for a node whose callbacks run one at a time). It cost the
    lockstep footbot controllers about 40% less CPU per step than the Python single-threaded executor, which
    rebuilds its wait set for every callback (several nodes' callbacks, too, run one at a time). Its
    ``spin()`` took no callback at all in Kilted (rclpy 9.1: a service was never answered, a subscription
    never called), while ``spin_once`` works: so it is spun one ``spin_once`` after another, and stops when
    the context is shut down (Ctrl-C: rclpy's signal handler shuts it down, which wakes the executor)."""
    if events and executor is not None:
        raise ValueError("spin_until_shutdown: give an executor or events=True, not both")
    group = [nodes] if isinstance(nodes, Node) else list(nodes)
    context = group[0].context
    try:
        if events:
            executor = EventsExecutor(context=context)
        executor = executor or SingleThreadedExecutor()
        for node in group:
            executor.add_node(node)
        if on_ready is not None:
            on_ready()
        if events:
            while context.ok():
                executor.spin_once(timeout_sec=EVENTS_WAKE)
        else:
            executor.spin()
    except (KeyboardInterrupt, ExternalShutdownException):
        pass
    except rclpy_implementation.RCLError:
        if context.ok():  # not a Ctrl-C that shut the context down between the loop's look and spin_once
            raise
    finally:
        if executor is not None:
            executor.shutdown()
        for node in group:
            node.destroy_node()
        rclpy.try_shutdown()
