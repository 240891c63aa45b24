"""The run loop: an algorithm, an evaluator, passive grids, a run directory and checkpoints.

A run directory holds (all written by this module, all plain text):

``config.json``
    the configuration and seed (never changed after the run starts);
``evaluations.csv``
    one row per evaluation: index, simulator seed, tree text, the three objectives, the three descriptors,
    error;
``progress.csv``
    one row per batch: evaluations so far, then for each objective the best fitness, the coverage and the QD
    score of its passive grid;
``checkpoint.json``
    the algorithm's state, the passive grids and the lengths of the two CSV files, written atomically;
``repertoire_<objective>.json``, ``archive.json`` (MAP-Elites), ``summary.json``, ``figures/``, ``best/``
    written when the run ends (see :mod:`.outputs`).

Every evaluated tree is offered to a passive grid per objective. A resumed run cuts the CSV files back to
the lengths in the checkpoint and continues from its state; since per-evaluation seeds depend only on the
run seed and the evaluation's index, it ends with exactly the files of an uninterrupted run.
"""

from __future__ import annotations

import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Protocol

from .algorithms import AskTell, GeneticProgramming, MapElites, as_outcome
from .archive import Repertoire
from .config import RunConfig, evaluation_seed
from .errors import RunDirectoryError
from .files import CsvLog, number, read_json, read_json_object, write_json
from .primitives import DESCRIPTORS, OBJECTIVES, tree_to_text

CHECKPOINT_FORMAT = 1

EVALUATION_HEADER = ["evaluation", "seed", "tree", *OBJECTIVES, *DESCRIPTORS, "error"]
PROGRESS_HEADER = ["evaluations"] + [f"{m}_{o}" for o in OBJECTIVES for m in ("best", "coverage", "qd_score")]


class Evaluator(Protocol):
    """The evaluator contract of ``docs/interfaces.md``."""

    def evaluate(self, requests: Sequence) -> list: ...


def _request_type() -> Callable[..., object]:
    from swarm_sim.evaluation import EvaluationRequest

    return EvaluationRequest


@dataclass
class Timing:
    """Wall-clock seconds spent in the evaluator and in everything else (algorithm, grids, files)."""

    evaluator: float = 0.0
    manager: float = 0.0

    @property
    def total(self) -> float:
        return self.evaluator + self.manager


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

    def repertoire(self, objective: str) -> Path:
        return self.root / f"repertoire_{objective}.json"

    @property
    def archive(self) -> Path:
        return self.root / "archive.json"

    def started(self) -> bool:
        """Whether a run was ever started here."""
        return self.config.exists()


class Run:
    """One run being executed; create with :meth:`start` or :meth:`resume`, then call :meth:`execute`."""

    def __init__(self, config: RunConfig, directory: RunDirectory, evaluator: Evaluator | None) -> None:
        self.config = config
        self.directory = directory
        self.evaluator = evaluator
        self.algorithm: AskTell = config.make_algorithm()
        self.passive = {objective: Repertoire() for objective in OBJECTIVES}
        self.evaluations = 0
        self.timing = Timing()
        self.offsets = {"evaluations": 0, "progress": 0}

    # Construction ------------------------------------------------------------------------------------
    @classmethod
    def start(cls, config: RunConfig, root: Path, evaluator: Evaluator) -> Run:
        """A new run in ``root``, which must not hold a run already (nothing saved is ever overwritten)."""
        directory = RunDirectory(root)
        if directory.started():
            raise RunDirectoryError(
                f"{root} already holds a run: continue it with --resume, or choose another --out"
            )
        if directory.root.exists() and not directory.root.is_dir():
            raise RunDirectoryError(f"{root} is a file, not a directory: choose another --out")
        if directory.root.exists() and any(directory.root.iterdir()):
            raise RunDirectoryError(f"{root} is not empty and holds no run: choose an empty or new --out")
        directory.root.mkdir(parents=True, exist_ok=True)
        run = cls(config, directory, evaluator)
        write_json(directory.config, config.to_json())
        run.offsets = {"evaluations": directory.evaluations.create(), "progress": directory.progress.create()}
        run.checkpoint()
        return run

    @classmethod
    def resume(cls, root: Path, evaluator: Evaluator | None, cut: bool = True) -> Run:
        """The run in ``root`` as it was at its last checkpoint, its CSV files cut back to match (with
        ``cut=False``, for reading only, the files are left as they are)."""
        directory = RunDirectory(root)
        if not directory.started():
            raise RunDirectoryError(f"{root} holds no run to resume (no config.json)")
        config = RunConfig.from_json(read_json_object(directory.config))
        state = read_json(directory.checkpoint)
        if not isinstance(state, dict) or state.get("format") != CHECKPOINT_FORMAT:
            raise RunDirectoryError(
                f"{directory.checkpoint} is not a checkpoint of format {CHECKPOINT_FORMAT}"
            )
        if RunConfig.from_json(state["config"]) != config:
            raise RunDirectoryError(
                f"{directory.checkpoint} belongs to another configuration than config.json"
            )
        run = cls(config, directory, evaluator)
        try:
            run.algorithm.restore(state["algorithm"])
            run.passive = {o: Repertoire.from_state(state["passive"][o]) for o in OBJECTIVES}
            run.evaluations = int(state["evaluations"])
            run.offsets = {k: int(v) for k, v in state["offsets"].items()}
            run.timing = Timing(**state["timing"])
        except (KeyError, TypeError, ValueError) as error:
            raise RunDirectoryError(f"{directory.checkpoint} is damaged: {error}") from error
        if cut:
            directory.evaluations.cut(run.offsets["evaluations"])
            directory.progress.cut(run.offsets["progress"])
        return run

    # Execution ---------------------------------------------------------------------------------------
    @property
    def done(self) -> bool:
        return self.algorithm.done

    def execute(
        self,
        on_batch: Callable[[int, int], None] | None = None,
        checkpoint_interval: float = 30.0,
        stop_after: int | None = None,
    ) -> None:
        """Run batches until the budget is spent (or ``stop_after`` evaluations, for tests and benchmarks).

        A checkpoint is written when ``checkpoint_interval`` seconds have passed since the last one, and
        always at the end. ``on_batch(evaluations, budget)`` is called after every batch.
        """
        last_checkpoint = time.monotonic()
        make_request = _request_type()
        while not self.algorithm.done and (stop_after is None or self.evaluations < stop_after):
            started = time.perf_counter()
            trees = self.algorithm.ask()
            first = self.evaluations
            requests = [
                make_request(
                    tree=tree, seed=evaluation_seed(self.config.seed, first + i), trials=self.config.trials
                )
                for i, tree in enumerate(trees)
            ]
            asked = time.perf_counter()
            if self.evaluator is None:
                raise RunDirectoryError("this run was opened for reading: it has no evaluator")
            results = list(self.evaluator.evaluate(requests))
            evaluated = time.perf_counter()
            self.algorithm.tell(results)
            self._record(requests, results)
            finished = time.perf_counter()
            self.timing.evaluator += evaluated - asked
            self.timing.manager += (asked - started) + (finished - evaluated)
            if on_batch is not None:
                on_batch(self.evaluations, self.config.evaluations)
            if time.monotonic() - last_checkpoint >= checkpoint_interval:
                self._timed_checkpoint()
                last_checkpoint = time.monotonic()
        self._timed_checkpoint()

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
                for k, objective in enumerate(OBJECTIVES):
                    self.passive[objective].offer(request.tree, fitness[k], descriptors, index)
                values = [number(v) for v in fitness + descriptors]
                error = ""
            else:
                values = [""] * (len(OBJECTIVES) + len(DESCRIPTORS))
                error = outcome.error or "no fitness or descriptors"
            rows.append([str(index), str(request.seed), request.tree, *values, error])
        self.evaluations += len(requests)
        self.offsets["evaluations"] = self.directory.evaluations.append(rows)
        self.offsets["progress"] = self.directory.progress.append([self.progress_row()])

    def progress_row(self) -> list[str]:
        """Evaluations so far, then best, coverage and QD score of each objective's passive grid."""
        row = [str(self.evaluations)]
        for objective in OBJECTIVES:
            grid = self.passive[objective]
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
                "passive": {o: self.passive[o].to_state() for o in OBJECTIVES},
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
