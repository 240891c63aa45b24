"""Managed (lifecycle) nodes: the base of the simulator and the evaluator, and the client that drives one.

A :class:`ManagedNode` declares its parameters when it is made (a bad one stops it at once, ``parameters``),
builds what it serves in ``configure`` (the simulator and the evaluator compile their kernels there), takes
work only while ``active``, and lets go of it in ``cleanup`` and ``shutdown``. With its ``autostart``
parameter (default true) it configures and activates itself when it starts, so a node started by hand, by a
launch file or on another host serves at once; a starter that drives the transitions itself (the trial graph)
starts it with ``-p autostart:=false`` and calls ``<node>/change_state`` through a :class:`LifecycleClient`.

Every managed node publishes ``diagnostic_msgs/DiagnosticArray`` on ``/diagnostics`` once a second, in every
state: its lifecycle state and the figures its class adds (``diagnostic_values``). The period runs on a steady
clock, so the reports go on under ``use_sim_time`` while no ``/clock`` ticks; each is stamped with
``diagnostics_stamp`` (the node's ROS time; the simulator's: its simulated time).
"""

from __future__ import annotations

import time
from collections.abc import Callable
from typing import Any

from builtin_interfaces.msg import Time
from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus, KeyValue
from lifecycle_msgs.msg import Transition
from lifecycle_msgs.srv import ChangeState, GetState
from rclpy.callback_groups import MutuallyExclusiveCallbackGroup
from rclpy.client import Client
from rclpy.clock import Clock, ClockType
from rclpy.lifecycle import LifecycleNode, LifecycleState, TransitionCallbackReturn
from rclpy.node import Node
from rclpy.task import Future
from std_msgs.msg import Header

from swarm_ros.parameters import declare, descriptor
from swarm_ros.services import RESEND_AFTER, call_until_answered

DIAGNOSTICS_TOPIC = "/diagnostics"
"""Where every managed node reports (absolute: the aggregator and ``rqt_robot_monitor`` listen there)."""
DIAGNOSTICS_PERIOD = 1.0
"""Seconds between two diagnostics messages of a node."""

REACHES = {
    "configure": "inactive",
    "activate": "active",
    "deactivate": "inactive",
    "cleanup": "unconfigured",
    "shutdown": "finalized",
}
"""The state each transition (by its label) ends in when it succeeds."""

STARTS = {"configure": "unconfigured", "activate": "inactive", "deactivate": "active", "cleanup": "inactive"}
"""The state each transition but shutdown (from any primary state) starts from: a node still there after an
unanswered request never got it, and is asked again."""

WaitFunction = Callable[[Future, float], bool]
"""``wait(future, seconds)``: wait up to ``seconds`` for ``future``; whether it is done."""


class LifecycleError(RuntimeError):
    """A managed node that did not make a transition; the message says which and why."""


class ManagedNode(LifecycleNode):
    """A lifecycle node with an ``autostart`` parameter and diagnostics on ``/diagnostics`` (see the module).

    Subclasses build their topics, services and actions in ``on_configure`` and let go of them in
    :meth:`release` (called by ``on_cleanup`` and ``on_shutdown``); :attr:`active` says whether to take
    work; :meth:`diagnostic_values` adds figures to the diagnostics."""

    def __init__(self, node_name: str, hardware_id: str, **node_options: Any) -> None:
        """``node_options``: rclpy's (``context``, ``parameter_overrides``, ...)."""
        super().__init__(node_name, **node_options)
        self.hardware_id = hardware_id
        self.autostart: bool = declare(
            self,
            "autostart",
            True,
            descriptor(
                "configure and activate the node when it starts; false: wait for a lifecycle manager to call "
                "change_state",
                read_only=True,
            ),
        )
        self.active = False
        self._diagnostics = self.create_publisher(DiagnosticArray, DIAGNOSTICS_TOPIC, 10)
        # a steady clock: a timer on the node's clock stops with simulated time (use_sim_time, no /clock yet)
        self.create_timer(
            DIAGNOSTICS_PERIOD,
            self.publish_diagnostics,
            callback_group=MutuallyExclusiveCallbackGroup(),
            clock=Clock(clock_type=ClockType.STEADY_TIME),
        )

    @property
    def state(self) -> str:
        """The lifecycle state's label: unconfigured, inactive, active, finalized, or a transition's."""
        return str(self._state_machine.current_state[1])  # rclpy has no public getter of the current state

    def start(self) -> None:
        """Configure and activate the node when ``autostart`` is set (a failure is logged and leaves the
        node in the state it reached)."""
        if self.autostart and self.trigger_configure() == TransitionCallbackReturn.SUCCESS:
            self.trigger_activate()

    def on_activate(self, state: LifecycleState) -> TransitionCallbackReturn:
        self.active = True
        self.get_logger().info("active")
        return super().on_activate(state)

    def on_deactivate(self, state: LifecycleState) -> TransitionCallbackReturn:
        self.active = False
        self.get_logger().info("inactive: refusing work")
        return super().on_deactivate(state)

    def on_cleanup(self, state: LifecycleState) -> TransitionCallbackReturn:
        self.release()
        return TransitionCallbackReturn.SUCCESS

    def on_shutdown(self, state: LifecycleState) -> TransitionCallbackReturn:
        self.active = False
        self.release()
        return TransitionCallbackReturn.SUCCESS

    def release(self) -> None:
        """Destroy what ``on_configure`` made (nothing when it made nothing)."""

    def diagnostic_values(self) -> dict[str, str]:
        """Figures for the diagnostics beside the state, by name (the subclass's)."""
        return {}

    def diagnostics_stamp(self) -> Time:
        """The stamp of a diagnostics message: the node's ROS time (simulated under ``use_sim_time``); the
        simulator stamps its own simulated time."""
        return self.get_clock().now().to_msg()

    def publish_diagnostics(self) -> None:
        """Publish one ``DiagnosticArray`` with this node's status."""
        state = self.state
        status = DiagnosticStatus(
            level=DiagnosticStatus.OK if state == "active" else DiagnosticStatus.WARN,
            name=self.get_fully_qualified_name(),
            message=state if state == "active" else f"{state}: takes no work",
            hardware_id=self.hardware_id,
            values=[
                KeyValue(key=k, value=v) for k, v in {"state": state, **self.diagnostic_values()}.items()
            ],
        )
        self._diagnostics.publish(
            DiagnosticArray(header=Header(stamp=self.diagnostics_stamp()), status=[status])
        )


class LifecycleClient:
    """Drives the managed node ``target`` (its name, relative to the client node's namespace or absolute)
    through ``<target>/change_state`` and reads ``<target>/get_state``."""

    def __init__(self, node: Node, target: str) -> None:
        self.target = target
        self._node = node
        self._change: Client = node.create_client(ChangeState, f"{target}/change_state")
        self._get: Client = node.create_client(GetState, f"{target}/get_state")

    def ready(self) -> bool:
        """Whether both services of the target are there."""
        return self._change.service_is_ready() and self._get.service_is_ready()

    def destroy(self) -> None:
        self._node.destroy_client(self._change)
        self._node.destroy_client(self._get)

    def state(self, wait: WaitFunction, timeout: float, resend_after: float = RESEND_AFTER) -> str:
        """The target's state label; ``LifecycleError`` when no answer comes within ``timeout`` seconds."""
        response = call_until_answered(
            self._get, GetState.Request(), wait, timeout, resend_after=resend_after
        )
        if response is None:
            raise LifecycleError(f"{self.target} did not say its lifecycle state in {timeout:.0f} s")
        return str(response.current_state.label)

    def transition(
        self, label: str, wait: WaitFunction, timeout: float, resend_after: float = RESEND_AFTER
    ) -> None:
        """Make the transition ``label`` (configure, activate, deactivate, cleanup, shutdown) and wait until
        it is done; ``LifecycleError`` when the target refuses it or does not reach its state in ``timeout``
        seconds. A configure can take long (the kernels compile): while no answer comes the state is asked
        (it is answered once the transition is over), since the answer after discovery can be lost; and so
        can the request: a target still in the transition's starting state is asked again."""
        if label not in REACHES:
            raise ValueError(f"no lifecycle transition {label!r}: expected one of {', '.join(REACHES)}")
        deadline = time.monotonic() + timeout
        while True:
            future = self._change.call_async(ChangeState.Request(transition=Transition(label=label)))
            answered = wait(future, min(resend_after, max(0.0, deadline - time.monotonic())))
            response = future.result() if answered else None
            if response is not None and response.success:
                return
            if not answered:
                self._change.remove_pending_request(future)
            state = self.state(wait, max(0.0, deadline - time.monotonic()), resend_after)
            if state == REACHES[label]:
                return
            if answered or state != STARTS.get(label) or time.monotonic() >= deadline:
                why = "refused it" if answered else f"did not answer in {timeout:.0f} s"
                raise LifecycleError(f"{self.target} could not {label}: it {why} and is {state}")

    def drive(self, labels: list[str], wait: WaitFunction, timeout: float) -> None:
        """Make each transition of ``labels`` in turn (each within ``timeout`` seconds)."""
        for label in labels:
            self.transition(label, wait, timeout)
