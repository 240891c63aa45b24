"""What every run shares, tree runs (``evolution.run``), composition runs (``evolution.compositions``),
network runs (``evolution.networks``) and team runs (``evolution.teams``): its folder and its loop.

A run folder holds ``config.json`` (never changed once the run starts; a composition run's says ``"kind":
"compositions"``, a network run's ``"kind": "networks"``), ``evaluations.csv`` and ``progress.csv``
(append-only logs, one row per evaluation and per batch), ``checkpoint.json`` (written atomically between
batches, with the lengths of the two logs) and, when the run ends, its results. A new folder appears whole or
not at all; one process at a time writes it, holding ``.lock``; a resume checks the checkpoint whole before
changing anything, then cuts the logs back to it, so that a resumed run ends with the very files of an
uninterrupted one.

:class:`RunLoop` is the loop every kind executes: ask for a batch, evaluate it, tell the outcome and record
it, checkpoint now and then and at the end. Each kind keeps its own configuration, log columns and checkpoint
contents (format 1 of each, as the runs already made wrote them). :class:`CountedRun` is what composition,
network and team runs add to it alike: a budget of genomes produced, a checkpoint of the configuration, the
counts and the kind's state, one resume that refuses a damaged run in one line, and the best genome so far,
each an :class:`EvaluatedGenome` (one JSON shape for the three).
"""

from __future__ import annotations

import math
import os
import random
import shutil
import tempfile
import time
from abc import ABC, abstractmethod
from collections.abc import Callable, Sequence
from contextlib import AbstractContextManager, nullcontext
from dataclasses import dataclass
from pathlib import Path
from typing import Any, ClassVar, Generic, Protocol, Self, TypeVar

from bt_controller.language import Library, LibraryError, library_from_json
from bt_controller.validate import integer
from bt_controller.validate import number as finite_number
from evolution_manager.errors import ConfigError, RunDirectoryError
from evolution_manager.files import CsvLog, _umask, number, read_json, write_atomic, write_json, writing
from evolution_manager.processes import Lock, exclusive_lock, is_locked
from swarm_ros.safe_paths import make_folder, refuse_links

LOCK_NAME = ".lock"  # in the run folder: held by the process writing the run
CHECKPOINT_FORMAT = 1
COMPOSITIONS = "compositions"
"""``config.json``'s ``kind`` of a composition run (a tree run's has no ``kind``)."""
NETWORKS = "networks"
"""``config.json``'s ``kind`` of a network run (``evolution.networks``)."""
TEAMS = "teams"
"""``config.json``'s ``kind`` of a team run (``evolution.teams``)."""

DAMAGE = (KeyError, TypeError, ValueError, AttributeError, IndexError, OverflowError)
"""What reading a damaged configuration or checkpoint raises (a missing key, a value of the wrong kind)."""

WRITTEN = (
    "checkpoint.json",
    "summary.json",
    "evaluations.csv",
    "progress.csv",
    "heldout.json",
    "archive.json",
    "timing.json",
    "sessions.json",
    "explorer.html",
    "best",
    "figures",
)
"""What a run writes in its folder, besides ``repertoire_<objective>.json`` and the files in ``best/`` and
``figures/`` (``config.json``, ``cells.json`` and ``library.json`` are only read once a run has started)."""

_Filled = TypeVar("_Filled")
_Run = TypeVar("_Run", bound="RunLoop")
_Asked = TypeVar("_Asked")
_Answer = TypeVar("_Answer")
_Genome = TypeVar("_Genome", bound=tuple)


def run_kind(root: Path) -> str | None:
    """The kind of the run in ``root`` by its ``config.json``: ``"compositions"``, ``"networks"``,
    ``"teams"``, ``"trees"``, or None when it holds no readable configuration."""
    path = Path(root) / "config.json"
    if not path.is_file():
        return None
    try:
        data = read_json(path)
    except RunDirectoryError:
        return None
    if not isinstance(data, dict):
        return None
    kind = data.get("kind")
    return kind if kind in (COMPOSITIONS, NETWORKS, TEAMS) else "trees"


def _remove_abandoned_starts(parent: Path, name: str) -> None:
    """Remove what starts of a run at ``parent/name`` killed before their first checkpoint left behind."""
    for leftover in parent.glob(f".{name}.new-*"):
        if leftover.is_dir() and not is_locked(leftover / LOCK_NAME):
            shutil.rmtree(leftover, ignore_errors=True)


def create_whole(root: Path, fill: Callable[[Path], _Filled]) -> tuple[_Filled, Lock]:
    """Create the run folder ``root`` whole or not at all: ``fill(folder)`` writes a hidden sibling
    (``.<name>.new-*``, holding the folder's lock) with the run's first files, which is then renamed into
    place (replacing an empty directory, never a full one). Returns what ``fill`` returned and the lock, now
    at ``root``. Leftovers of starts killed before their rename are removed first."""
    root = Path(root)
    parent = root.absolute().parent
    parent.mkdir(parents=True, exist_ok=True)
    _remove_abandoned_starts(parent, root.name)
    building = Path(tempfile.mkdtemp(prefix=f".{root.name}.new-", dir=parent))
    try:
        os.chmod(building, 0o777 & ~_umask())
        lock = exclusive_lock(building / LOCK_NAME, f"the run directory {root}")
        filled = fill(building)
        try:
            os.rename(building, root)
        except OSError as error:
            raise RunDirectoryError(
                f"{root} was created by another process meanwhile: choose another --out"
            ) from error
    except BaseException:
        shutil.rmtree(building, ignore_errors=True)
        raise
    lock.moved(root / LOCK_NAME)
    return filled, lock


def refuse_planted_links(root: Path) -> None:
    """Raise ``RunDirectoryError`` (one line) for a symbolic link at a path a run writes in ``root``
    (``WRITTEN``, the repertoires, what ``best/`` and ``figures/`` hold): a resume or a rebuild refuses it
    before anything is evaluated or written, rather than when it reaches that file."""
    root = Path(root)
    paths = [root / name for name in WRITTEN] + sorted(root.glob("repertoire_*.json"))
    for folder in (root / "best", root / "figures"):
        if folder.is_dir() and not folder.is_symlink():
            paths += sorted(folder.iterdir())
    for path in paths:
        try:
            refuse_links(path)
        except OSError as error:
            raise RunDirectoryError(str(error)) from None


def generator_state(rng: random.Random) -> list:
    """``rng``'s state as a checkpoint holds it in JSON: ``[version, [internal state...], gauss]``."""
    version, internal, gauss = rng.getstate()
    return [version, list(internal), gauss]


def restore_generator(rng: random.Random, state: Sequence) -> None:
    """Set ``rng`` to a state :func:`generator_state` gave; a ValueError or TypeError when it is not one."""
    version, internal, gauss = state
    rng.setstate((int(version), tuple(int(x) for x in internal), gauss))


@dataclass
class Timing:
    """Wall-clock seconds spent in the evaluator and in everything else (algorithm, grids, files)."""

    evaluator: float = 0.0
    manager: float = 0.0

    @property
    def total(self) -> float:
        return self.evaluator + self.manager

    @classmethod
    def from_state(cls, state: object) -> Timing:
        """The timing saved in a checkpoint: two non-negative seconds, or a ValueError naming the bad one."""
        if not isinstance(state, dict) or set(state) != {"evaluator", "manager"}:
            raise ValueError(f"timing must be an object of evaluator and manager seconds, got {state!r}")
        seconds = {name: finite_number(value, f"timing.{name}") for name, value in state.items()}
        if min(seconds.values()) < 0:
            raise ValueError(f"timing seconds must not be negative, got {state!r}")
        return cls(**seconds)


@dataclass(frozen=True)
class EvaluatedGenome(Generic[_Genome]):
    """One evaluated genome of a composition, network or team run, as its checkpoint, summary and repertoire
    record it: the genome, the objective's fitness and the measured values of the run's axes (both None when
    the evaluation failed), the index of the evaluation that gave them, and the error ("" when none). A kind
    says how its genome is written (:attr:`GENOME`, :meth:`_genome`) and how a failed one ranks."""

    genome: _Genome
    fitness: float | None
    descriptors: tuple[float, ...] | None
    evaluation: int
    error: str = ""

    GENOME: ClassVar[str] = "genome"
    """The genome's key in JSON."""
    FAILED: ClassVar[float] = -math.inf
    """The rank of a failed evaluation: below every fitness."""

    @property
    def rank(self) -> float:
        """What selection compares: the fitness, a failed evaluation at :attr:`FAILED`."""
        return self.FAILED if self.fitness is None else self.fitness

    @classmethod
    def _genome(cls, values: Sequence) -> _Genome:
        """The genome from its JSON list (a TypeError or ValueError for values of the wrong kind)."""
        raise NotImplementedError

    def as_json(self) -> dict:
        return {
            self.GENOME: list(self.genome),
            "fitness": self.fitness,
            "descriptors": None if self.descriptors is None else list(self.descriptors),
            "evaluation": self.evaluation,
            "error": self.error,
        }

    @classmethod
    def from_json(cls, data: dict) -> Self:
        return cls(**cls._fields_from_json(data))

    @classmethod
    def _fields_from_json(cls, data: dict) -> dict[str, Any]:
        """The fields :meth:`as_json` writes, read back and checked, by name."""
        descriptors, error = data["descriptors"], data["error"]
        return {
            "genome": cls._genome(data[cls.GENOME]),
            "fitness": None if data["fitness"] is None else float(data["fitness"]),
            "descriptors": None if descriptors is None else tuple(float(d) for d in descriptors),
            "evaluation": int(data["evaluation"]),
            "error": "" if error is None else str(error),
        }

    def logged(self, axes: int) -> list[str]:
        """The fitness and the ``axes`` measured values as ``evaluations.csv`` writes them: empty cells for a
        failed evaluation."""
        if self.fitness is None or self.descriptors is None:
            return [""] * (1 + axes)
        return [number(self.fitness), *(number(d) for d in self.descriptors)]


class RunFolder:
    """The paths every run folder has, and what is done to them alike for every kind of run."""

    def __init__(self, root: Path, evaluation_header: Sequence[str], progress_header: Sequence[str]) -> None:
        self.root = Path(root)
        self.config = self.root / "config.json"
        self.checkpoint = self.root / "checkpoint.json"
        self.summary = self.root / "summary.json"
        self.library = self.root / "library.json"
        self.best = self.root / "best"
        self.evaluations = CsvLog(self.root / "evaluations.csv", list(evaluation_header))
        self.progress = CsvLog(self.root / "progress.csv", list(progress_header))

    def started(self) -> bool:
        """Whether a run was ever started here."""
        return self.config.exists()

    def read_library_copy(self, digest: str, label: str) -> Library | None:
        """The run's copy of its primitive library (None for a run without one, ``digest`` ""), checked
        against the digest its configuration records; ``label`` names the library in errors."""
        if not digest:
            return None
        try:
            library = library_from_json(read_json(self.library), label)
        except (LibraryError, RunDirectoryError, *DAMAGE) as error:
            raise RunDirectoryError(f"{self.library} is damaged: {error}") from error
        if library.digest != digest:
            raise RunDirectoryError(f"{self.library} is not the library the run started with")
        return library

    def read_checkpoint(self) -> dict:
        """``checkpoint.json``, a JSON object of :data:`CHECKPOINT_FORMAT` (its contents are the kind's)."""
        state = read_json(self.checkpoint)
        if not isinstance(state, dict) or state.get("format") != CHECKPOINT_FORMAT:
            raise RunDirectoryError(f"{self.checkpoint} is not a checkpoint of format {CHECKPOINT_FORMAT}")
        return state

    def write_checkpoint(self, state: dict) -> None:
        """Write ``checkpoint.json`` atomically: the format, then ``state``."""
        write_json(self.checkpoint, {"format": CHECKPOINT_FORMAT, **state}, indent=None)

    def check_logs(self) -> None:
        """Raise ``RunDirectoryError`` if a log was written with other columns than this version's."""
        for log in (self.evaluations, self.progress):
            with open(log.path, newline="") as handle:
                header = handle.readline().strip()
            if header != ",".join(log.header):
                raise RunDirectoryError(
                    f"{log.path} was written with other columns ({header[:120]}): a run of an earlier "
                    "version of the model, which this version cannot continue"
                )

    def read_offsets(self, state: dict) -> dict[str, int]:
        """The lengths of the two logs a checkpoint records (``offsets``); a ValueError for one that is not
        a length or lies beyond the end of its log."""
        offsets = {}
        for name, log in (("evaluations", self.evaluations), ("progress", self.progress)):
            offset = integer(state[name], f"offsets.{name}", 0)
            if offset > log.size():
                raise ValueError(f"offsets.{name} {offset} is beyond the end of {log.path.name}")
            offsets[name] = offset
        return offsets

    def write_best_swarm(self, objective: str, layout: dict, trees: Sequence[str], each: str) -> list[Path]:
        """Write a run's best swarm in ``best/``: its layout file ``<objective>_swarm.json`` (``layout``, for
        ``evaluate --swarm``, ``trial --swarm``, ``animate --swarm``) and each of its ``trees`` as
        ``<objective>_<each><i>.txt``; return the paths written."""
        with writing(self.best):  # a link planted in the run folder is refused, never followed
            make_folder(self.best, self.root)
        path = self.best / f"{objective}_swarm.json"
        write_json(path, layout)
        written = [path]
        for i, tree in enumerate(trees):
            path = self.best / f"{objective}_{each}{i}.txt"
            write_atomic(path, tree + "\n")
            written.append(path)
        return written

    def temporary_files(self) -> list[Path]:
        """The temporary files of atomic writes a killed writer left behind (``.<name>.*.tmp``)."""
        if not self.root.is_dir():
            return []
        return [p for p in self.root.rglob(".*.tmp") if p.is_file()]


class RunLoop(ABC, Generic[_Asked, _Answer]):
    """A run being executed, of any kind: its folder, its lock, the lengths of its logs at the last
    checkpoint, where the time went, and the loop of batches (:meth:`execute`). A kind says how a batch is
    asked for, evaluated and told (:meth:`_ask`, :meth:`_evaluate`, :meth:`_tell`) and what its checkpoint
    holds (:meth:`checkpoint`)."""

    directory: RunFolder

    def __init__(self) -> None:
        self.evaluations = 0
        self.offsets = {"evaluations": 0, "progress": 0}
        self.timing = Timing()
        self.lock: Lock | None = None  # the run folder's lock, held by a run that writes

    # Construction ------------------------------------------------------------------------------------
    @staticmethod
    def _begin(folder: RunFolder, make: Callable[[Path], _Run], files: dict[str, object]) -> _Run:
        """The run ``make(building)`` started in ``folder``, which must not hold a run already (nothing saved
        is ever overwritten). The folder appears whole or not at all: it is built as a hidden sibling
        (``.<name>.new-*``) with ``files`` (name: JSON document, in order), empty logs and the first
        checkpoint, then renamed into place. The run holds the folder's lock until the process ends."""
        root = folder.root
        if folder.started():
            raise RunDirectoryError(
                f"{root} already holds a run: continue it with --resume, or choose another --out"
            )
        if root.exists() and not root.is_dir():
            raise RunDirectoryError(f"{root} is a file, not a directory: choose another --out")
        if root.exists() and any(root.iterdir()):
            raise RunDirectoryError(f"{root} is not empty and holds no run: choose an empty or new --out")

        def fill(building: Path) -> _Run:
            run = make(building)
            for name, document in files.items():
                write_json(building / name, document)
            run.offsets = {
                "evaluations": run.directory.evaluations.create(),
                "progress": run.directory.progress.create(),
            }
            run.checkpoint()
            return run

        run, lock = create_whole(root, fill)
        run.lock = lock
        run.directory = folder
        return run

    @staticmethod
    def _reopen(folder: RunFolder, load: Callable[[], _Run]) -> _Run:
        """The run ``load()`` reads from its checkpoint in ``folder``, to be continued: the folder's lock is
        taken first, then the run is loaded and checked whole (``load`` changes nothing) and the folder
        checked for planted links; only then are the temporary files of a killed writer removed and the
        logs cut back to the checkpoint."""
        if not folder.started():
            raise RunDirectoryError(f"{folder.root} holds no run to resume (no config.json)")
        lock = exclusive_lock(folder.root / LOCK_NAME, f"the run directory {folder.root}")
        try:
            run = load()
            refuse_planted_links(run.directory.root)  # before anything is evaluated or written
        except BaseException:
            lock.release()
            raise
        run.lock = lock
        for temporary in run.directory.temporary_files():
            temporary.unlink(missing_ok=True)
        run.directory.evaluations.cut(run.offsets["evaluations"])
        run.directory.progress.cut(run.offsets["progress"])
        return run

    def _append_logs(self, rows: list[list[str]], progress: list[str]) -> None:
        """Append a batch's rows to ``evaluations.csv`` and its row to ``progress.csv``, and keep their
        lengths."""
        self.offsets["evaluations"] = self.directory.evaluations.append(rows)
        self.offsets["progress"] = self.directory.progress.append([progress])

    # The kind's part ---------------------------------------------------------------------------------
    @property
    @abstractmethod
    def done(self) -> bool:
        """Whether the budget is spent."""

    @abstractmethod
    def progress(self) -> tuple[int, int]:
        """Individuals produced so far (what the budget counts) and the budget."""

    @abstractmethod
    def _ask(self) -> list[_Asked]:
        """The next batch to evaluate."""

    @abstractmethod
    def _evaluate(self, batch: list[_Asked]) -> list[_Answer]:
        """The batch evaluated (the evaluator's time)."""

    @abstractmethod
    def _tell(self, batch: list[_Asked], answers: list[_Answer]) -> None:
        """Give the algorithm the batch's outcomes, then record them in the logs."""

    @abstractmethod
    def checkpoint(self) -> None:
        """Write the checkpoint atomically (only between batches)."""

    def _batch_context(self) -> AbstractContextManager[object]:
        """What ``execute`` runs its batches within: nothing here (a network run: one BLAS thread)."""
        return nullcontext()

    # The loop ----------------------------------------------------------------------------------------
    def execute(
        self,
        on_batch: Callable[[int, int], None] | None = None,
        checkpoint_interval: float = 30.0,
        stop_after: int | None = None,
        before_checkpoint: Callable[[], None] | None = None,
    ) -> None:
        """Run batches until the budget is spent (or ``stop_after`` evaluations, for tests and benchmarks).

        A checkpoint is written when ``checkpoint_interval`` seconds have passed since the last one, and
        always at the end. ``on_batch(produced, budget)`` is called after every batch, and
        ``before_checkpoint()`` before every checkpoint (to put what else records the run on disk first).
        """
        last_checkpoint = time.monotonic()
        with self._batch_context():
            while not self.done and (stop_after is None or self.evaluations < stop_after):
                started = time.perf_counter()
                batch = self._ask()
                asked = time.perf_counter()
                answers = self._evaluate(batch)
                evaluated = time.perf_counter()
                self._tell(batch, answers)
                finished = time.perf_counter()
                self.timing.evaluator += evaluated - asked
                self.timing.manager += (asked - started) + (finished - evaluated)
                if on_batch is not None:
                    on_batch(*self.progress())
                if time.monotonic() - last_checkpoint >= checkpoint_interval:
                    self._save(before_checkpoint)
                    last_checkpoint = time.monotonic()
        self._save(before_checkpoint)

    def _save(self, before_checkpoint: Callable[[], None] | None) -> None:
        if before_checkpoint is not None:
            before_checkpoint()
        started = time.perf_counter()
        self.checkpoint()
        self.timing.manager += time.perf_counter() - started


class KindConfig(Protocol):
    """The configuration of a :class:`CountedRun`: its budget, and its ``config.json`` both ways."""

    @property
    def evaluations(self) -> int: ...

    def to_json(self) -> dict: ...

    @classmethod
    def from_json(cls, data: dict) -> Any: ...


_Member = TypeVar("_Member", bound=EvaluatedGenome)
_Counted = TypeVar("_Counted", bound="CountedRun")


class CountedRun(RunLoop[_Asked, _Member]):
    """A composition, network or team run: a :class:`RunLoop` whose budget counts the genomes it
    ``produced`` against its configuration's ``evaluations``, which keeps the ``best`` genome evaluated (the
    first among equals), and whose checkpoint holds its configuration, its counts, the kind's state
    (:meth:`_state`, :meth:`_restore`) and the lengths of its logs, in that order."""

    config: KindConfig
    produced: int
    best: _Member | None

    @classmethod
    def _resume(cls, folder: RunFolder, build: Callable[[], _Counted]) -> _Counted:
        """The run ``build()`` makes from the configuration (and whatever else) in ``folder``, restored from
        its checkpoint and reopened to continue (``RunLoop._reopen``); a run whose files are damaged is
        refused in one line before anything changes."""

        def load() -> _Counted:
            try:
                run = build()
                state = run.directory.read_checkpoint()
                run.directory.check_logs()
                run.restore(state)
            except (ConfigError, *DAMAGE) as error:
                raise RunDirectoryError(
                    f"{folder.root}: the run cannot be continued, it is damaged: {error}"
                ) from error
            return run

        return cls._reopen(folder, load)

    @abstractmethod
    def _state(self) -> dict:
        """The kind's part of the checkpoint, in the order it is written."""

    @abstractmethod
    def _restore(self, state: dict) -> None:
        """The kind's part of the run from its checkpoint; a ValueError, KeyError or TypeError when it is
        damaged."""

    def checkpoint(self) -> None:
        """Write the checkpoint atomically (between batches only)."""
        self.directory.write_checkpoint(
            {
                "config": self.config.to_json(),
                "evaluations": self.evaluations,
                "produced": self.produced,
                **self._state(),
                "offsets": self.offsets,
            }
        )

    def restore(self, state: dict) -> None:
        """The run's state from its checkpoint; a ValueError, KeyError or TypeError when it is damaged."""
        if type(self.config).from_json(state["config"]) != self.config:
            raise ValueError("the checkpoint belongs to another configuration than config.json")
        self.evaluations = integer(state["evaluations"], "evaluations", 0)
        self.produced = integer(state["produced"], "produced", 0)
        self._restore(state)
        self.offsets = self.directory.read_offsets(state["offsets"])

    @property
    def done(self) -> bool:
        return self.produced >= self.config.evaluations

    def progress(self) -> tuple[int, int]:
        return self.produced, self.config.evaluations

    def _keep_best(self, members: Sequence[_Member]) -> None:
        """Keep the fittest of ``members`` as :attr:`best` when it is fitter than the best so far."""
        for member in members:
            if member.fitness is not None and (self.best is None or member.fitness > self.best.rank):
                self.best = member
