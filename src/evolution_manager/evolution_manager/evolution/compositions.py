"""Heterogeneous compositions: evolve which repertoire cell each robot of a foraging swarm runs.

``evolve --task foraging --swarm-from RUN_DIR [RUN_DIR ...] --algorithm ga|qd`` (``docs/algorithms.md``,
"Heterogeneous compositions"). The *cells* are the best tree of every filled bin of every repertoire file
found in the given run directories, listed in a fixed order (:func:`read_sources`): directory by directory
as given, then the objectives in ``OBJECTIVES`` order (``repertoire_<objective>.json``), then the bins
in index order. A *genome* is one cell index per robot (robot 0 first); it is evaluated as a heterogeneous
swarm (``swarm_sim.model.swarm_layout``) on the foraging task, every evaluation on the run's scenario seed.

``ga``: a population of ``population`` genomes; each generation keeps ``elites`` best and fills the rest with
tournament winners (``tournament``), varied pairwise by two-point crossover (probability ``crossover``) and
then each by mutation (probability ``mutation``: one robot's cell redrawn uniformly among the other cells).
``qd``: MAP-Elites over compositions: an 8x8x8 grid (the swarm's movement, rotation, conditionality, binned as
every repertoire of the project) holding one genome per bin, the fitter kept; ``init_batch`` random genomes,
then batches of ``batch`` genomes varied as above from tournament winners of the grid. The budget
(``evaluations``) counts the genomes produced after the initial population, as every run's.

A run directory holds ``config.json``, ``cells.json`` (the run's copy of its cells, checked by digest),
``evaluations.csv`` (index, seed, genome as space-separated cell indices, foraging, the descriptors, error),
``progress.csv``, ``checkpoint.json`` (written atomically, with the lengths of the two CSV files and the
random generator's state); when the run ends ``summary.json``, ``best/foraging_swarm.json`` (the best
composition as a swarm layout file, for ``evaluate --swarm``, ``trial --swarm``, ``animate --swarm``),
``best/foraging_robot<i>.txt`` (its trees) and for ``qd`` ``repertoire_compositions.json``. A resumed run cuts
the CSV files back to its checkpoint and ends with the very bytes of an uninterrupted run.
"""

from __future__ import annotations

import functools
import hashlib
import json
import math
import random
from collections.abc import Sequence
from dataclasses import asdict, dataclass, field
from pathlib import Path

from bt_controller.draws import MAX_SEED, RUN_ALGORITHM, RUN_HELDOUT, derive_seed
from bt_controller.errors import TreeError
from bt_controller.library import Library, LibraryError, load_library
from bt_controller.model_settings import PROFILES
from bt_controller.tree import parse
from bt_controller.validate import integer
from evolution_manager.errors import ConfigError, RunDirectoryError
from evolution_manager.evolution.archive import Repertoire
from evolution_manager.evolution.parameters import GPParameters, QDParameters
from evolution_manager.evolution.run_config import DEFAULT_PROFILE, HELDOUT_EVALUATIONS, default_scenario_seed
from evolution_manager.evolution.run_folder import COMPOSITIONS, RunFolder, RunLoop
from evolution_manager.files import (
    number,
    read_json_object,
    write_atomic,
    write_json,
    writing,
)
from swarm_ros.safe_paths import make_folder
from swarm_sim.evaluation import Evaluator, SwarmRequest
from swarm_sim.model import OBJECTIVES, Config, SwarmLayout
from swarm_sim.tasks import task_named

KIND = COMPOSITIONS
"""``config.json``'s ``kind``: what tells a composition run from a tree run."""

ALGORITHMS: tuple[str, ...] = ("ga", "qd")
DEFAULT_EVALUATIONS = {"ga": 1000, "qd": 1000}
LABELS = {"ga": "GA_compositions", "qd": "QD_compositions"}
OBJECTIVE = "foraging"
TASK = "foraging"
DESCRIPTORS = ("movement", "rotation", "conditionality")

MUTATION = 0.5
"""Probability that a child is mutated (one robot's cell redrawn): our choice, the probability of the GP's
point mutation (``replace`` 0.5 of ``GPParameters.mutations``), the operator that likewise swaps one part of
a genome for a random one."""

EVALUATION_HEADER = ["evaluation", "seed", "genome", OBJECTIVE, *DESCRIPTORS, "error"]
PROGRESS_HEADER = ["evaluations", f"best_{OBJECTIVE}", "coverage", "qd_score"]

Genome = tuple[int, ...]

_GP = GPParameters()
_QD = QDParameters()


@dataclass(frozen=True)
class CompositionParameters:
    """The GA's and MAP-Elites' parameters: the 2023 GP's population, tournament, elite and crossover
    (``GPParameters``) and MAP-Elites' batches (``QDParameters``), with :data:`MUTATION`."""

    population: int = _GP.population
    tournament: int = _GP.tournament
    elites: int = _GP.elites_per_objective
    crossover: float = _GP.crossover
    mutation: float = MUTATION
    init_batch: int = _QD.init_batch
    batch: int = _QD.batch
    homogeneous: int = 0
    """How many genomes of the initial population (ga) or batch (qd) are homogeneous swarms of the fittest
    cells (:func:`homogeneous_genomes`), the rest random; 0, the authors' start: all random."""

    def __post_init__(self) -> None:
        integer(self.population, "population", 2, error=ConfigError)
        integer(self.homogeneous, "homogeneous", 0, error=ConfigError)
        integer(self.tournament, "tournament", 1, error=ConfigError)
        integer(self.elites, "elites", 0, self.population - 1, error=ConfigError)
        integer(self.init_batch, "init_batch", 1, error=ConfigError)
        integer(self.batch, "batch", 1, error=ConfigError)
        for name in ("crossover", "mutation"):
            value = getattr(self, name)
            if isinstance(value, bool) or not isinstance(value, (int, float)) or not 0.0 <= value <= 1.0:
                raise ConfigError(f"{name} must be a probability in [0, 1], got {value!r}")


# Cells -------------------------------------------------------------------------------------------------
@dataclass(frozen=True)
class Cell:
    """One repertoire cell: the best tree of a filled bin of a source run's repertoire."""

    source: str
    objective: str
    bin: tuple[int, ...]
    fitness: float
    tree: str

    def as_json(self) -> dict:
        return {
            "source": self.source,
            "objective": self.objective,
            "bin": list(self.bin),
            "fitness": self.fitness,
            "tree": self.tree,
        }

    @classmethod
    def from_json(cls, data: dict) -> Cell:
        return cls(
            str(data["source"]),
            str(data["objective"]),
            tuple(int(i) for i in data["bin"]),
            float(data["fitness"]),
            str(data["tree"]),
        )


def check_distinct_sources(run_dirs: Sequence[Path]) -> None:
    """Refuse a run directory given twice to ``--swarm-from`` (by its resolved path: a link to it counts), in
    one line: every one of its cells would be in the run twice."""
    seen: dict[Path, Path] = {}
    for directory in map(Path, run_dirs):
        same = seen.setdefault(directory.resolve(), directory)
        if same is not directory:
            raise ConfigError(
                f"--swarm-from: {directory} is given twice ({same} is the same run): every cell would be "
                "duplicated; give each run once"
            )


def read_sources(run_dirs: Sequence[Path]) -> tuple[list[Cell], Library | None]:
    """The cells of the repertoires in ``run_dirs``: directory by directory (as given), objective by objective
    (``OBJECTIVES`` order: ``repertoire_<objective>.json``), bin by bin (index order), each bin's fittest
    item (the first in the file among equals); and the primitive library their trees name (a run's copy,
    ``library.json``: the runs that have one must share it), or None. ``ConfigError`` naming the directory or
    file that has none or is damaged, or the runs whose libraries differ."""
    cells: list[Cell] = []
    libraries: dict[str, tuple[Path, Library]] = {}
    for directory in map(Path, run_dirs):
        library = _run_library(directory)
        if library is not None:
            libraries.setdefault(library.digest, (directory, library))
        if not directory.is_dir():
            raise ConfigError(f"--swarm-from: {directory} is not a run directory")
        files = [(o, directory / f"repertoire_{o}.json") for o in OBJECTIVES]
        files = [(o, path) for o, path in files if path.is_file()]
        if not files:
            raise ConfigError(
                f"--swarm-from: {directory} holds no repertoire (expected repertoire_<objective>.json, "
                f"objective one of {', '.join(OBJECTIVES)}, as a finished run writes)"
            )
        for objective, path in files:
            cells += _cells_of(path, directory, objective, library)
    if len(libraries) > 1:
        named = ", ".join(str(directory) for directory, _ in libraries.values())
        raise ConfigError(
            f"--swarm-from: the runs use different primitive libraries ({named}); give runs of one library"
        )
    if not cells:
        raise ConfigError(
            "--swarm-from: the repertoires hold no filled bin, so there is no cell to compose (at least 1 "
            "is needed)"
        )
    return cells, next(iter(libraries.values()))[1] if libraries else None


def _run_library(directory: Path) -> Library | None:
    """The primitive library of the run in ``directory`` (its copy, ``library.json``), or None."""
    path = directory / "library.json"
    if not path.is_file():
        return None
    try:
        return load_library(path)
    except LibraryError as error:
        raise ConfigError(f"--swarm-from: {error}") from None


def _cells_of(path: Path, directory: Path, objective: str, library: Library | None) -> list[Cell]:
    try:
        document = read_json_object(path)
        best: dict[tuple[int, ...], tuple[float, str]] = {}
        for item in document["items"]:
            index = tuple(int(i) for i in item["bin"])
            fitness, tree = float(item["fitness"]), item["tree"]
            if not isinstance(tree, str):
                raise TypeError(f"a tree is {type(tree).__name__}, not tree text")
            if index not in best or fitness > best[index][0]:
                best[index] = (fitness, tree)
    except (RunDirectoryError, KeyError, TypeError, ValueError) as error:
        raise ConfigError(f"--swarm-from: {path} is not a repertoire file: {error}") from None
    cells = []
    for index in sorted(best):
        fitness, tree = best[index]
        try:
            parse(tree, library=library)
        except TreeError as error:
            raise ConfigError(
                f"--swarm-from: the tree of bin {list(index)} in {path} does not parse ({error}); "
                "a run's primitives are read from its library.json"
            ) from None
        cells.append(Cell(str(directory), objective, index, fitness, tree))
    return cells


def cells_digest(cells: Sequence[Cell]) -> str:
    """A digest of the cell list (what ``config.json`` records; ``cells.json`` must match it)."""
    text = json.dumps([c.as_json() for c in cells], sort_keys=True, allow_nan=False)
    return hashlib.sha256(text.encode()).hexdigest()


# Genome operators ------------------------------------------------------------------------------------
def random_genome(rng: random.Random, n_cells: int, n_robots: int) -> Genome:
    """A genome of cells drawn uniformly, one per robot."""
    return tuple(rng.randrange(n_cells) for _ in range(n_robots))


def homogeneous_genomes(cells: Sequence[Cell], count: int, n_robots: int) -> list[Genome]:
    """The homogeneous swarms (every robot the same cell) of the ``count`` fittest cells by their
    recorded fitness, fittest first (the first in cell order among equals); fewer when there are fewer
    cells."""
    order = sorted(range(len(cells)), key=lambda c: (-cells[c].fitness, c))
    return [(c,) * n_robots for c in order[:count]]


def two_point_crossover(a: Genome, b: Genome, rng: random.Random) -> tuple[Genome, Genome]:
    """Two children exchanging the robots between two cut points (distinct, in 1 .. n-1): each robot keeps a
    cell of one parent at its own position."""
    if len(a) != len(b) or len(a) < 3:
        raise ValueError(
            f"two-point crossover needs genomes of one length of at least 3, got {len(a)}, {len(b)}"
        )
    i, j = sorted(rng.sample(range(1, len(a)), 2))
    return a[:i] + b[i:j] + a[j:], b[:i] + a[i:j] + b[j:]


def mutate(genome: Genome, rng: random.Random, n_cells: int) -> Genome:
    """The genome with one robot's cell redrawn uniformly among the other cells (unchanged when there is only
    one cell)."""
    if n_cells < 2:
        return genome
    robot = rng.randrange(len(genome))
    cell = rng.randrange(n_cells - 1)
    cell += cell >= genome[robot]  # skip the current cell: exactly one robot changes
    return (*genome[:robot], cell, *genome[robot + 1 :])


def vary(
    parents: Sequence[Genome], rng: random.Random, crossover: float, mutation: float, n_cells: int
) -> list[Genome]:
    """Offspring of ``parents`` (in order): consecutive pairs crossed with probability ``crossover``, then
    each child mutated with probability ``mutation`` (DEAP's ``varAnd`` order)."""
    children = list(parents)
    for k in range(1, len(children), 2):
        if rng.random() < crossover:
            children[k - 1], children[k] = two_point_crossover(children[k - 1], children[k], rng)
    return [mutate(c, rng, n_cells) if rng.random() < mutation else c for c in children]


@dataclass(frozen=True)
class Member:
    """An evaluated genome: foraging fitness and descriptors (None when the evaluation failed)."""

    genome: Genome
    fitness: float | None
    descriptors: tuple[float, ...] | None
    evaluation: int
    error: str = ""

    @property
    def rank(self) -> float:
        """What selection compares: the fitness, a failed evaluation below every other."""
        return -math.inf if self.fitness is None else self.fitness

    def as_json(self) -> dict:
        return {
            "genome": list(self.genome),
            "fitness": self.fitness,
            "descriptors": None if self.descriptors is None else list(self.descriptors),
            "evaluation": self.evaluation,
            "error": self.error,
        }

    @classmethod
    def from_json(cls, data: dict) -> Member:
        descriptors = data["descriptors"]
        return cls(
            tuple(int(c) for c in data["genome"]),
            None if data["fitness"] is None else float(data["fitness"]),
            None if descriptors is None else tuple(float(d) for d in descriptors),
            int(data["evaluation"]),
            str(data["error"]),
        )


def fittest(members: Sequence[Member]) -> Member:
    """The member of highest fitness, the first among equals."""
    best = members[0]
    for member in members[1:]:
        if member.rank > best.rank:
            best = member
    return best


def tournament(members: Sequence[Member], count: int, size: int, rng: random.Random) -> list[Genome]:
    """``count`` winners of tournaments among ``size`` members drawn with replacement."""
    return [fittest([members[rng.randrange(len(members))] for _ in range(size)]).genome for _ in range(count)]


@functools.cache
def _binner() -> Repertoire:

    return Repertoire()


def bin_of(descriptors: Sequence[float]) -> tuple[int, ...]:
    """The 8x8x8 bin of a descriptor vector, as every repertoire of the project bins (``archive``)."""
    return _binner().bin_of(tuple(descriptors))


# Configuration -------------------------------------------------------------------------------------------
@dataclass(frozen=True)
class CompositionConfig:
    """One composition run (``config.json``)."""

    algorithm: str
    evaluations: int
    seed: int
    trials: int = 10
    profile: str = DEFAULT_PROFILE
    scenario_seed: int = -1
    """-1: derived from ``seed`` as every run's (``run_config.default_scenario_seed``)."""
    sources: tuple[str, ...] = ()
    cells: int = 0
    cells_digest: str = ""
    parameters: CompositionParameters = field(default_factory=CompositionParameters)
    library_digest: str = ""
    """The digest of the primitive library the cells' trees name ("" for none); the run keeps a copy."""

    def __post_init__(self) -> None:
        if self.algorithm not in ALGORITHMS:
            raise ConfigError(f"compositions evolve with {' or '.join(ALGORITHMS)}, got {self.algorithm!r}")
        integer(self.evaluations, "evaluations", 1, error=ConfigError)
        integer(self.seed, "seed", 0, MAX_SEED, error=ConfigError)
        integer(self.trials, "trials", 1, error=ConfigError)
        integer(self.cells, "cells", 1, error=ConfigError)
        if self.profile not in PROFILES:
            raise ConfigError(f"profile must be one of {', '.join(PROFILES)}, got {self.profile!r}")
        object.__setattr__(self, "sources", tuple(self.sources))
        if self.scenario_seed == -1:
            object.__setattr__(self, "scenario_seed", default_scenario_seed(self.seed))
        integer(self.scenario_seed, "the scenario seed", 0, MAX_SEED, error=ConfigError)

    @property
    def label(self) -> str:
        return LABELS[self.algorithm]

    def world(self) -> Config:
        """The model of every evaluation: the run's profile, the foraging task's trials."""

        return task_named(TASK).config(self.profile)

    def to_json(self) -> dict:
        data = asdict(self)
        data["sources"] = list(self.sources)
        if not self.parameters.homogeneous:  # written only when asked for: earlier runs' files unchanged
            del data["parameters"]["homogeneous"]
        return {"kind": KIND, "objective": OBJECTIVE, "task": TASK, **data}

    @classmethod
    def from_json(cls, data: dict) -> CompositionConfig:
        try:
            if data.get("kind") != KIND:
                raise ConfigError("not a composition run's configuration")
            return cls(
                str(data["algorithm"]),
                data["evaluations"],
                data["seed"],
                data["trials"],
                str(data["profile"]),
                data["scenario_seed"],
                tuple(str(s) for s in data["sources"]),
                data["cells"],
                str(data["cells_digest"]),
                CompositionParameters(**data["parameters"]),
                str(data.get("library_digest", "")),
            )
        except (KeyError, TypeError, ValueError) as error:
            if isinstance(error, ConfigError):
                raise
            raise ConfigError(f"not a composition run's configuration: {error}") from error


def layout_of(genome: Genome, cells: Sequence[Cell]) -> SwarmLayout:
    """The swarm a genome stands for: robot ``i`` runs the tree of cell ``genome[i]``."""

    return SwarmLayout(tuple(cells[k].tree for k in genome))


def evaluate_genomes(
    evaluator: Evaluator,
    cells: Sequence[Cell],
    genomes: Sequence[Genome],
    seed: int,
    trials: int,
    first: int,
    seeds: Sequence[int] | None = None,
) -> list[Member]:
    """Each genome evaluated as a heterogeneous swarm with ``seed`` (or genome ``i`` with ``seeds[i]``) over
    ``trials`` trials; evaluation indices from ``first``."""
    if not genomes:
        return []
    chosen = [seed] * len(genomes) if seeds is None else list(seeds)
    requests = [SwarmRequest(layout_of(g, cells), s, trials) for g, s in zip(genomes, chosen, strict=True)]
    results = evaluator.evaluate(requests)  # type: ignore[arg-type]  # BatchEvaluator takes swarm requests
    k = OBJECTIVES.index(OBJECTIVE)
    members = []
    for offset, (genome, result) in enumerate(zip(genomes, results, strict=True)):
        if result.error is None and result.fitness is not None and result.descriptors is not None:
            members.append(Member(genome, result.fitness[k], tuple(result.descriptors), first + offset))
        else:
            members.append(Member(genome, None, None, first + offset, result.error or "no fitness"))
    return members


# The run -------------------------------------------------------------------------------------------------
class CompositionDirectory(RunFolder):
    """The paths of a composition run's folder."""

    def __init__(self, root: Path) -> None:
        super().__init__(root, EVALUATION_HEADER, PROGRESS_HEADER)
        self.cells = self.root / "cells.json"
        self.repertoire = self.root / "repertoire_compositions.json"

    def read_library(self, config: CompositionConfig) -> Library | None:
        """The run's copy of its primitive library (None without one), checked against the digest."""
        return self.read_library_copy(config.library_digest, str(self.library))


class CompositionRun(RunLoop[Genome, Member]):
    """One composition run; create with :meth:`start` or :meth:`resume`, then :meth:`execute`."""

    def __init__(
        self, config: CompositionConfig, cells: Sequence[Cell], root: Path, evaluator: Evaluator | None
    ) -> None:
        super().__init__()
        self.config = config
        self.cells = list(cells)
        self.directory: CompositionDirectory = CompositionDirectory(root)
        self.evaluator = evaluator
        self.rng = random.Random(derive_seed(config.seed, RUN_ALGORITHM))
        self.n_robots = config.world().n_robots
        self.produced = 0
        """Genomes produced after the initial population (what the budget counts)."""
        self.population: list[Member] = []
        """ga: the current population (empty before the initial one is evaluated)."""
        self.grid: dict[tuple[int, ...], Member] = {}
        """qd: the archive, one genome per bin."""
        self.best: Member | None = None
        """The fittest genome evaluated (the first among equals)."""
        self.known: dict[Genome, Member] = {}
        """Genomes evaluated by this process (fixed scenario: a genome's result never changes)."""

    # Construction ----------------------------------------------------------------------------------------
    @classmethod
    def start(
        cls,
        config: CompositionConfig,
        cells: Sequence[Cell],
        root: Path,
        evaluator: Evaluator,
        library: Library | None = None,
    ) -> CompositionRun:
        """A new run in ``root``, which must not hold a run already (``RunLoop._begin``): its configuration,
        its cells, its copy of the library, empty logs and first checkpoint."""
        if config.cells != len(cells) or config.cells_digest != cells_digest(cells):
            raise ConfigError("the configuration does not describe these cells")
        if config.library_digest != ("" if library is None else library.digest):
            raise ConfigError("the configuration does not describe this primitive library")
        files: dict[str, object] = {
            "config.json": config.to_json(),
            "cells.json": {"cells": [c.as_json() for c in cells]},
        }
        if library is not None:
            files["library.json"] = library.as_json()
        return cls._begin(
            CompositionDirectory(root), lambda building: cls(config, cells, building, evaluator), files
        )

    @classmethod
    def resume(cls, root: Path, evaluator: Evaluator | None) -> CompositionRun:
        """The run in ``root`` at its last checkpoint, its CSV files cut back to it (``RunLoop._reopen``)."""
        directory = CompositionDirectory(root)

        def load() -> CompositionRun:
            try:
                config = CompositionConfig.from_json(read_json_object(directory.config))
                cells = [Cell.from_json(c) for c in read_json_object(directory.cells)["cells"]]
                if len(cells) != config.cells or cells_digest(cells) != config.cells_digest:
                    raise RunDirectoryError(f"{directory.cells} is not the cell list the run started with")
                directory.read_library(config)  # the evaluator was made with it
                run = cls(config, cells, root, evaluator)
                state = directory.read_checkpoint()
                directory.check_logs()
                run.restore(state)
            except (ConfigError, KeyError, TypeError, ValueError) as error:
                raise RunDirectoryError(
                    f"{root}: the run cannot be continued, it is damaged: {error}"
                ) from error
            return run

        return cls._reopen(directory, load)

    # State -------------------------------------------------------------------------------------------------
    def checkpoint(self) -> None:
        """Write the checkpoint atomically (between batches only)."""
        version, internal, gauss = self.rng.getstate()
        self.directory.write_checkpoint(
            {
                "config": self.config.to_json(),
                "evaluations": self.evaluations,
                "produced": self.produced,
                "rng": [version, list(internal), gauss],
                "population": [m.as_json() for m in self.population],
                "grid": [self.grid[b].as_json() for b in sorted(self.grid)],
                "best": None if self.best is None else self.best.as_json(),
                "offsets": self.offsets,
            }
        )

    def restore(self, state: dict) -> None:
        """The run's state from its checkpoint (``checkpoint.json``); a ValueError or KeyError when it is
        damaged."""
        if CompositionConfig.from_json(state["config"]) != self.config:
            raise ValueError("the checkpoint belongs to another configuration than config.json")
        version, internal, gauss = state["rng"]
        self.rng.setstate((int(version), tuple(int(x) for x in internal), gauss))
        self.evaluations = integer(state["evaluations"], "evaluations", 0)
        self.produced = integer(state["produced"], "produced", 0)
        self.population = [Member.from_json(m) for m in state["population"]]
        members = [Member.from_json(m) for m in state["grid"]]
        self.grid = {bin_of(m.descriptors): m for m in members if m.descriptors is not None}
        self.best = None if state["best"] is None else Member.from_json(state["best"])
        for member in [*self.population, *members, *([self.best] if self.best else [])]:
            if len(member.genome) != self.n_robots or not all(
                0 <= c < len(self.cells) for c in member.genome
            ):
                raise ValueError(f"genome {list(member.genome)} is not {self.n_robots} cell indices")
        self.offsets = self.directory.read_offsets(state["offsets"])

    # Execution ---------------------------------------------------------------------------------------------
    @property
    def done(self) -> bool:
        return self.produced >= self.config.evaluations

    def progress(self) -> tuple[int, int]:
        return self.produced, self.config.evaluations

    def _ask(self) -> list[Genome]:
        """The next batch of genomes: the initial population, or offspring cut to the budget left."""
        p = self.config.parameters
        n = len(self.cells)
        if self.config.algorithm == "ga":
            if not self.population:
                return self._initial(p.population)
            parents = tournament(self.population, p.population - p.elites, p.tournament, self.rng)
        else:
            if not self.grid:  # the initial batch (again, if every genome of it failed)
                return self._initial(p.init_batch)
            entries = [self.grid[b] for b in sorted(self.grid)]
            parents = tournament(entries, p.batch, p.tournament, self.rng)
        children = vary(parents, self.rng, p.crossover, p.mutation, n)
        return children[: self.config.evaluations - self.produced]

    def _initial(self, size: int) -> list[Genome]:
        """``size`` genomes: the homogeneous swarms of the fittest cells asked for, then random ones."""
        seeded = homogeneous_genomes(self.cells, min(size, self.config.parameters.homogeneous), self.n_robots)
        drawn = [random_genome(self.rng, len(self.cells), self.n_robots) for _ in range(size - len(seeded))]
        return seeded + drawn

    def _tell(self, batch: list[Genome], answers: list[Member]) -> None:
        self._select(answers)
        self._record(answers)

    def _select(self, members: list[Member]) -> None:
        """The GA's next population, or the members kept in MAP-Elites' grid; the best so far."""
        initial = not self.population if self.config.algorithm == "ga" else not self.grid
        if not initial:
            self.produced += len(members)
        for member in members:
            if member.fitness is not None and (self.best is None or member.rank > self.best.rank):
                self.best = member
        if self.config.algorithm == "ga":
            if initial:
                self.population = members
            else:
                elites = sorted(self.population, key=lambda m: -m.rank)[: self.config.parameters.elites]
                self.population = elites + members
        else:
            for member in members:
                if member.descriptors is None or member.fitness is None:
                    continue
                index = bin_of(member.descriptors)
                held = self.grid.get(index)
                if held is None or member.fitness > held.rank:
                    self.grid[index] = member

    def _evaluate(self, genomes: list[Genome]) -> list[Member]:
        """The genomes evaluated on the run's scenario; a genome this process evaluated before is answered
        from memory (the same request, the same result)."""
        if self.evaluator is None:
            raise RunDirectoryError("this run was opened for reading: it has no evaluator")
        fresh = list(dict.fromkeys(g for g in genomes if g not in self.known))
        for member in evaluate_genomes(
            self.evaluator, self.cells, fresh, self.config.scenario_seed, self.config.trials, 0
        ):
            self.known[member.genome] = member
        return [
            Member(
                g, self.known[g].fitness, self.known[g].descriptors, self.evaluations + i, self.known[g].error
            )
            for i, g in enumerate(genomes)
        ]

    def _record(self, members: Sequence[Member]) -> None:
        rows = []
        for m in members:
            values = (
                [number(m.fitness), *(number(d) for d in m.descriptors)]
                if m.fitness is not None and m.descriptors is not None
                else [""] * (1 + len(DESCRIPTORS))
            )
            genome = " ".join(str(c) for c in m.genome)
            rows.append([str(m.evaluation), str(self.config.scenario_seed), genome, *values, m.error])
        self.evaluations += len(members)
        self.offsets["evaluations"] = self.directory.evaluations.append(rows)
        coverage = qd_score = ""
        if self.config.algorithm == "qd":
            coverage = number(len(self.grid) / 512)
            qd_score = number(math.fsum(m.rank for m in self.grid.values()) / 512)
        best = number(self.best.fitness) if self.best is not None else ""
        self.offsets["progress"] = self.directory.progress.append(
            [[str(self.evaluations), best, coverage, qd_score]]
        )

    # Results -----------------------------------------------------------------------------------------------
    def composition_json(self, member: Member) -> dict:
        return {
            "genome": list(member.genome),
            "fitness": member.fitness,
            "descriptors": None if member.descriptors is None else list(member.descriptors),
            "evaluation": member.evaluation,
            "trees": list(layout_of(member.genome, self.cells).trees),
        }

    def write_results(self) -> list[Path]:
        """``summary.json``, the best composition in ``best/``; for qd ``repertoire_compositions.json``."""
        directory = self.directory
        written = []
        summary: dict = {
            "run": self.config.label,
            "config": self.config.to_json(),
            "cells": len(self.cells),
            "evaluations": self.evaluations,
            "individuals_produced": self.produced,
            "finished": self.done,
            "best_fitness": None if self.best is None else self.best.fitness,
            "best": None,
        }
        if self.best is not None:
            best = self.composition_json(self.best)
            best["cells"] = [self.cells[k].as_json() for k in self.best.genome]
            summary["best"] = best
        if self.done and self.best is not None and self.evaluator is not None:
            seeds = [
                derive_seed(self.config.scenario_seed, RUN_HELDOUT, r) for r in range(HELDOUT_EVALUATIONS)
            ]
            scored = evaluate_genomes(
                self.evaluator, self.cells, [self.best.genome] * len(seeds), 0, self.config.trials, 0, seeds
            )
            values = [m.fitness for m in scored if m.fitness is not None]
            summary["heldout"] = {"seeds": seeds, "evaluations": len(seeds), "trials": self.config.trials}
            summary["heldout_best_fitness"] = (
                math.fsum(values) / len(values) if len(values) == len(seeds) else None
            )
        if self.config.algorithm == "qd":
            summary["coverage"] = len(self.grid) / 512
            summary["qd_score"] = math.fsum(m.rank for m in self.grid.values()) / 512
            summary["repertoire_size"] = len(self.grid)
            items = [{"bin": list(b), **self.composition_json(self.grid[b])} for b in sorted(self.grid)]
            write_json(
                directory.repertoire,
                {
                    "objective": OBJECTIVE,
                    "algorithm": self.config.algorithm,
                    "run": self.config.label,
                    "seed": self.config.seed,
                    "evaluations": self.evaluations,
                    "shape": [8, 8, 8],
                    "descriptors": list(DESCRIPTORS),
                    "coverage": summary["coverage"],
                    "qd_score": summary["qd_score"],
                    "repertoire_size": len(self.grid),
                    "items": items,
                },
            )
            written.append(directory.repertoire)
        write_json(directory.summary, summary)
        written.append(directory.summary)
        if self.best is not None:
            with writing(directory.best):  # a link planted in the run folder is refused, never followed
                make_folder(directory.best, directory.root)
            layout = layout_of(self.best.genome, self.cells)
            path = directory.best / f"{OBJECTIVE}_swarm.json"
            write_json(path, layout.as_json())
            written.append(path)
            for robot, tree in enumerate(layout.trees):
                path = directory.best / f"{OBJECTIVE}_robot{robot}.txt"
                write_atomic(path, tree + "\n")
                written.append(path)
        return written
