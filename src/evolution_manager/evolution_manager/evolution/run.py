"""A tree run (GP, GP_fnd, MAP-Elites): an algorithm, an evaluator, passive grids, a run directory and
checkpoints, on the loop and folder every run shares (``run_folder``).

A run directory holds (all plain text):

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

Every evaluated tree is offered to a passive grid per objective of ``RunConfig.grids`` (3 per bin), at its
point of the run's behaviour space (``RunConfig.descriptors``: the paper's descriptors, or the deliveries of
each food kind; ``descriptor_sets``). The
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
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

from bt_controller.language import Library
from bt_controller.validate import integer
from evolution_manager.errors import EvolutionError, RunDirectoryError
from evolution_manager.evolution.algorithms import AskTell, GeneticProgramming, MapElites, Outcome, as_outcome
from evolution_manager.evolution.archive import Repertoire, SimplifiedForms
from evolution_manager.evolution.deap_trees import DESCRIPTORS, OBJECTIVES, tree_from_text, tree_to_text
from evolution_manager.evolution.descriptor_sets import descriptor_set
from evolution_manager.evolution.run_config import RunConfig
from evolution_manager.evolution.run_folder import DAMAGE, RunFolder, RunLoop, Timing
from evolution_manager.files import number, read_json_object
from swarm_ros.safe_paths import refuse_links
from swarm_sim.evaluation import EvaluationRequest, Evaluator
from swarm_sim.model import fitness_ceiling

SIMULATED, CACHED, INHERITED = "simulated", "cached", "inherited"
"""How an evaluation was answered: simulated; from the cache (fixed scenarios: the same tree text evaluated
before); from the simplified form's earlier evaluation (``paper`` with fixed scenarios)."""

EVALUATION_HEADER = ["evaluation", "seed", "tree", *OBJECTIVES, *DESCRIPTORS, "error"]
PROGRESS_HEADER = ["evaluations"] + [f"{m}_{o}" for o in OBJECTIVES for m in ("best", "coverage", "qd_score")]


@dataclass(frozen=True)
class Evaluated:
    """One evaluation of a batch as the run recorded it: the request, its outcome, and whether it was
    answered from the run's cache (under fixed scenarios, a tree seen before is not simulated again)."""

    request: EvaluationRequest
    outcome: Outcome
    cached: bool
    """Answered without simulating (``CACHED`` or ``INHERITED``)."""


class RunDirectory(RunFolder):
    """The paths of a tree run's folder."""

    def __init__(self, root: Path) -> None:
        super().__init__(root, EVALUATION_HEADER, PROGRESS_HEADER)
        self.figures = self.root / "figures"

    def repertoire(self, objective: str) -> Path:
        return self.root / f"repertoire_{objective}.json"

    @property
    def archive(self) -> Path:
        return self.root / "archive.json"

    def read_config(self) -> RunConfig:
        """The run's configuration from ``config.json``; a damaged file is named in the error."""
        try:
            return RunConfig.from_json(read_json_object(self.config))
        except RunDirectoryError:
            raise
        except (*DAMAGE, EvolutionError) as error:
            raise RunDirectoryError(f"{self.config} is damaged: {error}") from error

    def read_library(self, config: RunConfig) -> Library | None:
        """The run's copy of its primitive library (None for a run without one), checked against the
        configuration's digest."""
        return self.read_library_copy(config.library_digest, config.library)

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


class Run(RunLoop[EvaluationRequest, Evaluated]):
    """One tree run being executed; create with :meth:`start` or :meth:`resume`, then call :meth:`execute`."""

    def __init__(
        self,
        config: RunConfig,
        directory: RunDirectory,
        evaluator: Evaluator | None,
        library: Library | None = None,
    ) -> None:
        super().__init__()
        self.config = config
        self.directory: RunDirectory = directory
        self.evaluator = evaluator
        self.library = library
        """The run's primitive library (its copy in the run directory), or None."""
        self.forms = SimplifiedForms(library)
        """The simplified form of every tree text that needed one (shared by the grids and the cache)."""
        self.grid_forms = self.forms if config.refuses_clones else None
        """What the grids refuse clones by: the simplified forms under ``clean``, nothing under ``paper``."""
        self.space = descriptor_set(config.descriptors)
        """The behaviour space the grids bin trees by (``descriptor_sets``)."""
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

    # Construction ------------------------------------------------------------------------------------
    @classmethod
    def start(
        cls, config: RunConfig, root: Path, evaluator: Evaluator, library: Library | None = None
    ) -> Run:
        """A new run in ``root``, which must not hold a run already (``RunLoop._begin``): its configuration,
        its copy of the library, empty logs and first checkpoint."""
        files: dict[str, object] = {"config.json": config.to_json()}
        if library is not None:
            files["library.json"] = library.as_json()
        return cls._begin(
            RunDirectory(root),
            lambda building: cls(config, RunDirectory(building), evaluator, library),
            files,
        )

    @classmethod
    def resume(cls, root: Path, evaluator: Evaluator | None, cut: bool = True) -> Run:
        """The run in ``root`` as it was at its last checkpoint, its CSV files cut back to match (with
        ``cut=False``, for reading only, the files are left as they are and no lock is taken).

        The checkpoint is checked whole (format, configuration, algorithm state, every tree in it) before
        anything is changed; a writer's lock is taken first, and the temporary files of a killed writer are
        removed."""
        directory = RunDirectory(root)
        if not cut:
            if not directory.started():
                raise RunDirectoryError(f"{root} holds no run to resume (no config.json)")
            return cls._load(directory, evaluator)

        def load() -> Run:
            run = cls._load(directory, evaluator)
            directory.check_heldout()  # read when the run ends: checked before anything is run
            return run

        return cls._reopen(directory, load)

    @classmethod
    def _load(cls, directory: RunDirectory, evaluator: Evaluator | None) -> Run:
        """The run of ``directory`` at its checkpoint, every part of it checked; changes nothing."""
        config = directory.read_config()
        state = directory.read_checkpoint()
        directory.check_logs()
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
            run.offsets = directory.read_offsets(state["offsets"])
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
        except RunDirectoryError:
            raise
        except (*DAMAGE, EvolutionError) as error:
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

    def progress(self) -> tuple[int, int]:
        return self.algorithm.produced, self.config.evaluations

    def _ask(self) -> list[EvaluationRequest]:
        """The algorithm's next trees, each with its evaluation's seed."""
        first = self.evaluations
        return [
            EvaluationRequest(tree=tree, seed=self.config.request_seed(first + i), trials=self.config.trials)
            for i, tree in enumerate(self.algorithm.ask())
        ]

    def _tell(self, batch: list[EvaluationRequest], answers: list[Evaluated]) -> None:
        self.last_batch = answers
        results = [e.outcome for e in answers]
        self.algorithm.tell([self._placed(outcome) for outcome in results])
        self._record(batch, results)

    def _placed(self, outcome: Outcome) -> Outcome:
        """``outcome`` with its descriptors in the run's behaviour space (the grids'; the evaluator's own
        stay in ``evaluations.csv``)."""
        measured = outcome.measured()
        if measured is None or self.space.names == DESCRIPTORS:
            return outcome
        return Outcome(measured[0], self.space.point(*measured), outcome.error)

    def _evaluate(self, requests: list[EvaluationRequest]) -> list[Evaluated]:
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

    def _record(self, requests: Sequence, results: Sequence) -> None:
        rows = []
        for offset, (request, result) in enumerate(zip(requests, results, strict=True)):
            index = self.evaluations + offset
            outcome = as_outcome(result)
            measured = outcome.measured()
            if measured is not None:
                fitness, descriptors = measured
                point = self.space.point(fitness, descriptors)
                for objective, grid in self.passive.items():
                    grid.offer(request.tree, fitness[OBJECTIVES.index(objective)], point, index)
                values = [number(v) for v in fitness + descriptors]
                error = ""
            else:
                values = [""] * (len(OBJECTIVES) + len(DESCRIPTORS))
                error = outcome.error or "no fitness or descriptors"
            rows.append([str(index), str(request.seed), request.tree, *values, error])
            self._first.setdefault(request.tree, index)
        self.evaluations += len(requests)
        self._offer_generations()  # before the progress row, which measures the repertoires
        self._append_logs(rows, self.progress_row())

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
        self.directory.write_checkpoint(
            {
                "config": self.config.to_json(),
                "evaluations": self.evaluations,
                "done": self.algorithm.done,
                "offsets": self.offsets,
                "timing": {"evaluator": self.timing.evaluator, "manager": self.timing.manager},
                "algorithm": self.algorithm.to_state(),
                "passive": {o: grid.to_state() for o, grid in self.passive.items()},
                "generations": {o: grid.to_state() for o, grid in self.generations.items()},
            }
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
