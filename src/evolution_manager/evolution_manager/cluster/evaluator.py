"""One run's batches on Dask workers: :class:`DaskEvaluator`, an evaluator of the run loop's contract.

A batch is cut into nearly equal chunks, in order, each one Dask task: as many chunks as the cluster has
worker threads, but none smaller than ``chunk`` evaluations (25), so that the cost of a task (about a
millisecond by Dask's own figure, tens under load) is lost in the chunk's hundreds, and a worker gets one task
per batch rather than several in a row. Requests travel as plain text and numbers (tree text, seed, trials),
results as numbers; no DEAP object is ever pickled. The world is a model profile's name, or a whole
``swarm_sim`` ``Config`` (a changed world, as ``adapt-benchmark`` uses, or a task's trial length: a small
frozen record), with the run's primitive library, if any, as its JSON text and label. Each worker process
builds one in-process evaluator per world and library and keeps it (:func:`worker_evaluator`), so numba's
kernels are loaded or compiled once per process, not per task; :class:`CompileKernels`, a worker plugin,
does that when a worker starts, before its first chunk.

A chunk whose worker dies mid-task (killed, its SLURM job cancelled) is run again by the scheduler on
another worker; since a result depends only on its request, the run's files are the same bytes as an
in-process run's.
"""

from __future__ import annotations

import asyncio
import functools
import json
import math
import time
from collections.abc import Sequence
from typing import TYPE_CHECKING

from distributed import WorkerPlugin
from distributed.client import FutureCancelledError
from distributed.scheduler import KilledWorker

from bt_controller.language import Library, library_from_json
from evolution_manager.cluster.settings import CHUNK
from evolution_manager.errors import DispatchError
from swarm_sim.evaluation import BatchEvaluator, EvaluationRequest, EvaluationResult, failed
from swarm_sim.model import Config, default_config

if TYPE_CHECKING:
    from distributed import Client, Worker

Payload = tuple[str, int, int]
"""A request as it travels: tree text, seed, trials."""

Answer = tuple[tuple[float, ...] | None, tuple[float, ...] | None, str | None]
"""A result as it travels: fitness, descriptors, error."""

World = str | Config
"""What the evaluations simulate: a model profile's name (its default configuration), or a configuration."""

PLUGIN = "swarm-bt-qd-kernels"

RECOUNT = 10.0
"""Seconds between two counts of the cluster's worker threads (workers come and go)."""

WARM_UP_TREE = "sel(on_food, forward)"
"""A small tree evaluated once per worker process to load the kernels."""


LibraryText = tuple[str, str]
"""A primitive library as it travels: its label and its JSON document as text (("", ""): none)."""

NO_LIBRARY: LibraryText = ("", "")


def library_text(library: Library | None) -> LibraryText:
    """How ``library`` travels to the workers."""
    return NO_LIBRARY if library is None else (library.label, json.dumps(library.as_json()))


@functools.lru_cache(maxsize=8)
def worker_evaluator(world: World, library: LibraryText = NO_LIBRARY) -> BatchEvaluator:
    """This process's evaluator of ``world`` with ``library`` (one per process, world and library, kept: the
    kernels load once)."""

    label, text = library
    return BatchEvaluator(
        default_config(world) if isinstance(world, str) else world,
        threads=1,
        library=library_from_json(json.loads(text), label) if text else None,
    )


def evaluate_chunk(
    world: World, payloads: Sequence[Payload], library: LibraryText = NO_LIBRARY
) -> list[Answer]:
    """A Dask task: the answers to ``payloads`` from this worker's evaluator of ``world`` and ``library``."""
    requests = [EvaluationRequest(tree=tree, seed=seed, trials=trials) for tree, seed, trials in payloads]
    return [(r.fitness, r.descriptors, r.error) for r in worker_evaluator(world, library).evaluate(requests)]


def chunks(count: int, least: int, threads: int) -> list[range]:
    """``range(count)`` cut, in order, into nearly equal pieces: one per thread (``threads`` <= 0: unknown, as
    many as can be), but none smaller than ``least`` items (unless the whole is)."""
    if count == 0:
        return []
    most = max(1, count // least)
    pieces = most if threads <= 0 else min(threads, most)
    size, extra = divmod(count, pieces)
    out, start = [], 0
    for k in range(pieces):
        end = start + size + (1 if k < extra else 0)
        out.append(range(start, end))
        start = end
    return out


class CompileKernels(WorkerPlugin):
    """A worker plugin: on every worker (those running now and those that join later), build the evaluator
    of ``world`` and evaluate one small tree, off the worker's event loop, before the first chunk. (The
    kernels are the same for every world: once loaded in a process, they serve them all.)"""

    name = PLUGIN

    def __init__(self, world: World, library: LibraryText = NO_LIBRARY) -> None:
        self.world = world
        self.library = library

    async def setup(self, worker: Worker) -> None:
        await asyncio.to_thread(_warm_up, self.world, self.library)


def _warm_up(world: World, library: LibraryText) -> None:
    worker_evaluator(world, library).evaluate([EvaluationRequest(tree=WARM_UP_TREE, seed=0, trials=1)])


class DaskEvaluator:
    """The evaluator contract (``swarm_sim.evaluation.batch.Evaluator``) over the workers of ``client``, in
    ``world`` (a model profile's name, or a Config) with ``library`` (a primitive library whose names the
    trees may use, or None): every batch cut into one chunk per worker thread, of
    at least ``chunk`` evaluations; the threads are counted by the scheduler at most every ``recount`` s.

    A request that is not an ``EvaluationRequest`` is answered with an error result here, as the in-process
    evaluator does; everything else is answered by the workers. A chunk that fails on every worker it is
    given to (the scheduler's allowed failures spent) raises :class:`DispatchError`."""

    def __init__(
        self,
        client: Client,
        world: World,
        chunk: int = CHUNK,
        recount: float = RECOUNT,
        library: Library | None = None,
    ) -> None:
        if isinstance(chunk, bool) or not isinstance(chunk, int) or chunk < 1:
            raise ValueError(f"chunk must be a positive integer, got {chunk!r}")
        self.client = client
        self.world = world
        self.library = library_text(library)
        self.chunk = chunk
        self.recount = recount
        self.tasks = 0
        """Chunks sent so far."""
        self._threads = 0
        self._counted = -math.inf
        client.register_plugin(CompileKernels(world, self.library))

    def threads(self) -> int:
        """Worker threads of the cluster (0 while it has none), asked at most every ``recount`` seconds."""
        if time.monotonic() - self._counted >= self.recount:
            self._threads = sum(self.client.nthreads().values())
            self._counted = time.monotonic()
        return self._threads

    def evaluate(self, requests: Sequence[EvaluationRequest]) -> list[EvaluationResult]:
        """Evaluate every request (see ``Evaluator``): one result per request, in order."""
        results: list[EvaluationResult | None] = [None] * len(requests)
        sent: list[int] = []
        payloads: list[Payload] = []
        for i, request in enumerate(requests):
            if not isinstance(request, EvaluationRequest):
                results[i] = failed(f"expected an EvaluationRequest, got {type(request).__name__}")
                continue
            sent.append(i)
            payloads.append((str(request.tree), int(request.seed), int(request.trials)))
        pieces = chunks(len(payloads), self.chunk, self.threads() if payloads else 0)
        futures = self.client.map(
            evaluate_chunk,
            [self.world] * len(pieces),
            [[payloads[k] for k in p] for p in pieces],
            [self.library] * len(pieces),
            pure=False,
        )
        self.tasks += len(futures)
        try:
            answers = self.client.gather(futures)  # waits: one round trip per chunk
        except FutureCancelledError as error:  # Dask's reason may span lines: one line here
            if self.client.status != "running":  # the scheduler died, or cannot be reached any more
                address = getattr(self.client.scheduler, "address", "?")
                raise DispatchError(
                    f"the Dask scheduler at {address} was lost mid-run (the client could not reconnect to it)"
                ) from None
            reason = " ".join(str(error).split())
            raise DispatchError(f"a chunk of evaluations was cancelled: {reason}") from None
        except KilledWorker as error:  # the chunk's workers died more often than the scheduler allows
            reason = " ".join(str(error).split())
            raise DispatchError(f"a chunk of evaluations killed each worker it went to: {reason}") from None
        for piece, answer in zip(pieces, answers, strict=True):
            if len(answer) != len(piece):
                raise DispatchError(f"a worker answered {len(answer)} of {len(piece)} requests")
            for k, (fitness, descriptors, reason) in zip(piece, answer, strict=True):
                results[sent[k]] = EvaluationResult(
                    None if fitness is None else tuple(fitness),
                    None if descriptors is None else tuple(descriptors),
                    reason,
                )
        return results  # type: ignore[return-value]  # every position filled above
