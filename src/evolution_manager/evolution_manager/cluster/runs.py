"""Whole runs of an experiment as Dask tasks: :func:`map_runs`.

Each task runs (or continues from its checkpoint, or leaves alone when finished) one planned run in its run
directory, exactly as ``experiment`` does in a local process: with the function the caller hands over
(``studies.experiment.run_one``, which this wing, below ``studies``, does not import); the directories must
lie on a filesystem that the client and every worker share, as a cluster's home or scratch does. A task whose
worker dies (killed, its SLURM job cancelled or out of walltime) is run again on another worker, which
continues the run from its last checkpoint: a run's files do not depend on how often it was interrupted.

Progress travels as Dask events: each run reports the individuals produced after every batch, and the
client's handler collects them for the caller's progress bar.
"""

from __future__ import annotations

import itertools
import os
import queue
import socket
from collections.abc import Callable, Iterator, Sequence
from typing import TYPE_CHECKING

from distributed import get_worker, wait
from distributed.scheduler import KilledWorker

if TYPE_CHECKING:
    from distributed import Client, Future

PROGRESS_TOPIC = "swarm-bt-qd-progress"

ATTEMPTS = 3
"""Times a run is submitted when its workers keep dying (each submission survives the scheduler's allowed
failures: 3 worker deaths by Dask's default, 10 under ``--cluster slurm``)."""

_calls = itertools.count()


class WorkerProgress:
    """What a run on a worker is given as ``progress``: ``put((root, produced))`` becomes a Dask event of
    ``topic``, which the client that submitted the run subscribed to."""

    def __init__(self, topic: str) -> None:
        self.topic = topic

    def put(self, item: tuple[str, int]) -> None:
        root, produced = item
        get_worker().log_event(self.topic, [str(root), int(produced)])


RunOne = Callable[..., str]
"""``run_one(config_data, root, progress, checkpoint_interval)``: run, continue or leave alone one planned run
in ``root`` (a top-level function, sent to the workers by name); it calls ``progress.put((root, produced))``
after every batch, with a :class:`WorkerProgress` here."""


def run_task(run_one: RunOne, config_data: dict, root: str, topic: str, checkpoint_interval: float) -> str:
    """A Dask task: ``run_one`` of the planned run ``config_data`` in ``root``, with progress as events."""
    return run_one(config_data, root, WorkerProgress(topic), checkpoint_interval)


def map_runs(
    client: Client,
    run_one: RunOne,
    runs: Sequence[tuple[dict, str]],
    checkpoint_interval: float = 30.0,
    on_progress: Callable[[str, int], None] | None = None,
    attempts: int = ATTEMPTS,
    poll: float = 0.5,
) -> Iterator[tuple[str, BaseException | None]]:
    """Run every ``(config_data, root)`` of ``runs`` with ``run_one`` on the workers of ``client``; yield
    ``(root, None)`` for each run as it finishes, ``(root, error)`` for one that failed (the others go on).
    The roots must be absolute paths on the filesystem the workers share.

    ``on_progress(root, produced)`` is called in the caller's thread, between results, with the individuals
    produced by a run so far. A run whose workers kept dying (``KilledWorker``) is submitted again, up to
    ``attempts`` times. Closing the iterator early releases the runs not yet finished (Dask cannot stop one
    already running on a worker: it finishes there, or its worker ends with the cluster)."""
    topic = f"{PROGRESS_TOPIC}-{socket.gethostname()}-{os.getpid()}-{next(_calls)}"
    events: queue.Queue = queue.Queue()
    client.subscribe_topic(topic, lambda event: events.put(event[1]))

    def submit(config_data: dict, root: str, attempt: int) -> Future:
        key = f"run {root} (attempt {attempt}, {topic})"  # what the dashboard shows; unique per submission
        return client.submit(run_task, run_one, config_data, root, topic, checkpoint_interval, key=key)

    def report() -> None:
        while on_progress is not None:
            try:
                root, produced = events.get_nowait()
            except queue.Empty:
                return
            on_progress(str(root), int(produced))

    futures = {submit(config, root, 1): (config, root, 1) for config, root in runs}
    try:
        while futures:
            try:
                finished, _ = wait(list(futures), timeout=poll, return_when="FIRST_COMPLETED")
            except TimeoutError:
                finished = set()
            report()
            for future in finished:
                config, root, attempt = futures.pop(future)
                if future.status == "finished":
                    yield root, None
                    continue
                error = future.exception()
                if isinstance(error, KilledWorker) and attempt < attempts:
                    futures[submit(config, root, attempt + 1)] = (config, root, attempt + 1)
                    continue
                yield root, error
    finally:
        if futures:
            client.cancel(list(futures))
        client.unsubscribe_topic(topic)
