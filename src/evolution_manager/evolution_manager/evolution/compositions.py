"""Heterogeneous compositions: evolve which repertoire cell each robot of a swarm runs.

``evolve --task TASK --swarm-from RUN_DIR [RUN_DIR ...] --algorithm ga|qd|ascent`` (``docs/algorithms.md``,
"Heterogeneous compositions"); any task and objective (by default ``foraging``), binned by the paper's
behaviour space or by the deliveries of each food kind (``--descriptors``, ``descriptor_sets``).

The *cells* are the best tree of every filled bin of every repertoire file
found in the given run directories, listed in a fixed order (:func:`read_sources`): directory by directory
as given, then the objectives in ``OBJECTIVES`` order (``repertoire_<objective>.json``), then the bins
in index order. A *genome* is one cell index per robot (robot 0 first); it is evaluated as a heterogeneous
swarm (``swarm_sim.model.swarm_layout``) on the run's task, every evaluation on the run's scenario seed
(``fixed``, the authors' design) or on a scenario of its own (``fresh``; ``CompositionConfig.scenarios``).

``ga``: a population of ``population`` genomes; each generation keeps ``elites`` best and fills the rest with
tournament winners (``tournament``), varied pairwise by two-point crossover (probability ``crossover``) and
then each by mutation (probability ``mutation``), one of the authors' three (``ga/qd.py``; ``cell_mutation``):
``one`` robot's cell redrawn uniformly among the other cells; ``all``: each robot's cell, with probability
0.5, redrawn among every cell; ``axis``: each robot's cell moved along one descriptor axis of its source
repertoire, drawn uniformly, to a cell that shares the other two coordinates (kept when there is none).
``qd``: MAP-Elites over compositions: an 8x8x8 grid over the run's behaviour space (binned as every
repertoire of the project) holding one genome per bin, the fitter kept (under ``foraging_biased`` binned by
deliveries, the authors' rule: the one that delivers more of the preferred kind); ``init_batch`` random
genomes, then batches of ``batch`` genomes varied as above from tournament winners of the grid, or, with
``crossover_operator`` ``mix`` (after Mix-ME, Ingvarsson et al. 2023), each child with probability
``crossover`` made of two genomes of different bins drawn uniformly, each robot taking its cell from either,
then mutated as above. ``ascent``: coordinate ascent over the groups' cells (best responses, as in
cooperative coevolution), from the homogeneous swarm of the fittest cell by its recorded fitness; each batch
tries every other cell for one group, the others kept, and the fittest genome of the batch becomes the
incumbent when it is strictly fitter; the groups take turns in order, and the run ends when the budget is
spent or when every group's cell is its best response to the others (a turn of every group without a change:
the budget may be left unspent). Each batch's cells are tried in an order drawn from the run's generator, so
that a batch cut by the budget is not biased to low cell numbers; on one scenario only (``fixed``), where a
genome's fitness is the same at every evaluation. The budget (``evaluations``) counts the genomes produced
after the initial population, as every run's.

A run directory holds ``config.json``, ``cells.json`` (the run's copy of its cells, checked by digest),
``evaluations.csv`` (index, seed, genome as space-separated cell indices, the objective, the behaviour
space's measured values, error),
``progress.csv``, ``checkpoint.json`` (written atomically, with the lengths of the two CSV files and the
random generator's state); when the run ends ``summary.json`` (with the authors' QD score at 1, 2, 4 and 8
bins per axis, :func:`coarse_qd_scores`; the validated choice, ``validation``, of the run and of its
homogeneous baseline), ``best/<objective>_swarm.json`` (the best composition as a
swarm layout file, for ``evaluate --swarm``, ``trial --swarm``, ``animate --swarm``),
``best/<objective>_robot<i>.txt`` (its trees) and for ``qd`` ``repertoire_compositions.json``. A resumed
run cuts the CSV files back to its checkpoint and ends with the very bytes of an uninterrupted run.
"""

from __future__ import annotations

import dataclasses
import functools
import hashlib
import json
import math
import random
from collections.abc import Callable, Iterable, Sequence
from dataclasses import asdict, dataclass, field
from pathlib import Path

from bt_controller.draws import MAX_SEED, RUN_ALGORITHM, RUN_HELDOUT, derive_seed
from bt_controller.errors import TreeError
from bt_controller.language import Library, LibraryError, load_library, parse
from bt_controller.model_settings import PROFILES
from bt_controller.validate import integer
from evolution_manager.errors import ConfigError, RunDirectoryError
from evolution_manager.evolution.archive import Repertoire
from evolution_manager.evolution.descriptor_sets import (
    BEHAVIOUR,
    DELIVERY_SETS,
    DescriptorSet,
    checked_space,
    descriptor_set,
)
from evolution_manager.evolution.parameters import GPParameters, QDParameters
from evolution_manager.evolution.run_config import (
    DEFAULT_PROFILE,
    HELDOUT_EVALUATIONS,
    SCENARIOS,
    default_scenario_seed,
    scenario_of_evaluation,
)
from evolution_manager.evolution.run_folder import (
    COMPOSITIONS,
    CountedRun,
    EvaluatedGenome,
    RunFolder,
    generator_state,
    restore_generator,
)
from evolution_manager.evolution.validation import (
    best_distinct,
    choose_on_validation,
    validation_seeds,
    validation_settings,
)
from evolution_manager.files import (
    number,
    read_json_object,
    write_json,
)
from swarm_sim.evaluation import Evaluator, SwarmRequest
from swarm_sim.model import OBJECTIVES, Config, SwarmLayout
from swarm_sim.tasks import TaskSpec, resolve_task, task_from_record, task_named, task_to_record

KIND = COMPOSITIONS
"""``config.json``'s ``kind``: what tells a composition run from a tree run."""

ALGORITHMS: tuple[str, ...] = ("ga", "qd", "ascent")
DEFAULT_EVALUATIONS = {"ga": 1000, "qd": 1000, "ascent": 1000}
LABELS = {"ga": "GA_compositions", "qd": "QD_compositions", "ascent": "Ascent_compositions"}
OBJECTIVE = "foraging"
"""The objective a run evolves unless it names another (every run before multi-food tasks)."""
TASK = "foraging"
"""The task a run's configuration names when it names none (every run before multi-food tasks)."""
DESCRIPTORS = ("movement", "rotation", "conditionality")
CELL_MUTATIONS: tuple[str, ...] = ("one", "all", "axis")
"""The authors' three mutations of a genome (``ga/qd.py``), ``cell_mutation``'s values; ``one`` is theirs in
use and the default."""
CROSSOVERS: tuple[str, ...] = ("two-point", "mix")
"""How two genomes are crossed (``crossover_operator``): the authors' two-point crossover, or Mix-ME's mixing
of two archive bins' genomes (``qd`` only)."""
QD_SCORE_BINS: tuple[int, ...] = (1, 2, 4, 8)
"""The bins per axis at which the authors print a container's QD score (``utilities.py``)."""

MUTATION = 0.5
"""Probability that a child is mutated (one robot's cell redrawn): our choice, the probability of the GP's
point mutation (``replace`` 0.5 of ``GPParameters.mutations``), the operator that likewise swaps one part of
a genome for a random one."""

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
    cell_mutation: str = "one"
    """Which of :data:`CELL_MUTATIONS` a mutated child undergoes."""
    crossover_operator: str = "two-point"
    """Which of :data:`CROSSOVERS` makes children (``mix``: MAP-Elites only)."""
    groups: int = 0
    """K >= 2: the robots form K groups, robot i in group i mod K (a team's groups, and those of
    ``robots.carries``), every robot of a group running one cell: the search is over K cells, not one per
    robot. 0: a cell per robot (the authors')."""

    def __post_init__(self) -> None:
        if self.cell_mutation not in CELL_MUTATIONS:
            raise ConfigError(
                f"cell_mutation must be one of {', '.join(CELL_MUTATIONS)}, got {self.cell_mutation!r}"
            )
        if self.crossover_operator not in CROSSOVERS:
            raise ConfigError(
                f"crossover_operator must be one of {', '.join(CROSSOVERS)}, got {self.crossover_operator!r}"
            )
        integer(self.population, "population", 2, error=ConfigError)
        integer(self.homogeneous, "homogeneous", 0, error=ConfigError)
        integer(self.groups, "groups", 0, error=ConfigError)
        if self.groups == 1:
            raise ConfigError(
                "groups must be 0 (a cell per robot) or at least 2; one group is a homogeneous swarm"
            )
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


def mutate_all(genome: Genome, rng: random.Random, n_cells: int) -> Genome:
    """The genome with each robot's cell, with probability 0.5, redrawn uniformly among every cell (it may
    draw its own): the authors' ``mutateAllAxes``."""
    return tuple(rng.randrange(n_cells) if rng.random() < 0.5 else c for c in genome)


Neighbours = tuple[tuple[tuple[int, ...], ...], ...]
"""For each cell and descriptor axis, the cells one step along that axis: :func:`axis_neighbours`."""


def axis_neighbours(cells: Sequence[Cell]) -> Neighbours:
    """For each cell and each axis of its source repertoire's bin, the cells whose bins share every other
    coordinate and differ on that axis (cell order), whichever run or objective they come from."""
    return tuple(
        tuple(
            tuple(
                k
                for k, other in enumerate(cells)
                if len(other.bin) == len(cell.bin)
                and other.bin[axis] != cell.bin[axis]
                and all(other.bin[a] == cell.bin[a] for a in range(len(cell.bin)) if a != axis)
            )
            for axis in range(len(cell.bin))
        )
        for cell in cells
    )


def mutate_axis(genome: Genome, rng: random.Random, neighbours: Neighbours) -> Genome:
    """The genome with each robot's cell moved along one axis of its source repertoire, drawn uniformly, to a
    cell drawn uniformly among :func:`axis_neighbours` (kept when that axis has none): the authors'
    ``mutateOneAxis``."""
    moved = []
    for cell in genome:
        choices = neighbours[cell][rng.randrange(len(neighbours[cell]))] if neighbours[cell] else ()
        moved.append(choices[rng.randrange(len(choices))] if choices else cell)
    return tuple(moved)


def mix(a: Genome, b: Genome, rng: random.Random) -> Genome:
    """A child whose robot ``i`` runs the cell of robot ``i`` of ``a`` or of ``b``, each with probability 0.5:
    Mix-ME's mixing of two teams."""
    if len(a) != len(b):
        raise ValueError(f"mixing needs genomes of one length, got {len(a)}, {len(b)}")
    return tuple(x if rng.random() < 0.5 else y for x, y in zip(a, b, strict=True))


def vary(
    parents: Sequence[Genome],
    rng: random.Random,
    crossover: float,
    mutation: float,
    n_cells: int,
    mutator: Callable[[Genome, random.Random], Genome] | None = None,
) -> list[Genome]:
    """Offspring of ``parents`` (in order): consecutive pairs crossed with probability ``crossover``, then
    each child mutated with probability ``mutation`` (DEAP's ``varAnd`` order) by ``mutator`` (by default
    :func:`mutate`)."""
    children = list(parents)
    for k in range(1, len(children), 2):
        if rng.random() < crossover:
            children[k - 1], children[k] = two_point_crossover(children[k - 1], children[k], rng)
    change = mutator or (lambda genome, r: mutate(genome, r, n_cells))
    return [change(c, rng) if rng.random() < mutation else c for c in children]


class Member(EvaluatedGenome[Genome]):
    """An evaluated genome (its cell indices): the run's objective and the measured values of its axes."""

    @classmethod
    def _genome(cls, values: Sequence) -> Genome:
        return tuple(int(c) for c in values)


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
    """The 8x8x8 bin of a point in [0, 1]^3, as every repertoire of the project bins (``archive``)."""
    return _binner().bin_of(tuple(descriptors))


def coarse_qd_scores(
    scored: Iterable[tuple[Sequence[float], float]], bins: Sequence[int] = QD_SCORE_BINS
) -> dict[int, float]:
    """The authors' QD score of a container at ``k`` bins per axis, for each ``k`` of ``bins``: its points
    (in [0, 1]^3, each with its fitness) binned ``k`` per axis (the top edge into the last bin), the fittest
    of each bin kept, their fitnesses summed and divided by ``k`` cubed (``utilities.py``, the foraging
    description: no offset). Callers leave failed evaluations out."""
    entries = [(tuple(point), fitness) for point, fitness in scored]
    scores = {}
    for k in bins:
        integer(k, "bins per axis", 1)
        best: dict[tuple[int, ...], float] = {}
        for point, fitness in entries:
            index = tuple(min(k - 1, math.floor(x * k)) for x in point)
            best[index] = max(fitness, best.get(index, -math.inf))
        scores[k] = math.fsum(best.values()) / k ** len(entries[0][0]) if entries else 0.0
    return scores


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
    task: TaskSpec = field(default_factory=lambda: task_named(TASK))
    """The world every evaluation runs in (a name is taken for the registered task)."""
    objective: str = OBJECTIVE
    """What the run maximises: one of ``OBJECTIVES``."""
    descriptors: str = BEHAVIOUR.name
    """The behaviour space the grids bin compositions by (``descriptor_sets``)."""
    scenarios: str = "fixed"
    """``fixed``: every evaluation on the scenario seed (the authors' design); ``fresh``: evaluation ``i``
    on a scenario of its own (``run_config.evaluation_seed``), so that no swarm is chosen for one
    scenario's luck. The held-out, validation and baseline scenarios come from the scenario seed either
    way, so the two designs of one seed share them."""

    def __post_init__(self) -> None:
        if self.algorithm not in ALGORITHMS:
            raise ConfigError(f"compositions evolve with {' or '.join(ALGORITHMS)}, got {self.algorithm!r}")
        if isinstance(self.task, str):
            object.__setattr__(self, "task", resolve_task(self.task))
        if self.objective not in OBJECTIVES:
            raise ConfigError(f"objective must be one of {', '.join(OBJECTIVES)}, got {self.objective!r}")
        try:
            checked_space(self.descriptors, self.task, "swarms", "multifood-arena9-kind2")
        except ValueError as error:
            raise ConfigError(str(error)) from None
        if self.parameters.crossover_operator == "mix" and self.algorithm != "qd":
            raise ConfigError(
                "crossover_operator mix draws its parents from two bins of MAP-Elites' grid: it goes with "
                "algorithm qd"
            )
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
        if self.scenarios not in SCENARIOS:
            raise ConfigError(f"scenarios must be one of {', '.join(SCENARIOS)}, got {self.scenarios!r}")
        groups, robots = self.parameters.groups, self.world().n_robots
        if groups > robots:
            raise ConfigError(f"groups {groups}: the task has {robots} robots, so at most {robots} groups")
        if self.algorithm == "ascent":
            self._check_ascent()
        elif 0 < groups < 3 and self.parameters.crossover_operator == "two-point":
            raise ConfigError(
                f"groups {groups}: two-point crossover needs genomes of at least 3 cells; give at least 3 "
                "groups or crossover_operator mix"
            )

    def _check_ascent(self) -> None:
        """Refuse what coordinate ascent has no use for: other scenarios than the fixed one (it compares
        each genome with the incumbent's fitness) and the GA's seeds and operators."""
        if self.scenarios != "fixed":
            raise ConfigError(
                "algorithm ascent compares every genome with the incumbent on one scenario: it goes with "
                "scenarios fixed"
            )
        p = self.parameters
        for name, value in (
            ("homogeneous", p.homogeneous),
            ("cell_mutation", p.cell_mutation),
            ("crossover_operator", p.crossover_operator),
        ):
            if value != _PARAMETER_DEFAULTS[name]:
                raise ConfigError(
                    f"{name} {value!r}: algorithm ascent starts from the fittest cell's homogeneous swarm "
                    "and has no mutation or crossover; leave it out"
                )

    @property
    def label(self) -> str:
        return LABELS[self.algorithm]

    def world(self) -> Config:
        """The model of every evaluation: the run's task under its profile."""
        return self.task.config(self.profile)

    @property
    def space(self) -> DescriptorSet:
        """The behaviour space of the run's grids."""
        return descriptor_set(self.descriptors)

    def to_json(self) -> dict:
        data = {
            f.name: getattr(self, f.name) for f in dataclasses.fields(self) if f.name not in _NOT_IN_ORDER
        }
        data["sources"] = list(self.sources)
        data["parameters"] = asdict(self.parameters)
        # written only when asked for: the files of earlier runs stay as they were
        for name, default in _PARAMETER_DEFAULTS.items():
            if data["parameters"][name] == default:
                del data["parameters"][name]
        document = {"kind": KIND, "objective": self.objective, "task": task_to_record(self.task), **data}
        if self.descriptors != BEHAVIOUR.name:
            document["descriptors"] = self.descriptors
        if self.scenarios != "fixed":  # written only when asked for, as the descriptors
            document["scenarios"] = self.scenarios
        return document

    def evaluation_seed(self, index: int) -> int:
        """The scenario of evaluation ``index``: the scenario seed, or under fresh scenarios its own."""
        return scenario_of_evaluation(self.scenarios, self.scenario_seed, self.seed, index)

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
                task_from_record(data.get("task", TASK), "config.json: task"),
                str(data.get("objective", OBJECTIVE)),
                str(data.get("descriptors", BEHAVIOUR.name)),
                str(data.get("scenarios", "fixed")),
            )
        except (KeyError, TypeError, ValueError) as error:
            if isinstance(error, ConfigError):
                raise
            raise ConfigError(f"not a composition run's configuration: {error}") from error


_NOT_IN_ORDER = ("task", "objective", "descriptors", "scenarios")
"""Fields ``config.json`` writes elsewhere than in field order (they came later)."""
_PARAMETER_DEFAULTS = {
    "homogeneous": 0,
    "cell_mutation": "one",
    "crossover_operator": "two-point",
    "groups": 0,
}
"""The parameters ``config.json`` leaves out at these values, as runs made before them did not know them."""


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
    objective: str = OBJECTIVE,
    space: DescriptorSet = BEHAVIOUR,
) -> list[Member]:
    """Each genome evaluated as a heterogeneous swarm with ``seed`` (or genome ``i`` with ``seeds[i]``) over
    ``trials`` trials: its ``objective`` and its measured values of ``space``'s axes; evaluation indices from
    ``first``."""
    if not genomes:
        return []
    chosen = [seed] * len(genomes) if seeds is None else list(seeds)
    requests = [SwarmRequest(layout_of(g, cells), s, trials) for g, s in zip(genomes, chosen, strict=True)]
    results = evaluator.evaluate(requests)  # type: ignore[arg-type]  # BatchEvaluator takes swarm requests
    k = OBJECTIVES.index(objective)
    members = []
    for offset, (genome, result) in enumerate(zip(genomes, results, strict=True)):
        if result.error is None and result.fitness is not None and result.descriptors is not None:
            values = space.values(result.fitness, result.descriptors)
            members.append(Member(genome, result.fitness[k], values, first + offset))
        else:
            members.append(Member(genome, None, None, first + offset, result.error or "no fitness"))
    return members


# The run -------------------------------------------------------------------------------------------------
class CompositionDirectory(RunFolder):
    """The paths of a composition run's folder; its logs' columns name the run's objective and axes (by
    default those of the runs made before multi-food tasks)."""

    def __init__(self, root: Path, objective: str = OBJECTIVE, axes: Sequence[str] = DESCRIPTORS) -> None:
        super().__init__(
            root,
            ["evaluation", "seed", "genome", objective, *axes, "error"],
            ["evaluations", f"best_{objective}", "coverage", "qd_score"],
        )
        self.cells = self.root / "cells.json"
        self.repertoire = self.root / "repertoire_compositions.json"

    def read_library(self, config: CompositionConfig) -> Library | None:
        """The run's copy of its primitive library (None without one), checked against the digest."""
        return self.read_library_copy(config.library_digest, str(self.library))


def _directory(root: Path, config: CompositionConfig) -> CompositionDirectory:
    """The folder of ``config``'s run, its logs' columns named after its objective and axes."""
    return CompositionDirectory(root, config.objective, config.space.names)


def _preferred_axis(config: CompositionConfig) -> int | None:
    """The axis of the preferred food kind when the run bins by deliveries and maximises
    ``foraging_biased`` with a preferred kind (then a bin keeps the genome that delivers more of it, the
    authors' rule); None otherwise."""
    preferred = config.world().preferred_food
    if config.space not in DELIVERY_SETS or config.objective != "foraging_biased" or not preferred:
        return None
    return preferred - 1


class CompositionRun(CountedRun[Genome, Member]):
    """One composition run; create with :meth:`start` or :meth:`resume`, then :meth:`execute` (the loop
    every run shares, ``run_folder.RunLoop``, with what network and team runs share, ``CountedRun``)."""

    def __init__(
        self, config: CompositionConfig, cells: Sequence[Cell], root: Path, evaluator: Evaluator | None
    ) -> None:
        super().__init__()
        self.config: CompositionConfig = config
        self.cells = list(cells)
        self.directory: CompositionDirectory = _directory(root, config)
        self.evaluator = evaluator
        self.rng = random.Random(derive_seed(config.seed, RUN_ALGORITHM))
        self.n_robots = config.world().n_robots
        self.groups = config.parameters.groups or self.n_robots
        """The cells a genome chooses: one per group of robots (``groups``), or one per robot."""
        self.space = config.space
        self.neighbours = axis_neighbours(self.cells) if config.parameters.cell_mutation == "axis" else ()
        self.preferred = _preferred_axis(config)
        """The axis whose deliveries decide between two genomes of one bin, or None: by fitness."""
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
        self.incumbent: Member | None = None
        """ascent: the genome every batch varies one group's cell of (None before the first batch)."""
        self.turn = 0
        """ascent: the group whose cell the next batch varies."""
        self.settled = 0
        """ascent: how many groups in a row hold a best response to the others' cells; all of them, and
        the run has converged."""

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
            _directory(root, config), lambda building: cls(config, cells, building, evaluator), files
        )

    @classmethod
    def resume(cls, root: Path, evaluator: Evaluator | None) -> CompositionRun:
        """The run in ``root`` at its last checkpoint, its CSV files cut back to it (``RunLoop._reopen``)."""
        directory = CompositionDirectory(root)

        def build() -> CompositionRun:
            config = CompositionConfig.from_json(read_json_object(directory.config))
            cells = [Cell.from_json(c) for c in read_json_object(directory.cells)["cells"]]
            if len(cells) != config.cells or cells_digest(cells) != config.cells_digest:
                raise RunDirectoryError(f"{directory.cells} is not the cell list the run started with")
            directory.read_library(config)  # the evaluator was made with it
            return cls(config, cells, root, evaluator)

        return cls._resume(directory, build)

    # State -------------------------------------------------------------------------------------------------
    def _state(self) -> dict:
        return {
            "rng": generator_state(self.rng),
            "population": [m.as_json() for m in self.population],
            "grid": [self.grid[b].as_json() for b in sorted(self.grid)],
            "best": None if self.best is None else self.best.as_json(),
            # only ascent's: the checkpoints of the GA and MAP-Elites stay as they were
            **({"ascent": self._ascent_state()} if self.config.algorithm == "ascent" else {}),
        }

    def _ascent_state(self) -> dict:
        return {
            "incumbent": None if self.incumbent is None else self.incumbent.as_json(),
            "turn": self.turn,
            "settled": self.settled,
        }

    def _restore(self, state: dict) -> None:
        restore_generator(self.rng, state["rng"])
        self.population = [Member.from_json(m) for m in state["population"]]
        members = [Member.from_json(m) for m in state["grid"]]
        self.grid = {self._bin(m.descriptors): m for m in members if m.descriptors is not None}
        self.best = None if state["best"] is None else Member.from_json(state["best"])
        if self.config.algorithm == "ascent":
            ascent = state["ascent"]
            self.incumbent = None if ascent["incumbent"] is None else Member.from_json(ascent["incumbent"])
            self.turn = integer(ascent["turn"], "turn", 0, self.groups - 1, error=ValueError)
            self.settled = integer(ascent["settled"], "settled", 0, self.groups, error=ValueError)
        held = [self.best, self.incumbent]
        for member in [*self.population, *members, *(m for m in held if m is not None)]:
            if len(member.genome) != self.n_robots or not all(
                0 <= c < len(self.cells) for c in member.genome
            ):
                raise ValueError(f"genome {list(member.genome)} is not {self.n_robots} cell indices")
            if self._spread(self._roles(member.genome)) != member.genome:
                raise ValueError(f"genome {list(member.genome)} is not one cell per group of {self.groups}")

    # Execution ---------------------------------------------------------------------------------------------
    @property
    def done(self) -> bool:
        """Whether the budget is spent, or ascent has converged."""
        converged = self.config.algorithm == "ascent" and self.settled >= self.groups
        return converged or super().done

    def _ask(self) -> list[Genome]:
        """The next batch of genomes: the initial population, or offspring cut to the budget left."""
        p = self.config.parameters
        n = len(self.cells)
        if self.config.algorithm == "ascent":
            return self._turn()
        if self.config.algorithm == "ga":
            if not self.population:
                return self._initial(p.population)
            parents = tournament(self.population, p.population - p.elites, p.tournament, self.rng)
        else:
            if not self.grid:  # the initial batch (again, if every genome of it failed)
                return self._initial(p.init_batch)
            entries = [self.grid[b] for b in sorted(self.grid)]
            if p.crossover_operator == "mix":
                return self._mixed(entries)[: self.config.evaluations - self.produced]
            parents = tournament(entries, p.batch, p.tournament, self.rng)
        roles = [self._roles(g) for g in parents]
        children = vary(roles, self.rng, p.crossover, p.mutation, n, self._mutate)
        return [self._spread(c) for c in children[: self.config.evaluations - self.produced]]

    def _turn(self) -> list[Genome]:
        """ascent's next batch: the fittest cell's homogeneous swarm first; then the incumbent with the
        group of this turn running each other cell in turn, in a drawn order, cut to the budget left."""
        if self.incumbent is None:
            return homogeneous_genomes(self.cells, 1, self.n_robots)
        roles = self._roles(self.incumbent.genome)
        others = [c for c in range(len(self.cells)) if c != roles[self.turn]]
        self.rng.shuffle(others)
        return [
            self._spread((*roles[: self.turn], c, *roles[self.turn + 1 :]))
            for c in others[: self.config.evaluations - self.produced]
        ]

    def _roles(self, genome: Genome) -> Genome:
        """The cells a genome chooses, one per group (robot i runs cell ``i mod groups``): what the
        operators vary."""
        return genome[: self.groups]

    def _spread(self, roles: Genome) -> Genome:
        """The genome of one cell per robot whose groups run ``roles`` (the identity without groups)."""
        return tuple(roles[i % len(roles)] for i in range(self.n_robots))

    def _mixed(self, entries: Sequence[Member]) -> list[Genome]:
        """A batch after Mix-ME: each child, with probability ``crossover``, mixes two genomes of different
        bins drawn uniformly (:func:`mix`), else is a tournament winner; then mutated with probability
        ``mutation``."""
        p = self.config.parameters
        children = []
        for _ in range(p.batch):
            if len(entries) >= 2 and self.rng.random() < p.crossover:
                a, b = self.rng.sample(range(len(entries)), 2)
                child = mix(self._roles(entries[a].genome), self._roles(entries[b].genome), self.rng)
            else:
                child = self._roles(tournament(entries, 1, p.tournament, self.rng)[0])
            child = self._mutate(child, self.rng) if self.rng.random() < p.mutation else child
            children.append(self._spread(child))
        return children

    def _mutate(self, genome: Genome, rng: random.Random) -> Genome:
        """``genome`` under the run's mutation (``cell_mutation``)."""
        kind = self.config.parameters.cell_mutation
        if kind == "all":
            return mutate_all(genome, rng, len(self.cells))
        if kind == "axis":
            return mutate_axis(genome, rng, self.neighbours)
        return mutate(genome, rng, len(self.cells))

    def _bin(self, values: Sequence[float]) -> tuple[int, ...]:
        """The grid bin of a genome's measured values of the run's axes."""
        return bin_of(self.space.scaled(values))

    def _initial(self, size: int) -> list[Genome]:
        """``size`` genomes: the homogeneous swarms of the fittest cells asked for, then random ones."""
        seeded = homogeneous_genomes(self.cells, min(size, self.config.parameters.homogeneous), self.n_robots)
        drawn = [
            self._spread(random_genome(self.rng, len(self.cells), self.groups))
            for _ in range(size - len(seeded))
        ]
        return seeded + drawn

    def _tell(self, batch: list[Genome], answers: list[Member]) -> None:
        self._select(answers)
        self._record(answers)

    def _select(self, members: list[Member]) -> None:
        """The GA's next population, or the members kept in MAP-Elites' grid; the best so far."""
        initial = {
            "ga": not self.population, "qd": not self.grid, "ascent": self.incumbent is None
        }[self.config.algorithm]  # fmt: skip
        if not initial:
            self.produced += len(members)
        self._keep_best(members)
        if self.config.algorithm == "ascent":
            self._step(members, initial)
        elif self.config.algorithm == "ga":
            if initial:
                self.population = members
            else:
                elites = sorted(self.population, key=lambda m: -m.rank)[: self.config.parameters.elites]
                self.population = elites + members
        else:
            for member in members:
                if member.descriptors is None or member.fitness is None:
                    continue
                index = self._bin(member.descriptors)
                held = self.grid.get(index)
                if held is None or self._displaces(member, held):
                    self.grid[index] = member

    def _step(self, members: list[Member], initial: bool) -> None:
        """ascent: the incumbent after a batch (the fittest of it when strictly fitter), and the next turn."""
        scored = [m for m in members if m.fitness is not None]
        if initial:  # the homogeneous start (asked again if it failed)
            self.incumbent = scored[0] if scored else None
            return
        assert self.incumbent is not None
        challenger = fittest(scored) if scored else None
        if challenger is not None and challenger.rank > self.incumbent.rank:
            self.incumbent = challenger
            self.settled = 1
        else:
            self.settled += 1
        self.turn = (self.turn + 1) % self.groups

    def _displaces(self, member: Member, held: Member) -> bool:
        """Whether ``member`` takes the bin of ``held``: the fitter, or under a preferred kind the one that
        delivers more of it (the authors' grid)."""
        assert member.fitness is not None and member.descriptors is not None
        if self.preferred is None or held.descriptors is None:
            return member.fitness > held.rank
        return member.descriptors[self.preferred] > held.descriptors[self.preferred]

    def _evaluate(self, genomes: list[Genome]) -> list[Member]:
        """The genomes evaluated on the run's scenario; a genome this process evaluated before is answered
        from memory (the same request, the same result). Under fresh scenarios each on its own scenario,
        nothing remembered."""
        if self.evaluator is None:
            raise RunDirectoryError("this run was opened for reading: it has no evaluator")
        if self.config.scenarios == "fresh":
            seeds = [self.config.evaluation_seed(self.evaluations + i) for i in range(len(genomes))]
            return evaluate_genomes(
                self.evaluator,
                self.cells,
                genomes,
                0,
                self.config.trials,
                self.evaluations,
                seeds,
                self.config.objective,
                self.space,
            )
        fresh = list(dict.fromkeys(g for g in genomes if g not in self.known))
        for member in evaluate_genomes(
            self.evaluator,
            self.cells,
            fresh,
            self.config.scenario_seed,
            self.config.trials,
            0,
            objective=self.config.objective,
            space=self.space,
        ):
            self.known[member.genome] = member
        return [
            Member(
                g, self.known[g].fitness, self.known[g].descriptors, self.evaluations + i, self.known[g].error
            )
            for i, g in enumerate(genomes)
        ]

    def _record(self, members: Sequence[Member]) -> None:
        axes = len(self.space.names)
        rows = [
            [
                str(m.evaluation),
                str(self.config.evaluation_seed(m.evaluation)),
                " ".join(str(c) for c in m.genome),
                *m.logged(axes),
                m.error,
            ]
            for m in members
        ]
        self.evaluations += len(members)
        coverage = qd_score = ""
        if self.config.algorithm == "qd":
            coverage = number(len(self.grid) / 512)
            qd_score = number(math.fsum(m.rank for m in self.grid.values()) / 512)
        best = number(self.best.fitness) if self.best is not None else ""
        self._append_logs(rows, [str(self.evaluations), best, coverage, qd_score])

    # Results -----------------------------------------------------------------------------------------------
    def composition_json(self, member: Member) -> dict:
        return {
            "genome": list(member.genome),
            "fitness": member.fitness,
            "descriptors": None if member.descriptors is None else list(member.descriptors),
            "evaluation": member.evaluation,
            "trees": list(layout_of(member.genome, self.cells).trees),
        }

    def _heldout_seeds(self) -> list[int]:
        """The held-out scenarios: those of a tree run on the same scenario seed (``heldout_seed``)."""
        return [derive_seed(self.config.scenario_seed, RUN_HELDOUT, r) for r in range(HELDOUT_EVALUATIONS)]

    def _means_on(
        self, genomes: Sequence[Genome], seeds: Sequence[int]
    ) -> list[tuple[float | None, list[float] | None]]:
        """Each genome's mean objective and mean values of the run's axes over the scenarios ``seeds`` (None
        and None when one of its evaluations failed), all evaluated in one batch."""
        assert self.evaluator is not None
        scored = evaluate_genomes(
            self.evaluator,
            self.cells,
            [genome for genome in genomes for _ in seeds],
            0,
            self.config.trials,
            0,
            [seed for _ in genomes for seed in seeds],
            self.config.objective,
            self.space,
        )
        means: list[tuple[float | None, list[float] | None]] = []
        for start in range(0, len(scored), len(seeds)):
            own = scored[start : start + len(seeds)]
            if any(m.fitness is None or m.descriptors is None for m in own):
                means.append((None, None))
                continue
            fitness = math.fsum(m.rank for m in own) / len(own)
            axes = [math.fsum(m.descriptors[a] for m in own if m.descriptors) / len(own)
                    for a in range(len(self.space.names))]  # fmt: skip
            means.append((fitness, axes))
        return means

    def _heldout(self, genome: Genome) -> tuple[float | None, list[float] | None]:
        """``genome``'s mean objective and mean values of the run's axes over the held-out scenarios (None
        when an evaluation failed)."""
        return self._means_on([genome], self._heldout_seeds())[0]

    def _validated(self, scored: Iterable[tuple[Genome, float]]) -> dict | None:
        """The validated choice among ``scored`` (genomes with their fitness on the run's scenario, in the
        order the run met them; ``validation``): the best distinct candidates re-scored on the validation
        scenarios, the chosen one on the held-out scenarios. None when no candidate could be scored."""
        seeds = validation_seeds(self.config.scenario_seed)
        chosen = choose_on_validation(
            best_distinct(scored), lambda genomes: [f for f, _ in self._means_on(genomes, seeds)]
        )
        if chosen is None:
            return None
        heldout, axes = self._heldout(chosen.genome)
        return {
            "genome": list(chosen.genome),
            "trees": list(layout_of(chosen.genome, self.cells).trees),
            "fitness": chosen.fitness,
            "validation_fitness": chosen.validation_fitness,
            "heldout_best_fitness": heldout,
            "heldout_descriptors": axes,
            "candidates": [
                {"genome": list(genome), "fitness": fitness, "validation_fitness": validation}
                for genome, fitness, validation in chosen.candidates
            ],
        }

    def _scored_rows(self) -> list[dict[str, str]]:
        """The rows of ``evaluations.csv``, every genome the run evaluated in evaluation order, failed
        evaluations left out: what the validated choice and the evaluated QD scores are computed from."""
        return [row for row in self.directory.evaluations.read() if row[self.config.objective] != ""]

    def _scored_genomes(self, rows: Sequence[dict[str, str]]) -> list[tuple[Genome, float]]:
        """Each evaluated genome (``_scored_rows``) with its fitness."""
        return [
            (tuple(int(c) for c in row["genome"].split()), float(row[self.config.objective])) for row in rows
        ]

    def _homogeneous_baseline(self) -> dict | None:
        """The best homogeneous swarm of the run's cells, what a composition has to beat: every cell's nine
        copies on the run's scenario, the fittest (the first in cell order among equals) re-scored on the
        held-out scenarios. None when no cell could be evaluated."""
        assert self.evaluator is not None
        genomes = [(c,) * self.n_robots for c in range(len(self.cells))]
        members = evaluate_genomes(
            self.evaluator,
            self.cells,
            genomes,
            self.config.scenario_seed,
            self.config.trials,
            0,
            objective=self.config.objective,
            space=self.space,
        )
        scored = [m for m in members if m.fitness is not None]
        if not scored:
            return None
        best = fittest(scored)
        heldout, axes = self._heldout(best.genome)
        validated = self._validated((m.genome, m.rank) for m in scored)
        if validated is not None:
            validated = {"cell": validated["genome"][0], "tree": validated["trees"][0], **validated}
        return {
            "cell": best.genome[0],
            "tree": self.cells[best.genome[0]].tree,
            "fitness": best.fitness,
            "descriptors": None if best.descriptors is None else list(best.descriptors),
            "heldout_best_fitness": heldout,
            "heldout_descriptors": axes,
            "validated": validated,
        }

    def _evaluated(self, rows: Sequence[dict[str, str]]) -> list[tuple[tuple[float, ...], float]]:
        """Each evaluated genome (``_scored_rows``) at its point of the run's behaviour space, with its
        fitness."""
        axes = self.space.names
        return [
            (self.space.scaled([float(row[a]) for a in axes]), float(row[self.config.objective]))
            for row in rows
        ]

    def write_results(self) -> list[Path]:
        """``summary.json``, the best composition in ``best/``; for qd ``repertoire_compositions.json``."""
        directory = self.directory
        rows = self._scored_rows()  # read once, for the validated choice and the evaluated QD scores
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
            seeds = self._heldout_seeds()
            summary["heldout"] = {"seeds": seeds, "evaluations": len(seeds), "trials": self.config.trials}
            summary["heldout_best_fitness"], summary["heldout_descriptors"] = self._heldout(self.best.genome)
            summary["validation"] = validation_settings(self.config.scenario_seed, self.config.trials)
            summary["validated"] = self._validated(self._scored_genomes(rows))
            summary["homogeneous"] = self._homogeneous_baseline()
        if self.config.algorithm == "qd":
            summary["coverage"] = len(self.grid) / 512
            summary["qd_score"] = math.fsum(m.rank for m in self.grid.values()) / 512
            archive = [
                (self.space.scaled(m.descriptors), m.rank)
                for m in self.grid.values()
                if m.descriptors is not None
            ]
            summary["qd_scores_archive"] = _by_bins(coarse_qd_scores(archive))
            summary["repertoire_size"] = len(self.grid)
            items = [{"bin": list(b), **self.composition_json(self.grid[b])} for b in sorted(self.grid)]
            write_json(
                directory.repertoire,
                {
                    "objective": self.config.objective,
                    "algorithm": self.config.algorithm,
                    "run": self.config.label,
                    "seed": self.config.seed,
                    "evaluations": self.evaluations,
                    "shape": [8, 8, 8],
                    "descriptors": list(self.space.names),
                    "coverage": summary["coverage"],
                    "qd_score": summary["qd_score"],
                    "repertoire_size": len(self.grid),
                    "items": items,
                },
            )
            written.append(directory.repertoire)
        summary["qd_scores_evaluated"] = _by_bins(coarse_qd_scores(self._evaluated(rows)))
        write_json(directory.summary, summary)
        written.append(directory.summary)
        if self.best is not None:
            layout = layout_of(self.best.genome, self.cells)
            written += directory.write_best_swarm(
                self.config.objective, layout.as_json(), layout.trees, "robot"
            )
        return written


def _by_bins(scores: dict[int, float]) -> dict[str, float]:
    """QD scores keyed as JSON keeps them: the bins per axis as text."""
    return {str(k): v for k, v in scores.items()}
