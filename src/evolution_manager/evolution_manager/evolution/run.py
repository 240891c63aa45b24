"""The run loop: an algorithm, an evaluator, passive grids, a run directory and checkpoints.

A run directory holds (all written by this module, all plain text):

``config.json``
    the configuration and seed (never changed after the run starts);
``library.json``
    with a primitive library, the run's copy of it (what every later step of the run reads);
``evaluations.csv``
    one row per evaluation: index, simulator seed, tree text, every objective, the three descriptors,
    error;
``progress.csv``
    one row per batch: evaluations so far, then for each objective the best fitness, the coverage and the QD
    score of its repertoire (:meth:`Run.repertoire`; empty for an objective the run has no grid of);
``checkpoint.json``
    the algorithm's state, the passive grids and the lengths of the two CSV files, written atomically;
``repertoire_<objective>.json``, ``archive.json`` (MAP-Elites), ``summary.json``, ``figures/``, ``best/``
    written when the run ends (see ``evolution_manager.viewing.results``).

Every evaluated tree is offered to a passive grid per objective of ``RunConfig.grids`` (3 per bin). The
repertoire of an objective that the run evolves is what the authors' analysis measures: MAP-Elites' own
archive; for GP a grid of one tree per bin offered every individual of generations 1 onwards
(charts/analysis.py:96-121).

Scenarios (``RunConfig.scenarios``): under ``fixed`` every evaluation uses the run's scenario seed, so a tree
asked for again is answered from the run's cache of results (keyed by the canonical tree text) without
simulating it; :attr:`Run.simulations` and :attr:`Run.simulations_saved` count both. Under the ``paper``
profile the cache is keyed on the simplified form instead, as the authors' code keys it on the
redundancy-stripped tree (qdpy/ea.py:447-478, gp/ea.py:506-555): a tree whose simplified form an earlier
batch evaluated takes that evaluation's fitness and descriptors, conditionality included, without being
simulated (docs/algorithms.md, "Clones"). Either way its rows in ``evaluations.csv`` are the same as a
simulation's, so the cache is rebuilt from that file, batch by batch (``progress.csv``), on resume.

Clones: under the ``clean`` profile every grid (MAP-Elites' archive, the passive grids, GP's repertoires)
refuses a tree whose simplified form is already in its bin (``Repertoire``).

A resumed run cuts the CSV files back to the lengths in the checkpoint and continues from its state; since
per-evaluation seeds depend only on the run's seeds and the evaluation's index, it ends with exactly the
files of an uninterrupted run.
"""

from __future__ import annotations

import csv
import io
import os
import shutil
import tempfile
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import TypeVar

from bt_controller.library import Library, LibraryError, library_from_json
from bt_controller.validate import integer
from bt_controller.validate import number as finite_number
from evolution_manager.errors import EvolutionError, RunDirectoryError
from evolution_manager.evolution.algorithms import AskTell, GeneticProgramming, MapElites, Outcome, as_outcome
from evolution_manager.evolution.archive import Repertoire, SimplifiedForms
from evolution_manager.evolution.deap_trees import DESCRIPTORS, OBJECTIVES, tree_from_text, tree_to_text
from evolution_manager.evolution.run_config import RunConfig
from evolution_manager.files import CsvLog, _umask, number, read_json, read_json_object, write_json
from evolution_manager.processes import Lock, exclusive_lock, is_locked
from swarm_ros.safe_paths import refuse_links
from swarm_sim.evaluation import EvaluationRequest, Evaluator
from swarm_sim.model import fitness_ceiling

LOCK_NAME = ".lock"  # in the run directory: held by the process writing the run
_Filled = TypeVar("_Filled")

CHECKPOINT_FORMAT = 1

_DAMAGE = (KeyError, TypeError, ValueError, AttributeError, IndexError, OverflowError)
"""What reading a damaged configuration or checkpoint raises (a missing key, a value of the wrong kind)."""

SIMULATED, CACHED, INHERITED = "simulated", "cached", "inherited"
"""How an evaluation was answered: simulated; from the cache (fixed scenarios: the same tree text evaluated
before); from the simplified form's earlier evaluation (``paper`` with fixed scenarios)."""

EVALUATION_HEADER = ["evaluation", "seed", "tree", *OBJECTIVES, *DESCRIPTORS, "error"]
PROGRESS_HEADER = ["evaluations"] + [f"{m}_{o}" for o in OBJECTIVES for m in ("best", "coverage", "qd_score")]


def _remove_abandoned_starts(parent: Path, name: str) -> None:
    """Remove what starts of a run at ``parent/name`` killed before their first checkpoint left behind."""
    for leftover in parent.glob(f".{name}.new-*"):
        if leftover.is_dir() and not is_locked(leftover / LOCK_NAME):
            shutil.rmtree(leftover, ignore_errors=True)


def create_whole(root: Path, fill: Callable[[Path], _Filled]) -> tuple[_Filled, Lock]:
    """Create the run directory ``root`` whole or not at all: ``fill(folder)`` writes a hidden sibling
    (``.<name>.new-*``, holding the directory's lock) with the run's first files, which is then renamed into
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


@dataclass(frozen=True)
class Evaluated:
    """One evaluation of a batch as the run recorded it: the request, its outcome, and whether it was
    answered from the run's cache (under fixed scenarios, a tree seen before is not simulated again)."""

    request: EvaluationRequest
    outcome: Outcome
    cached: bool
    """Answered without simulating (``CACHED`` or ``INHERITED``)."""


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


class RunDirectory:
    """The paths of a run directory."""

    def __init__(self, root: Path) -> None:
        self.root = Path(root)
        self.config = self.root / "config.json"
        self.checkpoint = self.root / "checkpoint.json"
        self.summary = self.root / "summary.json"
        self.evaluations = CsvLog(self.root / "evaluations.csv", EVALUATION_HEADER)
        self.progress = CsvLog(self.root / "progress.csv", PROGRESS_HEADER)
        self.figures = self.root / "figures"
        self.best = self.root / "best"
        self.library = self.root / "library.json"

    def repertoire(self, objective: str) -> Path:
        return self.root / f"repertoire_{objective}.json"

    @property
    def archive(self) -> Path:
        return self.root / "archive.json"

    def started(self) -> bool:
        """Whether a run was ever started here."""
        return self.config.exists()

    def read_config(self) -> RunConfig:
        """The run's configuration from ``config.json``; a damaged file is named in the error."""
        try:
            return RunConfig.from_json(read_json_object(self.config))
        except RunDirectoryError:
            raise
        except (*_DAMAGE, EvolutionError) as error:
            raise RunDirectoryError(f"{self.config} is damaged: {error}") from error

    def read_library(self, config: RunConfig) -> Library | None:
        """The run's copy of its primitive library (None for a run without one), checked against the
        configuration's digest."""
        if not config.library:
            return None
        try:
            library = library_from_json(read_json(self.library), config.library)
        except (LibraryError, RunDirectoryError, *_DAMAGE) as error:
            raise RunDirectoryError(f"{self.library} is damaged: {error}") from error
        if library.digest != config.library_digest:
            raise RunDirectoryError(f"{self.library} is not the library the run started with")
        return library

    @property
    def heldout(self) -> Path:
        return self.root / "heldout.json"

    def check_heldout(self) -> None:
        """Raise ``RunDirectoryError`` (one line) if ``heldout.json`` is there but is a symbolic link or no
        JSON object: a resumed run reads it, or writes it, only once every evaluation is done."""
        if not (self.heldout.exists() or self.heldout.is_symlink()):
            return
        try:
            refuse_links(self.heldout)
        except OSError as error:
            raise RunDirectoryError(str(error)) from None
        try:
            read_json_object(self.heldout)
        except RunDirectoryError as error:
            raise RunDirectoryError(
                f"{error}; remove it (the held-out scores are computed again when the run ends)"
            ) from None

    def temporary_files(self) -> list[Path]:
        """The temporary files of atomic writes a killed writer left behind (``.<name>.*.tmp``)."""
        if not self.root.is_dir():
            return []
        return [p for p in self.root.rglob(".*.tmp") if p.is_file()]


class Run:
    """One run being executed; create with :meth:`start` or :meth:`resume`, then call :meth:`execute`."""

    def __init__(
        self,
        config: RunConfig,
        directory: RunDirectory,
        evaluator: Evaluator | None,
        library: Library | None = None,
    ) -> None:
        self.config = config
        self.directory = directory
        self.evaluator = evaluator
        self.library = library
        """The run's primitive library (its copy in the run directory), or None."""
        self.forms = SimplifiedForms(library)
        """The simplified form of every tree text that needed one (shared by the grids and the cache)."""
        self.grid_forms = self.forms if config.refuses_clones else None
        """What the grids refuse clones by: the simplified forms under ``clean``, nothing under ``paper``."""
        self.algorithm: AskTell = config.make_algorithm(library, self.forms)
        self.passive = {
            objective: Repertoire(forms=self.grid_forms, fitness_max=fitness_ceiling(objective))
            for objective in config.grids
        }
        self.generations: dict[str, Repertoire] = {}
        """GP only: per evolved objective, the grid of one tree per bin of generations 1 onwards."""
        if isinstance(self.algorithm, GeneticProgramming):
            self.generations = {
                o: Repertoire(items_per_bin=1, forms=self.grid_forms, fitness_max=fitness_ceiling(o))
                for o in config.objectives
            }
        self.known: dict[str, Outcome] = {}
        """Every tree text simulated in this run with its outcome (answers repeats under ``fixed``)."""
        self.known_forms: dict[str, Outcome] = {}
        """``paper`` with fixed scenarios: every simplified form evaluated in an earlier batch, with the
        outcome of its last evaluation in the batch that first met it (MAP-Elites) or its first (GP), as the
        authors' archives (:meth:`_remember`)."""
        self.answers: list[str] = []
        """How each evaluation of the run so far was answered (``SIMULATED``, ``CACHED``, ``INHERITED``)."""
        self.simulations = 0
        self.last_batch: list[Evaluated] = []
        """The batch evaluated last, every evaluation of it (for whoever records the run, e.g. a bag)."""
        self.simulations_saved = 0
        self._first: dict[str, int] = {}
        self.evaluations = 0
        self.timing = Timing()
        self.offsets = {"evaluations": 0, "progress": 0}
        self.lock: Lock | None = None  # the run directory's lock, held by a run that writes

    # Construction ------------------------------------------------------------------------------------
    @classmethod
    def start(
        cls, config: RunConfig, root: Path, evaluator: Evaluator, library: Library | None = None
    ) -> Run:
        """A new run in ``root``, which must not hold a run already (nothing saved is ever overwritten).

        The directory appears whole or not at all: it is built as a hidden sibling (``.<name>.new-*``) with
        its configuration, empty logs and first checkpoint, then renamed into place. The run holds the
        directory's lock (``.lock``) until the process ends."""
        directory = RunDirectory(root)
        if directory.started():
            raise RunDirectoryError(
                f"{root} already holds a run: continue it with --resume, or choose another --out"
            )
        if directory.root.exists() and not directory.root.is_dir():
            raise RunDirectoryError(f"{root} is a file, not a directory: choose another --out")
        if directory.root.exists() and any(directory.root.iterdir()):
            raise RunDirectoryError(f"{root} is not empty and holds no run: choose an empty or new --out")

        def fill(building: Path) -> Run:
            run = cls(config, RunDirectory(building), evaluator, library)
            write_json(run.directory.config, config.to_json())
            if library is not None:
                write_json(run.directory.library, library.as_json())
            run.offsets = {
                "evaluations": run.directory.evaluations.create(),
                "progress": run.directory.progress.create(),
            }
            run.checkpoint()
            return run

        run, lock = create_whole(directory.root, fill)
        run.lock = lock
        run.directory = directory
        return run

    @classmethod
    def resume(cls, root: Path, evaluator: Evaluator | None, cut: bool = True) -> Run:
        """The run in ``root`` as it was at its last checkpoint, its CSV files cut back to match (with
        ``cut=False``, for reading only, the files are left as they are and no lock is taken).

        The checkpoint is checked whole (format, configuration, algorithm state, every tree in it) before
        anything is changed; a writer's lock is taken first, and the temporary files of a killed writer are
        removed."""
        directory = RunDirectory(root)
        if not directory.started():
            raise RunDirectoryError(f"{root} holds no run to resume (no config.json)")
        lock = exclusive_lock(directory.root / LOCK_NAME, f"the run directory {root}") if cut else None
        try:
            run = cls._load(directory, evaluator)
            if cut:
                directory.check_heldout()  # read when the run ends: checked before anything is run
                refuse_planted_links(directory.root)
        except BaseException:
            if lock is not None:
                lock.release()
            raise
        run.lock = lock
        if cut:
            for temporary in directory.temporary_files():
                temporary.unlink(missing_ok=True)
            directory.evaluations.cut(run.offsets["evaluations"])
            directory.progress.cut(run.offsets["progress"])
        return run

    @classmethod
    def _load(cls, directory: RunDirectory, evaluator: Evaluator | None) -> Run:
        """The run of ``directory`` at its checkpoint, every part of it checked; changes nothing."""
        config = directory.read_config()
        state = read_json(directory.checkpoint)
        if not isinstance(state, dict) or state.get("format") != CHECKPOINT_FORMAT:
            raise RunDirectoryError(
                f"{directory.checkpoint} is not a checkpoint of format {CHECKPOINT_FORMAT}"
            )
        for log in (directory.evaluations, directory.progress):
            with open(log.path, newline="") as handle:
                header = handle.readline().strip()
            if header != ",".join(log.header):
                raise RunDirectoryError(
                    f"{log.path} was written with other columns ({header[:120]}): a run of an earlier "
                    "version of the model, which this version cannot continue"
                )
        run = cls(config, directory, evaluator, directory.read_library(config))
        try:
            if RunConfig.from_json(state["config"]) != config:
                raise RunDirectoryError(
                    f"{directory.checkpoint} belongs to another configuration than config.json"
                )
            run.algorithm.restore(state["algorithm"])
            run.passive = {
                o: Repertoire.from_state(state["passive"][o], run.grid_forms, fitness_ceiling(o))
                for o in config.grids
            }
            run.evaluations = integer(state["evaluations"], "evaluations", 0)
            logs = {"evaluations": directory.evaluations, "progress": directory.progress}
            for name, log in logs.items():
                offset = integer(state["offsets"][name], f"offsets.{name}", 0)
                if offset > log.size():
                    raise ValueError(f"offsets.{name} {offset} is beyond the end of {log.path.name}")
                run.offsets[name] = offset
            run.timing = Timing.from_state(state["timing"])
            for objective, grid in state.get("generations", {}).items():
                run.generations[objective] = Repertoire.from_state(
                    grid, run.grid_forms, fitness_ceiling(objective)
                )
            archive = run.archive()
            grids = [*run.passive.values(), *([archive] if archive is not None else [])]
            for grid in grids:
                for entry in grid.entries():
                    tree_from_text(entry.tree, run.algorithm.pset, library=run.library)
            if run.algorithm.evaluations != run.evaluations or run.evaluations < 0:
                raise ValueError(
                    f"the algorithm counts {run.algorithm.evaluations} evaluations, the run {run.evaluations}"
                )
        except (
            KeyError,
            TypeError,
            ValueError,
            AttributeError,
            IndexError,
            OverflowError,
            EvolutionError,
        ) as error:
            if isinstance(error, RunDirectoryError):
                raise
            raise RunDirectoryError(f"{directory.checkpoint} is damaged: {error}") from error
        run._rebuild_cache()
        return run

    def _rebuild_cache(self) -> None:
        """The caches, the simulation counts and :attr:`answers` from ``evaluations.csv``, batch by batch as
        ``progress.csv`` delimits them (both as far as the checkpoint): the decisions of the run replayed."""
        rows = self.directory.evaluations.read()[: self.evaluations]
        start = 0
        for end in self._batch_ends():
            batch = rows[start:end]
            start = end
            try:
                trees = [row["tree"] for row in batch]
                outcomes = [_row_outcome(row) for row in batch]
                plan = self._plan(trees)  # a tree text that does not parse: a ValueError (TreeError)
                first = [int(row["evaluation"]) for row in batch]
            except (KeyError, TypeError, ValueError) as error:
                raise RunDirectoryError(f"{self.directory.evaluations.path} is damaged: {error}") from error
            self._remember(trees, plan, outcomes)
            for tree, index in zip(trees, first, strict=True):
                self._first.setdefault(tree, index)
        if start != len(rows) or len(rows) != self.evaluations:
            raise RunDirectoryError(
                f"{self.directory.evaluations.path} and {self.directory.progress.path} hold {len(rows)} and "
                f"{start} evaluations where the checkpoint says {self.evaluations}"
            )

    def _batch_ends(self) -> list[int]:
        """The evaluations after each batch, from ``progress.csv`` as far as the checkpoint."""
        with open(self.directory.progress.path, "rb") as handle:
            data = handle.read(self.offsets["progress"])
        try:
            ends = [int(row["evaluations"]) for row in csv.DictReader(io.StringIO(data.decode()))]
        except (KeyError, TypeError, ValueError) as error:
            raise RunDirectoryError(f"{self.directory.progress.path} is damaged: {error}") from error
        if ends != sorted(ends):
            raise RunDirectoryError(f"{self.directory.progress.path} is damaged: evaluations decrease")
        return ends

    def _plan(self, trees: Sequence[str]) -> list[str]:
        """How each tree of a batch is answered, from the trees and what earlier batches evaluated only:
        ``INHERITED`` when its simplified form was evaluated in an earlier batch (``paper``, fixed scenarios),
        else ``CACHED`` when its text was simulated before, earlier in the batch too (fixed scenarios), else
        ``SIMULATED``. Under ``paper`` two trees of one form first met in the same batch are both simulated,
        as the authors' assignDuplicateFitness looks only at the archive of earlier batches."""
        fixed = self.config.scenarios == "fixed"
        plan: list[str] = []
        in_batch: set[str] = set()
        for tree in trees:
            if self.config.inherits_by_form and self.forms(tree) in self.known_forms:
                plan.append(INHERITED)
            elif fixed and (tree in self.known or tree in in_batch):
                plan.append(CACHED)
            else:
                plan.append(SIMULATED)
                in_batch.add(tree)
        return plan

    def _remember(self, trees: Sequence[str], plan: Sequence[str], outcomes: Sequence[Outcome]) -> None:
        """Count a batch's simulations and keep its outcomes for the batches to come."""
        for tree, how, outcome in zip(trees, plan, outcomes, strict=True):
            if how == SIMULATED:
                self.known[tree] = outcome
        if self.config.inherits_by_form:
            # a form first met in this batch keeps its last evaluation in MAP-Elites (a dict update,
            # qdpy/ea.py:496) and its first in GP (added only when new, redundancy.py:1798-1822)
            first = isinstance(self.algorithm, GeneticProgramming)
            for tree, how, outcome in zip(trees, plan, outcomes, strict=True):
                if how != INHERITED:
                    if first:
                        self.known_forms.setdefault(self.forms(tree), outcome)
                    else:
                        self.known_forms[self.forms(tree)] = outcome
        simulated = plan.count(SIMULATED)
        self.simulations += simulated
        self.simulations_saved += len(plan) - simulated
        self.answers.extend(plan)

    # Execution ---------------------------------------------------------------------------------------
    @property
    def done(self) -> bool:
        return self.algorithm.done

    def execute(
        self,
        on_batch: Callable[[int, int], None] | None = None,
        checkpoint_interval: float = 30.0,
        stop_after: int | None = None,
        before_checkpoint: Callable[[], None] | None = None,
    ) -> None:
        """Run batches until the budget is spent (or ``stop_after`` evaluations, for tests and benchmarks).

        A checkpoint is written when ``checkpoint_interval`` seconds have passed since the last one, and
        always at the end. ``on_batch(evaluations, budget)`` is called after every batch, and
        ``before_checkpoint()`` before every checkpoint (to put what else records the run on disk first).
        """
        last_checkpoint = time.monotonic()
        while not self.algorithm.done and (stop_after is None or self.evaluations < stop_after):
            started = time.perf_counter()
            trees = self.algorithm.ask()
            first = self.evaluations
            requests = [
                EvaluationRequest(
                    tree=tree, seed=self.config.request_seed(first + i), trials=self.config.trials
                )
                for i, tree in enumerate(trees)
            ]
            asked = time.perf_counter()
            self.last_batch = self._evaluate(requests)
            results = [e.outcome for e in self.last_batch]
            evaluated = time.perf_counter()
            self.algorithm.tell(results)
            self._record(requests, results)
            finished = time.perf_counter()
            self.timing.evaluator += evaluated - asked
            self.timing.manager += (asked - started) + (finished - evaluated)
            if on_batch is not None:
                on_batch(self.algorithm.produced, self.config.evaluations)
            if time.monotonic() - last_checkpoint >= checkpoint_interval:
                if before_checkpoint is not None:
                    before_checkpoint()
                self._timed_checkpoint()
                last_checkpoint = time.monotonic()
        if before_checkpoint is not None:
            before_checkpoint()
        self._timed_checkpoint()

    def _evaluate(self, requests: Sequence[EvaluationRequest]) -> list[Evaluated]:
        """Every request evaluated as :meth:`_plan` says: the ``SIMULATED`` ones go to the evaluator in one
        batch, the others are answered from the cache or from their simplified form's evaluation."""
        if self.evaluator is None:
            raise RunDirectoryError("this run was opened for reading: it has no evaluator")
        trees = [r.tree for r in requests]
        plan = self._plan(trees)
        fresh = [r for r, how in zip(requests, plan, strict=True) if how == SIMULATED]
        results = list(self.evaluator.evaluate(fresh)) if fresh else []
        if len(results) != len(fresh):
            raise RunDirectoryError(f"the evaluator answered {len(results)} of {len(fresh)} requests")
        answers = iter(results)
        in_batch: dict[str, Outcome] = {}
        outcomes: list[Outcome] = []
        for tree, how in zip(trees, plan, strict=True):
            if how == SIMULATED:
                # Under fresh scenarios a tree asked twice is simulated twice, on two seeds: each request
                # keeps its own result (the caches serve fixed scenarios only).
                outcome = in_batch[tree] = as_outcome(next(answers))
            elif how == INHERITED:
                outcome = self.known_forms[self.forms(tree)]
            else:
                outcome = in_batch[tree] if tree in in_batch else self.known[tree]
            outcomes.append(outcome)
        self._remember(trees, plan, outcomes)
        return [
            Evaluated(r, outcome, how != SIMULATED)
            for r, outcome, how in zip(requests, outcomes, plan, strict=True)
        ]

    def _offer_generations(self) -> None:
        """GP: every individual of each generation completed, to the one-per-bin grids."""
        if not isinstance(self.algorithm, GeneticProgramming):
            return

        for population in self.algorithm.take_generations():
            for tree in population:
                if tree.descriptors is None or not tree.fitness.valid:
                    continue  # a failed evaluation
                text = tree_to_text(tree)
                for objective, grid in self.generations.items():
                    k = OBJECTIVES.index(objective)
                    grid.offer(text, tree.fitness.values[k], tree.descriptors, self.first_evaluation(text))

    def first_evaluation(self, text: str) -> int:
        """The index of the first evaluation of ``text`` in this run (-1 if never evaluated)."""
        return self._first.get(text, -1)

    def repertoire(self, objective: str) -> Repertoire:
        """The repertoire the metrics measure: MAP-Elites' archive for its objective, GP's one-per-bin grid
        of generations 1 onwards for an objective it evolves, else the passive grid (every evaluated tree)."""
        if objective in self.generations:
            return self.generations[objective]
        return self.passive[objective]

    def best(self, objective: str) -> tuple[str, float, tuple[float, ...]] | None:
        """The best tree on ``objective`` as the authors report it: GP's elite (chosen with the derated
        selection rule, reported with its stored fitness), else the repertoire's fittest item."""
        if isinstance(self.algorithm, GeneticProgramming) and objective in self.config.objectives:
            tree = self.algorithm.best(OBJECTIVES.index(objective))
            if tree is not None and tree.descriptors is not None:
                return tree_to_text(tree), tree.fitness.values[OBJECTIVES.index(objective)], tree.descriptors
        entry = self.repertoire(objective).best()
        return None if entry is None else (entry.tree, entry.value, entry.descriptors)

    def _timed_checkpoint(self) -> None:
        started = time.perf_counter()
        self.checkpoint()
        self.timing.manager += time.perf_counter() - started

    def _record(self, requests: Sequence, results: Sequence) -> None:
        rows = []
        for offset, (request, result) in enumerate(zip(requests, results, strict=True)):
            index = self.evaluations + offset
            outcome = as_outcome(result)
            measured = outcome.measured()
            if measured is not None:
                fitness, descriptors = measured
                for objective, grid in self.passive.items():
                    grid.offer(request.tree, fitness[OBJECTIVES.index(objective)], descriptors, index)
                values = [number(v) for v in fitness + descriptors]
                error = ""
            else:
                values = [""] * (len(OBJECTIVES) + len(DESCRIPTORS))
                error = outcome.error or "no fitness or descriptors"
            rows.append([str(index), str(request.seed), request.tree, *values, error])
            self._first.setdefault(request.tree, index)
        self.evaluations += len(requests)
        self._offer_generations()  # before the progress row, which measures the repertoires
        self.offsets["evaluations"] = self.directory.evaluations.append(rows)
        self.offsets["progress"] = self.directory.progress.append([self.progress_row()])

    def progress_row(self) -> list[str]:
        """Evaluations so far, then best, coverage and QD score of each objective's repertoire (empty for an
        objective without a grid in this run)."""
        row = [str(self.evaluations)]
        for objective in OBJECTIVES:
            if objective not in self.passive:
                row += ["", "", ""]
                continue
            grid = self.repertoire(objective)
            row += [number(grid.best_value), number(grid.coverage), number(grid.qd_score)]
        return row

    def checkpoint(self) -> None:
        """Write the checkpoint atomically (only between batches)."""
        write_json(
            self.directory.checkpoint,
            {
                "format": CHECKPOINT_FORMAT,
                "config": self.config.to_json(),
                "evaluations": self.evaluations,
                "done": self.algorithm.done,
                "offsets": self.offsets,
                "timing": {"evaluator": self.timing.evaluator, "manager": self.timing.manager},
                "algorithm": self.algorithm.to_state(),
                "passive": {o: grid.to_state() for o, grid in self.passive.items()},
                "generations": {o: grid.to_state() for o, grid in self.generations.items()},
            },
            indent=None,
        )

    # Results -----------------------------------------------------------------------------------------
    def archive(self) -> Repertoire | None:
        """MAP-Elites' own archive (equal to the passive grid of its objective), or None for GP."""
        return self.algorithm.archive if isinstance(self.algorithm, MapElites) else None

    def population(self) -> list[str]:
        """GP's current population as tree texts (empty for MAP-Elites)."""
        if isinstance(self.algorithm, GeneticProgramming):
            return [tree_to_text(t) for t in self.algorithm.population]
        return []


def _row_outcome(row: dict[str, str]) -> Outcome:
    """The outcome a row of ``evaluations.csv`` records."""
    if row["error"]:
        return Outcome(None, None, row["error"])
    return Outcome(
        tuple(float(row[name]) for name in OBJECTIVES),
        tuple(float(row[name]) for name in DESCRIPTORS),
    )
