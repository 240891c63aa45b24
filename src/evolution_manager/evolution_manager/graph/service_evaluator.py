"""``ServiceEvaluator``: the evaluator contract over every ``EvaluateBatch`` action server of the ROS domain.

It finds the evaluators by type (``swarm_msgs/action/EvaluateBatch``, whatever their node's name, on this
machine or others in the domain), keeps looking during a run, and spreads each batch over them in chunks, each
chunk one goal sent with ``send_goal_async`` (a blocking call would never learn that a server died). The
bookkeeping — chunks, deadlines, re-sending the work of an evaluator that vanished, timed out or answered
wrongly, accepting each result once — is :class:`evolution_manager.graph.dispatch.Dispatcher`; this module
only talks to ROS. :meth:`ServiceEvaluator.close` cancels the goals still running, so an interrupted manager
leaves no evaluator busy.

An evaluator counts as present while ``ActionClient.server_is_ready()``: Fast DDS forgets a killed process
after its lease (about 20 s here) although its name may stay listed, so a chunk's timeout is what usually
notices a dead evaluator first. For evaluators whose processes the
caller started, ``watch`` reports a dead process at once: its evaluator is retired for good (a replacement
comes under a new name), so its work is re-sent once and nothing is sent to the stale name again.
"""

from __future__ import annotations

import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from typing import Any

from rclpy.action import ActionClient, get_action_names_and_types
from rclpy.action.client import ClientGoalHandle
from rclpy.executors import Executor
from rclpy.node import Node
from rclpy.task import Future

from bt_controller.draws import check_seed
from bt_controller.validate import integer
from evolution_manager.errors import NoEvaluatorError
from evolution_manager.graph.dispatch import Chunk, Dispatcher, Timeouts, WorkerState
from swarm_msgs.action import EvaluateBatch
from swarm_sim.evaluation import MAX_TRIALS, EvaluationRequest, EvaluationResult, evaluation_result_of, failed
from swarm_sim.model import OBJECTIVES

SERVICE_TYPE = "swarm_msgs/action/EvaluateBatch"
"""The type by which evaluators are found (their ``~/evaluate`` action; a service of that name wraps it)."""


@dataclass(frozen=True)
class ServiceSettings:
    """How batches are spread: chunk size, timeouts and how often to look for services (seconds)."""

    max_chunk: int = 50
    timeouts: Timeouts = field(default_factory=Timeouts)
    discovery_period: float = 1.0
    wait: float = 120.0  # how long to go on with pending work and no evaluator before giving up
    objective: str = "food"  # the objective each result's `fitness` field reports (all three come back)

    def __post_init__(self) -> None:
        if self.objective not in OBJECTIVES:
            raise ValueError(f"objective must be one of {', '.join(OBJECTIVES)}, got {self.objective!r}")
        if not self.discovery_period > 0 or not self.wait > 0:
            raise ValueError("discovery_period and wait must be positive numbers of seconds")


def _check(request: object) -> str:
    """Why ``request`` cannot be sent (the in-process evaluator's words), or the empty string; the tree itself
    is checked by the evaluator node."""
    if not isinstance(request, EvaluationRequest):
        return f"expected an EvaluationRequest, got {type(request).__name__}"
    if not isinstance(request.tree, str):
        return f"tree must be tree text (str), got {type(request.tree).__name__}"
    try:
        check_seed(request.seed)
        integer(request.trials, "trials", 1, MAX_TRIALS, numpy=True)
    except ValueError as error:
        return str(error)
    return ""


@dataclass
class _Call:
    """One chunk's goal: sent, then accepted (with a result to wait for), then answered."""

    chunk: Chunk
    request: EvaluateBatch.Goal
    accepted: Future
    result: Future | None = None
    handle: ClientGoalHandle | None = None


class ServiceEvaluator:
    """Evaluates batches over every evaluate service in ``node``'s domain (see the module docstring).

    ``node`` must be spun only by this object while :meth:`evaluate` runs (it spins ``executor`` itself).
    ``log(level, text)`` receives what happens to evaluators (level ``"info"`` or ``"warn"``). With ``only``,
    just the services of those names are used.
    """

    def __init__(
        self,
        node: Node,
        executor: Executor,
        settings: ServiceSettings | None = None,
        log: Callable[[str, str], None] | None = None,
        only: Sequence[str] | None = None,
        watch: Callable[[], Sequence[str]] | None = None,
    ) -> None:
        self.only = None if only is None else frozenset(only)
        self.watch = watch  # returns the services whose process is known to have died since the last call
        # the model profile every result must have been evaluated under (None: any); an evaluator of another
        # profile is not used again
        self.profile: str | None = None
        self.retired: set[str] = set()
        self.node = node
        self.executor = executor
        self.settings = settings or ServiceSettings()
        self.dispatcher = Dispatcher(self.settings.max_chunk, self.settings.timeouts)
        self._log = log or (lambda level, text: None)
        self._clients: dict[str, ActionClient] = {}
        self._futures: dict[int, _Call] = {}
        self._requests: list[EvaluationRequest] = []
        self._next_discovery = 0.0
        self.calls = 0

    # Discovery ---------------------------------------------------------------------------------------
    def discover(self) -> list[str]:
        """Look for evaluators now; return the names of those ready."""
        self._retire_dead()
        listed = {
            name
            for name, types in get_action_names_and_types(self.node)
            if SERVICE_TYPE in types and (self.only is None or name in self.only) and name not in self.retired
        }
        for name in sorted(listed - set(self._clients)):
            self._clients[name] = ActionClient(self.node, EvaluateBatch, name)
        ready = []
        for name, client in self._clients.items():
            state = self.dispatcher.state(name)
            if client.server_is_ready():
                ready.append(name)
                if state is None or state is WorkerState.GONE:
                    self._log("info", f"evaluator {name} {'is back' if state else 'found'}")
                self.dispatcher.appeared(name)
            elif state in (WorkerState.IDLE, WorkerState.BUSY, WorkerState.LATE):
                self._drop(name, state, "vanished")
        return ready

    def _drop(self, name: str, state: WorkerState | None, how: str) -> None:
        """Take evaluator ``name`` out of the dispatch; its chunk in flight, if any, is re-queued once."""
        chunk = self.dispatcher.vanished(name)
        lost = ""
        if chunk is not None and state is WorkerState.BUSY:
            lost = f"; re-sending its {len(chunk.indices)} requests"
        self._log("warn", f"evaluator {name} {how}{lost}")
        if chunk is not None:
            self._forget(chunk)

    def _retire_dead(self) -> None:
        """Retire the services ``watch`` reports dead: their chunk in flight is re-queued once."""
        for name in self.watch() if self.watch is not None else ():
            if name in self.retired:
                continue
            self.retired.add(name)
            self._drop(name, self.dispatcher.state(name), "died")
            client = self._clients.pop(name, None)
            if client is not None:
                client.destroy()

    def wait_for(self, count: int, timeout: float) -> list[str]:
        """Spin until ``count`` evaluators are ready or ``timeout`` seconds passed; return those ready."""
        deadline = time.monotonic() + timeout
        ready = self.discover()
        while len(ready) < count and time.monotonic() < deadline:
            self.executor.spin_once(timeout_sec=0.2)
            ready = self.discover()
        return ready

    # Evaluation --------------------------------------------------------------------------------------
    def evaluate(self, requests: Sequence[EvaluationRequest]) -> list[EvaluationResult]:
        """Evaluate every request over the services; results in request order (see ``Evaluator``)."""
        self.calls += 1
        problems = [_check(request) for request in requests]
        sendable = [index for index, problem in enumerate(problems) if not problem]
        self._requests = [requests[i] for i in sendable]
        answered = dict(zip(sendable, self._dispatch(), strict=True)) if self._requests else {}
        return [failed(problem) if problem else answered[i] for i, problem in enumerate(problems)]

    def _dispatch(self) -> list[EvaluationResult]:
        dispatcher = self.dispatcher
        dispatcher.start_batch([r.trials for r in self._requests], [r.trials for r in self._requests])
        starved_since: float | None = None
        while not dispatcher.done:
            now = time.monotonic()
            self._retire_dead()
            if now >= self._next_discovery:
                self.discover()
                self._next_discovery = now + self.settings.discovery_period
            for chunk in dispatcher.expire(now):
                self._log(
                    "warn",
                    f"evaluator {chunk.worker} did not answer within {chunk.deadline - chunk.sent:.0f} s; "
                    f"re-sending its {len(chunk.indices)} requests",
                )
            for chunk in dispatcher.assign(now):
                self._send(chunk)
            if dispatcher.has_capacity():
                starved_since = None
            elif starved_since is None:
                starved_since = now
            elif now - starved_since > self.settings.wait:
                raise NoEvaluatorError(
                    f"no evaluator service ({SERVICE_TYPE}) took work for {self.settings.wait:.0f} s: "
                    "start evaluator nodes in this ROS domain (ws/run swarm_sim evaluator)"
                )
            wait = self.settings.discovery_period
            deadline = dispatcher.next_deadline()
            if deadline is not None:
                wait = min(wait, max(deadline - now, 0.0) + 0.01)
            self.executor.spin_once(timeout_sec=min(wait, 0.5))
            self._collect()
        return dispatcher.results()  # type: ignore[return-value]  # the dispatcher holds what we gave it

    def _send(self, chunk: Chunk) -> None:
        request = EvaluateBatch.Goal()
        request.trees = [self._requests[i].tree for i in chunk.indices]
        request.seeds = [int(self._requests[i].seed) for i in chunk.indices]
        request.trials = int(chunk.key)  # type: ignore[call-overload]  # a chunk key is its trial count (int)
        request.objective = self.settings.objective
        accepted = self._clients[chunk.worker].send_goal_async(request)
        self._futures[chunk.id] = _Call(chunk, request, accepted)

    def _answer(self, call: _Call) -> tuple[bool, Any]:  # the result: an untyped ROS message, or None
        """Whether the goal of ``call`` has come to an end, and its result (None when refused or failed)."""
        if call.result is None:
            if not call.accepted.done():
                return False, None
            handle = call.accepted.result() if call.accepted.exception() is None else None
            if handle is None or not handle.accepted:
                return True, None
            call.handle = handle
            call.result = handle.get_result_async()
        if not call.result.done():
            return False, None
        answer = call.result.result() if call.result.exception() is None else None
        return True, None if answer is None else answer.result

    def _collect(self) -> None:
        for chunk_id, call in list(self._futures.items()):
            ended, response = self._answer(call)
            if not ended:
                continue
            del self._futures[chunk_id]
            chunk, request = call.chunk, call.request
            problem = self._problem(response, request)
            if problem or response is None:
                self._log(
                    "warn", f"evaluator {chunk.worker} answered wrongly ({problem}); not using it again"
                )
                self.dispatcher.refused(chunk)
                continue
            if response.message:
                results = [failed(response.message)] * len(chunk.indices)  # the whole request was refused
            else:
                results = [evaluation_result_of(m) for m in response.results]
            late = self.dispatcher.state(chunk.worker) is WorkerState.LATE
            self.dispatcher.answered(chunk, results, time.monotonic())
            if late:
                self._log("info", f"evaluator {chunk.worker} answered late; it gets work again")

    def _problem(self, response: Any, request: EvaluateBatch.Goal) -> str:  # response: untyped ROS message
        if response is None:
            return "no response"
        if response.message:
            return ""
        results = response.results
        if len(results) != len(request.trees):
            return f"{len(results)} results for {len(request.trees)} trees"
        for msg, seed in zip(results, request.seeds, strict=True):
            if msg.seed != seed or msg.trials != request.trials:
                return f"a result for seed {msg.seed} and {msg.trials} trials where {seed} was sent"
            if self.profile is not None and msg.profile != self.profile:
                return f"evaluated under the model profile {msg.profile!r}, the run's is {self.profile!r}"
        return ""

    def _forget(self, chunk: Chunk) -> None:
        """Drop the goal of a vanished evaluator (its answer can no longer come)."""
        self._futures.pop(chunk.id, None)

    def close(self, cancel_wait: float = 2.0) -> None:
        """Cancel the goals still running (waiting up to ``cancel_wait`` seconds for the evaluators to
        acknowledge), then destroy the clients."""
        cancels = [c.handle.cancel_goal_async() for c in self._futures.values() if c.handle is not None]
        deadline = time.monotonic() + cancel_wait
        while cancels and not all(f.done() for f in cancels) and time.monotonic() < deadline:
            self.executor.spin_once(timeout_sec=0.05)
        for client in self._clients.values():
            client.destroy()
        self._clients.clear()
        self._futures.clear()
