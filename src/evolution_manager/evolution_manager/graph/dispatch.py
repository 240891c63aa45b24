"""Spreading batches of evaluation requests over several evaluators: the bookkeeping, with no ROS in it.

A :class:`Dispatcher` knows the evaluators ("workers", by name) and the batch being evaluated. The caller
(the ROS 2 ``ServiceEvaluator``, or a test) tells it what happens — a worker appeared or vanished, a chunk was
answered, time passed — and asks it what to send next. Clocks are passed in, never read.

- A batch is cut into chunks when work is handed out: an idle worker gets up to ``ceil(pending / idle
  workers)`` requests (at most ``max_chunk``), all with the same key (requests of one chunk travel in one
  service call, which has a single ``trials``).
- Each worker has at most one chunk in flight. A chunk not answered by its deadline is re-queued; its worker
  is *late* and gets no more work until it answers or vanishes. A worker that vanishes has its chunk
  re-queued at once. A worker whose answer is malformed is *refused* for good and its chunk re-queued.
- Every request's result is accepted exactly once: the first answer that carries it wins, and later answers
  for it (a late worker's, a re-sent chunk's, a chunk of an earlier batch) are ignored. Results depend only
  on their request, so which copy wins does not matter.
- A request sent ``max_attempts`` times without an answer raises :class:`DispatchError` rather than looping.

Deadlines: a chunk's deadline is ``timeout`` seconds after it was sent, or ``factor`` times its expected
duration when that is longer (expected from the seconds per trial seen so far); a worker's first chunk also
gets ``first_timeout`` (an evaluator compiles its kernels on first use). The default ``timeout`` is a few
seconds, so a worker killed mid-chunk stalls its work no longer than that, while a slow chunk still gets ten
times its measured duration.
"""

from __future__ import annotations

import math
from collections.abc import Hashable, Sequence
from dataclasses import dataclass, field
from enum import Enum

from bt_controller.validate import integer
from evolution_manager.errors import DispatchError


class WorkerState(Enum):
    """Where a worker stands."""

    IDLE = "idle"  # answering, nothing in flight
    BUSY = "busy"  # one chunk in flight, within its deadline
    LATE = "late"  # its chunk passed the deadline and was re-queued; no work until it answers
    GONE = "gone"  # vanished; may come back
    REFUSED = "refused"  # answered with a malformed answer; never used again


@dataclass(frozen=True)
class Timeouts:
    """How long a chunk may take before its work is sent elsewhere (seconds)."""

    timeout: float = 3.0
    first_timeout: float = 300.0
    factor: float = 10.0

    def __post_init__(self) -> None:
        for name in ("timeout", "first_timeout", "factor"):
            value = getattr(self, name)
            if not (isinstance(value, int | float) and value > 0 and math.isfinite(value)):
                raise ValueError(f"{name} must be a positive number, got {value!r}")


@dataclass(frozen=True)
class Chunk:
    """Requests ``indices`` of batch ``batch``, sent together to ``worker``."""

    id: int
    batch: int
    worker: str
    indices: tuple[int, ...]
    key: Hashable
    sent: float
    deadline: float


@dataclass
class _Worker:
    name: str
    state: WorkerState = WorkerState.IDLE
    chunk: Chunk | None = None  # in flight (BUSY or LATE)
    answered: int = 0  # chunks answered so far


@dataclass
class _Batch:
    number: int
    keys: list[Hashable]
    weights: list[float]
    results: list[object | None]
    pending: list[int]  # not accepted and not in flight, in request order
    attempts: list[int]
    accepted: int = 0
    in_flight: dict[int, Chunk] = field(default_factory=dict)


class Dispatcher:
    """The workers and the current batch; see the module docstring."""

    def __init__(self, max_chunk: int = 50, timeouts: Timeouts | None = None, max_attempts: int = 5) -> None:
        integer(max_chunk, "max_chunk", 1)
        integer(max_attempts, "max_attempts", 1)
        self.max_chunk = max_chunk
        self.timeouts = timeouts or Timeouts()
        self.max_attempts = max_attempts
        self._workers: dict[str, _Worker] = {}
        self._batch: _Batch | None = None
        self._next_chunk = 0
        self._batches = 0
        self._seconds_per_weight: float | None = None
        self.resent = 0  # requests re-queued so far (after a timeout, a vanished or a refused worker)
        self.duplicates = 0  # results received for requests already accepted (ignored)

    # Workers -----------------------------------------------------------------------------------------
    def appeared(self, name: str) -> None:
        """Worker ``name`` is ready to take work (new, or back after vanishing)."""
        worker = self._workers.get(name)
        if worker is None:
            self._workers[name] = _Worker(name)
        elif worker.state is WorkerState.GONE:
            worker.state = WorkerState.IDLE

    def vanished(self, name: str) -> Chunk | None:
        """Worker ``name`` left; its chunk in flight (returned) goes back to the queue."""
        worker = self._workers.get(name)
        if worker is None or worker.state in (WorkerState.GONE, WorkerState.REFUSED):
            return None
        chunk = worker.chunk
        if worker.state is WorkerState.BUSY and chunk is not None:
            self._requeue(chunk)
        worker.state, worker.chunk = WorkerState.GONE, None
        return chunk

    def state(self, name: str) -> WorkerState | None:
        """The state of worker ``name`` (None if never seen)."""
        worker = self._workers.get(name)
        return None if worker is None else worker.state

    def workers(self, *states: WorkerState) -> list[str]:
        """The names of the workers in any of ``states`` (every worker when none is given)."""
        return [w.name for w in self._workers.values() if not states or w.state in states]

    def answered_chunks(self, name: str) -> int:
        """How many chunks worker ``name`` has answered (0 if never seen)."""
        worker = self._workers.get(name)
        return 0 if worker is None else worker.answered

    def has_capacity(self) -> bool:
        """Whether some worker is idle or busy, so the work can go on without a new one."""
        return any(w.state in (WorkerState.IDLE, WorkerState.BUSY) for w in self._workers.values())

    # Batches -----------------------------------------------------------------------------------------
    def start_batch(self, keys: Sequence[Hashable], weights: Sequence[float] | None = None) -> None:
        """Begin a batch of ``len(keys)`` requests; ``keys[i]`` groups requests that may share a chunk and
        ``weights[i]`` is its expected cost (e.g. trials; default 1). The previous batch must be done."""
        if self._batch is not None and not self.done:
            raise DispatchError("start_batch() before the previous batch was done")
        n = len(keys)
        weights = [1.0] * n if weights is None else [float(w) for w in weights]
        if len(weights) != n:
            raise ValueError(f"got {n} keys but {len(weights)} weights")
        self._batches += 1
        self._batch = _Batch(self._batches, list(keys), weights, [None] * n, list(range(n)), [0] * n)

    @property
    def done(self) -> bool:
        """Whether every request of the current batch has its result."""
        batch = self._batch
        return batch is None or batch.accepted == len(batch.results)

    def results(self) -> list[object]:
        """The results of the finished batch, in request order."""
        if self._batch is None or not self.done:
            raise DispatchError("results() before the batch was done")
        return list(self._batch.results)

    def assign(self, now: float) -> list[Chunk]:
        """Hand a chunk of pending work to every idle worker that can get one; return the chunks to send."""
        batch = self._batch
        if batch is None:
            return []
        chunks = []
        idle = [w for w in self._workers.values() if w.state is WorkerState.IDLE]
        for position, worker in enumerate(idle):
            if not batch.pending:
                break
            key = batch.keys[batch.pending[0]]
            same = [i for i in batch.pending if batch.keys[i] == key]
            size = min(self.max_chunk, math.ceil(len(same) / (len(idle) - position)))
            indices = tuple(same[:size])
            taken = set(indices)
            batch.pending = [i for i in batch.pending if i not in taken]
            for i in indices:
                if batch.attempts[i] >= self.max_attempts:
                    raise DispatchError(
                        f"request {i} of the batch was sent {batch.attempts[i]} times and never answered "
                        "in time: every evaluator it went to timed out, vanished or answered wrongly"
                    )
                batch.attempts[i] += 1
            chunk = Chunk(
                self._next_chunk,
                batch.number,
                worker.name,
                indices,
                key,
                now,
                now + self._timeout(worker, batch, indices),
            )
            self._next_chunk += 1
            batch.in_flight[chunk.id] = chunk
            worker.state, worker.chunk = WorkerState.BUSY, chunk
            chunks.append(chunk)
        return chunks

    def _timeout(self, worker: _Worker, batch: _Batch, indices: Sequence[int]) -> float:
        t = self.timeouts
        seconds = t.timeout
        if self._seconds_per_weight is not None:
            expected = self._seconds_per_weight * sum(batch.weights[i] for i in indices)
            seconds = max(seconds, t.factor * expected)
        if worker.answered == 0:
            seconds = max(seconds, t.first_timeout)
        return seconds

    def answered(self, chunk: Chunk, results: Sequence[object], now: float) -> int:
        """``chunk``'s worker answered with ``results`` (one per index, in order); return how many were
        accepted (the others were already known). The worker becomes idle."""
        if len(results) != len(chunk.indices):
            raise ValueError(
                f"chunk {chunk.id} has {len(chunk.indices)} requests but got {len(results)} results: "
                "call refused() for a malformed answer"
            )
        worker = self._workers.get(chunk.worker)
        if worker is not None and worker.chunk is not None and worker.chunk.id == chunk.id:
            worker.chunk = None
            worker.answered += 1
            if worker.state in (WorkerState.BUSY, WorkerState.LATE):
                worker.state = WorkerState.IDLE
        batch = self._batch
        if batch is None or batch.number != chunk.batch:
            self.duplicates += len(results)
            return 0
        batch.in_flight.pop(chunk.id, None)
        self._learn(batch, chunk, now)
        accepted = 0
        for index, result in zip(chunk.indices, results, strict=True):
            if batch.results[index] is not None:
                self.duplicates += 1
                continue
            batch.results[index] = result
            batch.accepted += 1
            accepted += 1
        if accepted:
            taken = set(chunk.indices)
            batch.pending = [i for i in batch.pending if i not in taken]
        return accepted

    def _learn(self, batch: _Batch, chunk: Chunk, now: float) -> None:
        weight = sum(batch.weights[i] for i in chunk.indices)
        if weight <= 0 or now <= chunk.sent:
            return
        rate = (now - chunk.sent) / weight
        previous = self._seconds_per_weight
        self._seconds_per_weight = rate if previous is None else 0.8 * previous + 0.2 * rate

    def refused(self, chunk: Chunk) -> None:
        """``chunk``'s worker answered with something unusable: it is never used again, its work re-queued."""
        worker = self._workers.get(chunk.worker)
        if worker is not None and worker.chunk is not None and worker.chunk.id == chunk.id:
            if worker.state is WorkerState.BUSY:
                self._requeue(chunk)
            worker.chunk = None
        if worker is not None:
            worker.state = WorkerState.REFUSED

    def expire(self, now: float) -> list[Chunk]:
        """Re-queue every chunk past its deadline (its worker becomes late); return those chunks."""
        expired = []
        for worker in self._workers.values():
            chunk = worker.chunk
            if worker.state is WorkerState.BUSY and chunk is not None and now >= chunk.deadline:
                worker.state = WorkerState.LATE
                self._requeue(chunk)
                expired.append(chunk)
        return expired

    def next_deadline(self) -> float | None:
        """The earliest deadline of a chunk in flight, or None."""
        deadlines = [
            w.chunk.deadline for w in self._workers.values() if w.state is WorkerState.BUSY and w.chunk
        ]
        return min(deadlines, default=None)

    def _requeue(self, chunk: Chunk) -> None:
        batch = self._batch
        if batch is None or batch.number != chunk.batch:
            return
        batch.in_flight.pop(chunk.id, None)
        back = [i for i in chunk.indices if batch.results[i] is None]
        self.resent += len(back)
        batch.pending = sorted(set(batch.pending) | set(back))
