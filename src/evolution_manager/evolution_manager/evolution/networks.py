"""Optimisers over a neural controller's 56 weights (``bt_controller.interpreters.network``, issue 37): CMA-ES
with pycma, the authors' GA with DEAP's operators and MAP-Elites with pyribs, as ask/tell objects, and a run
of any of them with its run directory.

``evolve --algorithm nn-cmaes|nn-ga|nn-qd --objective O [--task T] --evaluations N --seed S --out DIR``
(``--resume``; ``docs/algorithms.md``, "Networks"). Every network of a run is evaluated on the run's scenario
seed, as a tree run under ``--scenarios fixed``, and the run keeps the fittest network evaluated (the authors
keep the best individual so far rather than an elite, 6709a35).

``nn-cmaes`` (``WeightCmaEs``): pycma's ``CMAEvolutionStrategy`` at the authors' settings, centroid 0 on all
56 weights, step size 1, 25 samples per generation, no bounds, no rounding; it minimises, so it is told the
negated fitness. The authors use DEAP's ``cma.Strategy``; pycma, Hansen's reference implementation, differs in
ways that matter (see the class). ``nn-ga`` (``WeightGA``): the authors' GA: 25 weight vectors drawn uniformly
in [-5, 5], each generation the 3 best kept and 22 tournament winners (size 3) varied as DEAP's ``varAnd``:
pairwise two-point crossover with probability 0.5, then each child with probability 0.5 a Gaussian mutation
(mean 0, sigma 5, each weight with probability 0.05); weights rounded to 2 decimals. ``nn-qd``
(``WeightMapElites``): MAP-Elites over the weights with pyribs's CMA-ME (5 CMA-ES emitters of 10 samples,
each ranked by improvement of the archive, from centroid 0 and step size 1) on the paper's descriptors, an
8 x 8 x 8 grid over [0, 1]^3. Why pyribs rather than qdpy (the trees' MAP-Elites): its emitters are built for
continuous genomes (CMA-ME, CMA-MAE), it is maintained and typed, and its archive and emitters take explicit
seeds; qdpy's continuous operators are the plain Gaussian and polynomial mutations of 2019-era MAP-Elites.

Every run also keeps its networks on a grid of its own, binned as every repertoire of the project
(``archive.Repertoire``: movement, rotation, conditionality, 8 bins each), the fittest per bin: its coverage
(filled bins / 512) and QD score (the sum of each bin's best / 512) are what a tree run reports. A network
ticks no condition node, so its conditionality is 0 and only the 64 bins of the first conditionality slice
can be filled: coverage is at most 0.125 (issue 37's comparison of repertoires must say so).

Each optimiser takes its generator from the caller (a ``numpy.random.Generator`` for CMA-ES, whose sampling
it replaces pycma's ``np.random.randn`` with; a ``random.Random`` for the GA, drawn from exactly as DEAP's
operators draw from the ``random`` module, so ``cx_two_point``, ``mut_gaussian`` and ``sel_tournament`` give
DEAP's results for the same generator state; ``test_networks.py`` checks it). The budget counts the networks
produced: every sample of CMA-ES, and the GA's offspring after its initial population (as a tree run's).

A run directory is a run folder as every run's (``run_folder``; ``NetworkRun`` executes the shared
``RunLoop``): ``config.json`` (``"kind": "networks"``), ``evaluations.csv`` (evaluation, seed, the network's
56 weights space-separated, the objective, the descriptors, error), ``progress.csv``, ``checkpoint.json``
(atomic, with the lengths of the CSV files), and when the run ends ``summary.json`` (with the best network's
held-out fitness: its mean over the five held-out scenarios a tree run's best tree is re-scored on),
``repertoire_<objective>.json`` and ``best/<objective>.json`` (the best network, ``{"weights": [...]}``, for
``evaluate --network``, ``trial --network`` and ``animate --network``). The GA's checkpoint holds its
population and generator state; CMA-ES's its generator's starting state and the fitness told at every
generation, from which a resume rebuilds the strategy exactly (no pickle: a checkpoint is plain JSON). A
resumed run ends with the very bytes of an uninterrupted one.
"""

from __future__ import annotations

import math
import random
from collections.abc import Mapping, Sequence
from contextlib import AbstractContextManager
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
from threadpoolctl import threadpool_limits

from bt_controller.draws import MAX_SEED, RUN_ALGORITHM, derive_seed
from bt_controller.interpreters import N_WEIGHTS, Network, network_document
from bt_controller.interpreters import network_text as to_text
from bt_controller.model_settings import PROFILES
from bt_controller.validate import integer
from evolution_manager.errors import ConfigError, RunDirectoryError
from evolution_manager.evolution.compositions import bin_of
from evolution_manager.evolution.run_config import (
    DEFAULT_PROFILE,
    HELDOUT_EVALUATIONS,
    default_scenario_seed,
    heldout_seed,
)
from evolution_manager.evolution.run_folder import (
    NETWORKS,
    CountedRun,
    EvaluatedGenome,
    RunFolder,
    generator_state,
    restore_generator,
)
from evolution_manager.files import number, read_json_object, write_json
from swarm_ros.safe_paths import make_folder
from swarm_sim.core import world
from swarm_sim.evaluation import EvaluationRequest, Evaluator
from swarm_sim.model import Config
from swarm_sim.tasks import task_named

KIND = NETWORKS
"""``config.json``'s ``kind``: what tells a network run from a tree or composition run."""
ALGORITHMS: tuple[str, ...] = ("nn-cmaes", "nn-ga", "nn-qd")
GRID_BINS = 8 * 8 * 8
"""Bins of a repertoire grid (``archive.GRID_SHAPE``)."""
DESCRIPTORS = ("movement", "rotation", "conditionality")
FAILED = -1.0
"""The fitness a network whose evaluation failed is ranked with: below every real fitness."""


@dataclass(frozen=True)
class NetworkParameters:
    """The optimisers' settings (the authors', ``docs/model.md`` section 9 via ``multifood.md``)."""

    population: int = 25
    sigma: float = 1.0
    """CMA-ES: the initial step size (its centroid is 0)."""
    tournament: int = 3
    elites: int = 3
    crossover: float = 0.5
    mutation: float = 0.5
    """GA: probability that a child is mutated."""
    gene_probability: float = 0.05
    """GA: probability that a mutation changes each weight."""
    mutation_sigma: float = 5.0
    init_low: float = -5.0
    init_high: float = 5.0
    decimals: int = 2
    """GA: weights rounded to this many decimals after initialisation and variation."""
    emitters: int = 5
    """MAP-Elites: CMA-ME emitters."""
    emitter_batch: int = 10
    """MAP-Elites: samples per emitter and batch (5 x 10: the trees' MAP-Elites batch of 50)."""

    def __post_init__(self) -> None:
        integer(self.population, "population", 2, error=ConfigError)
        integer(self.tournament, "tournament", 1, error=ConfigError)
        integer(self.elites, "elites", 0, self.population - 1, error=ConfigError)
        integer(self.decimals, "decimals", 0, 15, error=ConfigError)
        integer(self.emitters, "emitters", 1, error=ConfigError)
        integer(self.emitter_batch, "emitter_batch", 2, error=ConfigError)
        for name in ("crossover", "mutation", "gene_probability"):
            if not 0.0 <= getattr(self, name) <= 1.0:
                raise ConfigError(f"{name} must be a probability in [0, 1], got {getattr(self, name)}")
        if not self.sigma > 0 or not self.mutation_sigma > 0 or not self.init_low < self.init_high:
            raise ConfigError("sigma and mutation_sigma must be positive and init_low < init_high")


# DEAP's operators with an explicit generator ---------------------------------------------------------------
def cx_two_point(a: list[float], b: list[float], rng: random.Random) -> None:
    """DEAP's ``cxTwoPoint`` in place, drawing from ``rng``: the segment between two cut points (the first in
    1..n, the second in 1..n-1, moved past the first when not below it) is exchanged."""
    size = min(len(a), len(b))
    one = rng.randint(1, size)
    two = rng.randint(1, size - 1)
    if two >= one:
        two += 1
    else:
        one, two = two, one
    a[one:two], b[one:two] = b[one:two], a[one:two]


def mut_gaussian(
    weights: list[float], mu: float, sigma: float, probability: float, rng: random.Random
) -> None:
    """DEAP's ``mutGaussian`` in place, drawing from ``rng``: each weight, with ``probability``, gets a
    Gaussian step (one uniform draw per weight, a Gaussian draw only for those changed)."""
    for i in range(len(weights)):
        if rng.random() < probability:
            weights[i] += rng.gauss(mu, sigma)


def sel_tournament(fitness: Sequence[float], count: int, size: int, rng: random.Random) -> list[int]:
    """DEAP's ``selTournament`` over indices, drawing from ``rng``: ``count`` winners, each the fittest of
    ``size`` drawn with replacement (the first drawn among equals, as ``max`` keeps it)."""
    chosen = []
    indices = range(len(fitness))
    for _ in range(count):
        aspirants = [rng.choice(indices) for _ in range(size)]
        chosen.append(max(aspirants, key=lambda k: fitness[k]))
    return chosen


def sel_best(fitness: Sequence[float], count: int) -> list[int]:
    """DEAP's ``selBest`` over indices: the ``count`` fittest, fittest first (a stable sort: earlier first
    among equals)."""
    return sorted(range(len(fitness)), key=lambda k: fitness[k], reverse=True)[:count]


# The optimisers --------------------------------------------------------------------------------------------
class WeightGA:
    """The authors' GA over weights (module docstring), ask/tell over weight vectors."""

    name = "nn-ga"

    def __init__(self, parameters: NetworkParameters, rng: random.Random) -> None:
        self.p = parameters
        self.rng = rng
        self.population: list[list[float]] = []
        self.fitness: list[float] = []
        self._asked: list[list[float]] | None = None

    def _round(self, weights: list[float]) -> list[float]:
        return [round(w, self.p.decimals) for w in weights]

    def ask(self) -> list[list[float]]:
        """The initial population, or a generation's offspring (the elites are not asked again)."""
        p = self.p
        if not self.population:
            batch = [self._round([self.rng.uniform(p.init_low, p.init_high) for _ in range(N_WEIGHTS)])
                     for _ in range(p.population)]  # fmt: skip
        else:
            winners = sel_tournament(self.fitness, p.population - p.elites, p.tournament, self.rng)
            batch = [list(self.population[k]) for k in winners]
            for i in range(1, len(batch), 2):  # DEAP's varAnd: crossover pairwise, then mutation
                if self.rng.random() < p.crossover:
                    cx_two_point(batch[i - 1], batch[i], self.rng)
            for child in batch:
                if self.rng.random() < p.mutation:
                    mut_gaussian(child, 0.0, p.mutation_sigma, p.gene_probability, self.rng)
            batch = [self._round(child) for child in batch]
        self._asked = batch
        return [list(w) for w in batch]

    def tell(
        self, fitness: Sequence[float], descriptors: Sequence[Sequence[float] | None] | None = None
    ) -> None:
        """The fitness of the asked batch, in order (``FAILED`` for a failed evaluation); the descriptors are
        not used."""
        if self._asked is None or len(fitness) != len(self._asked):
            raise ValueError("tell() needs one fitness per network of the last ask()")
        if self.population:
            elites = sel_best(self.fitness, self.p.elites)
            self.population = [self.population[k] for k in elites] + self._asked
            self.fitness = [self.fitness[k] for k in elites] + [float(f) for f in fitness]
        else:
            self.population, self.fitness = self._asked, [float(f) for f in fitness]
        self._asked = None

    def initial(self) -> bool:
        """Whether the next ask is the initial population (not counted in the budget)."""
        return not self.population

    def to_state(self) -> dict:
        return {
            "rng": generator_state(self.rng),
            "population": self.population,
            "fitness": self.fitness,
        }

    def restore(self, state: dict) -> None:
        restore_generator(self.rng, state["rng"])
        self.population = [[float(w) for w in weights] for weights in state["population"]]
        self.fitness = [float(f) for f in state["fitness"]]
        if len(self.population) != len(self.fitness) or any(len(w) != N_WEIGHTS for w in self.population):
            raise ValueError(f"the population is not networks of {N_WEIGHTS} weights with a fitness each")


class _Randn:
    """pycma's ``randn`` option (``randn(*shape)``, as ``np.random.randn``) from a passed-in generator."""

    def __init__(self, rng: np.random.Generator) -> None:
        self.rng = rng

    def __call__(self, *shape: int) -> np.ndarray:
        return self.rng.standard_normal(shape)


class _Replayed:
    """An optimiser whose state is its generator's starting state and what it was told, batch by batch
    (``told``): a checkpoint holds both, and a resume rebuilds the optimiser by replaying them, each ask
    drawing as it first did (no pickle: a checkpoint is plain JSON)."""

    rng: np.random.Generator
    start: Mapping[str, Any]
    told: list

    def initial(self) -> bool:
        """Never an uncounted initial batch: every sample counts."""
        return False

    def to_state(self) -> dict:
        return {"start": self.start, "told": self.told}

    def restore(self, state: dict) -> None:
        """Rebuild the optimiser from the generator's starting state and what it was told."""
        start = state["start"]
        if start.get("bit_generator") != self.rng.bit_generator.state["bit_generator"]:
            raise ValueError("the checkpoint's generator is not this run's")
        self.rng.bit_generator.state = start
        self.start = start
        self.told = []
        self._fresh()
        for told in state["told"]:
            self.ask()
            self._tell_again(told)

    def ask(self) -> list[list[float]]:
        raise NotImplementedError

    def _fresh(self) -> None:
        """The optimiser as new, drawing from the generator as it stands."""
        raise NotImplementedError

    def _tell_again(self, told: list) -> None:
        """Tell one batch's entry of ``told`` again."""
        raise NotImplementedError


class WeightCmaEs(_Replayed):
    """CMA-ES over the 56 weights with pycma (``cma``), ask/tell over weight vectors.

    Where pycma (4.x, Hansen's reference implementation) differs from DEAP's ``cma.Strategy``, which the
    authors use: pycma's defaults follow Hansen's 2016 tutorial: active CMA (the worst samples enter the
    covariance update with negative weights) where DEAP's update uses the mu best only, and the 2016 learning
    rates and step-size damping; it updates the eigendecomposition lazily, reacts to flat fitness (many
    networks score alike, common on foraging) by enlarging the step size with a warning, and keeps its own
    stopping rules, which this run ignores (the budget ends a run). Both sample centroid + sigma x B D z with
    the same positive recombination weights over the best half. Sampling draws from the passed-in generator
    (pycma's ``randn`` option), so pycma never touches numpy's global generator.
    """

    name = "nn-cmaes"

    def __init__(self, parameters: NetworkParameters, rng: np.random.Generator) -> None:
        self.p = parameters
        self.rng = rng
        self.start = rng.bit_generator.state
        """The generator's state before the first sample: with ``told``, what rebuilds the strategy."""
        self.told: list[list[float]] = []
        """The fitness told at each generation."""
        self._asked: np.ndarray | None = None
        self.es = self._strategy()

    def _strategy(self) -> object:
        import cma  # (pycma: imported only by network runs)

        options = {
            "popsize": self.p.population,
            "randn": _Randn(self.rng),
            "verbose": -9,
            "verb_log": 0,
            "verb_disp": 0,
            "seed": np.nan,
        }
        return cma.CMAEvolutionStrategy(np.zeros(N_WEIGHTS), self.p.sigma, options)

    def ask(self) -> list[list[float]]:
        """One generation's samples."""
        self._asked = np.array(self.es.ask())  # type: ignore[attr-defined]  # es is typed object: pycma loads late
        return [[float(w) for w in row] for row in self._asked]

    def tell(
        self, fitness: Sequence[float], descriptors: Sequence[Sequence[float] | None] | None = None
    ) -> None:
        """The fitness of the asked samples, in order (pycma is told their negation: it minimises); the
        descriptors are not used."""
        if self._asked is None or len(fitness) != len(self._asked):
            raise ValueError("tell() needs one fitness per network of the last ask()")
        told = [float(f) for f in fitness]
        self.es.tell(list(self._asked), [-f for f in told])  # type: ignore[attr-defined]  # typed object: pycma loads late
        self.told.append(told)
        self._asked = None

    def _fresh(self) -> None:
        self.es = self._strategy()

    def _tell_again(self, told: list) -> None:
        self.tell([float(f) for f in told])


class WeightMapElites(_Replayed):
    """MAP-Elites over the weights with pyribs (``ribs``): CMA-ME, ``emitters`` CMA-ES emitters ranked by
    improvement ("2imp"), restarting when they stop improving, on an 8 x 8 x 8 ``GridArchive`` of the
    descriptors over [0, 1]^3 (module docstring). The archive's and emitters' seeds are drawn from the
    passed-in generator. A checkpoint keeps the generator's starting state and every batch's fitness and
    descriptors; a resume replays them, as ``WeightCmaEs``. A failed evaluation (never expected of a network)
    is told as the worst fitness at descriptors (0, 0, 0).
    """

    name = "nn-qd"

    def __init__(self, parameters: NetworkParameters, rng: np.random.Generator) -> None:
        self.p = parameters
        self.rng = rng
        self.start = rng.bit_generator.state
        self.told: list[list[list[float]]] = []
        """Per batch: the fitness, then the descriptors of each network."""
        self._asked: np.ndarray | None = None
        self.scheduler = self._scheduler()

    def _scheduler(self) -> object:
        from ribs.archives import GridArchive  # (pyribs: imported only by network runs)
        from ribs.emitters import EvolutionStrategyEmitter
        from ribs.schedulers import Scheduler

        seeds = [int(s) for s in self.rng.integers(0, 2**62, size=1 + self.p.emitters)]
        archive = GridArchive(solution_dim=N_WEIGHTS, dims=(8, 8, 8), ranges=[(0.0, 1.0)] * 3, seed=seeds[0])
        emitters = [
            EvolutionStrategyEmitter(
                archive,
                x0=np.zeros(N_WEIGHTS),
                sigma0=self.p.sigma,
                ranker="2imp",
                batch_size=self.p.emitter_batch,
                seed=seed,
            )
            for seed in seeds[1:]
        ]
        return Scheduler(archive, emitters)

    def ask(self) -> list[list[float]]:
        self._asked = np.asarray(self.scheduler.ask())  # type: ignore[attr-defined]  # typed object: pyribs loads late
        return [[float(w) for w in row] for row in self._asked]

    def tell(
        self, fitness: Sequence[float], descriptors: Sequence[Sequence[float] | None] | None = None
    ) -> None:
        """The fitness and descriptors of the asked batch, in order (None descriptors: a failed one)."""
        if self._asked is None or len(fitness) != len(self._asked):
            raise ValueError("tell() needs one fitness per network of the last ask()")
        if descriptors is None or len(descriptors) != len(fitness):
            raise ValueError("MAP-Elites needs the descriptors of every network")
        told = [float(f) for f in fitness]
        measures = [[float(d) for d in (m if m is not None else (0.0, 0.0, 0.0))] for m in descriptors]
        self.scheduler.tell(np.array(told), np.array(measures))  # type: ignore[attr-defined]  # typed object: pyribs loads late
        self.told.append([told, *measures])
        self._asked = None

    def _fresh(self) -> None:
        self.scheduler = self._scheduler()

    def _tell_again(self, told: list) -> None:
        self.tell(told[0], told[1:])


Optimiser = WeightGA | WeightCmaEs | WeightMapElites


def make_optimiser(algorithm: str, parameters: NetworkParameters, seed: int) -> Optimiser:
    """The optimiser of ``algorithm`` with its generator seeded from the run's ``seed``."""
    algorithm_seed = derive_seed(seed, RUN_ALGORITHM)
    if algorithm == "nn-qd":
        return WeightMapElites(parameters, np.random.default_rng(algorithm_seed))
    if algorithm == "nn-ga":
        return WeightGA(parameters, random.Random(algorithm_seed))
    if algorithm == "nn-cmaes":
        return WeightCmaEs(parameters, np.random.default_rng(algorithm_seed))
    raise ConfigError(f"networks evolve with {' or '.join(ALGORITHMS)}, got {algorithm!r}")


# The run ---------------------------------------------------------------------------------------------------
@dataclass(frozen=True)
class NetworkConfig:
    """One network run (``config.json``)."""

    algorithm: str
    objective: str
    evaluations: int
    seed: int
    trials: int = 10
    profile: str = DEFAULT_PROFILE
    task: str = "primitives"
    scenario_seed: int = -1
    """-1: derived from ``seed`` as every run's (``run_config.default_scenario_seed``)."""
    parameters: NetworkParameters = field(default_factory=NetworkParameters)

    def __post_init__(self) -> None:
        if self.algorithm not in ALGORITHMS:
            raise ConfigError(f"networks evolve with {' or '.join(ALGORITHMS)}, got {self.algorithm!r}")
        if self.objective not in world.OBJECTIVES:
            raise ConfigError(
                f"objective must be one of {', '.join(world.OBJECTIVES)}, got {self.objective!r}"
            )
        integer(self.evaluations, "evaluations", 1, error=ConfigError)
        integer(self.seed, "seed", 0, MAX_SEED, error=ConfigError)
        integer(self.trials, "trials", 1, error=ConfigError)
        if self.profile not in PROFILES:
            raise ConfigError(f"profile must be one of {', '.join(PROFILES)}, got {self.profile!r}")
        task_named(self.task)  # a registered task (ValueError otherwise)
        if self.scenario_seed == -1:
            object.__setattr__(self, "scenario_seed", default_scenario_seed(self.seed))
        integer(self.scenario_seed, "the scenario seed", 0, MAX_SEED, error=ConfigError)

    @property
    def label(self) -> str:
        return self.algorithm

    def world(self) -> Config:
        """The model of every evaluation: the task's, under the run's profile."""
        return task_named(self.task).config(self.profile)

    def heldout_seeds(self) -> list[int]:
        """The seeds of the best network's held-out evaluations, as a tree run's (``heldout``)."""
        return [heldout_seed(self.scenario_seed, repeat) for repeat in range(HELDOUT_EVALUATIONS)]

    def to_json(self) -> dict:
        return {"kind": KIND, **asdict(self)}

    @classmethod
    def from_json(cls, data: dict) -> NetworkConfig:
        if data.get("kind") != KIND:
            raise ConfigError("not a network run's configuration")
        fields = {k: v for k, v in data.items() if k != "kind"}
        fields["parameters"] = NetworkParameters(**fields["parameters"])
        return cls(**fields)


class Evaluated(EvaluatedGenome[tuple[float, ...]]):
    """One evaluated network: its weights (``"weights"`` in JSON, where a success's error is null)."""

    GENOME = "weights"
    FAILED = FAILED

    @classmethod
    def _genome(cls, values: Sequence) -> tuple[float, ...]:
        return tuple(float(w) for w in values)

    def as_json(self) -> dict:
        return {**super().as_json(), "error": self.error or None}


EVALUATION_HEADER = ["evaluation", "seed", "weights", "fitness", *DESCRIPTORS, "error"]
PROGRESS_HEADER = ["evaluations", "best_fitness", "coverage", "qd_score"]


class NetworkDirectory(RunFolder):
    """The paths of a network run's folder."""

    def __init__(self, root: Path) -> None:
        super().__init__(root, EVALUATION_HEADER, PROGRESS_HEADER)

    def repertoire(self, objective: str) -> Path:
        return self.root / f"repertoire_{objective}.json"


class NetworkRun(CountedRun[list[float], Evaluated]):
    """One network run; create with :meth:`start` or :meth:`resume`, then :meth:`execute` (the loop every
    run shares, ``run_folder.RunLoop``, with what composition and team runs share, ``CountedRun``) and
    :meth:`finish`."""

    def __init__(self, config: NetworkConfig, root: Path, evaluator: Evaluator | None) -> None:
        super().__init__()
        self.config: NetworkConfig = config
        self.directory: NetworkDirectory = NetworkDirectory(root)
        self.evaluator = evaluator
        self.optimiser = make_optimiser(config.algorithm, config.parameters, config.seed)
        self.produced = 0
        """Networks produced, the optimiser's uncounted initial population aside (what the budget counts)."""
        self.best: Evaluated | None = None
        self.grid: dict[tuple[int, ...], Evaluated] = {}
        """The fittest network evaluated per bin (the first among equals), as a tree run's repertoire."""
        self._counted = True
        """Whether the batch being evaluated counts in the budget."""

    # Construction ------------------------------------------------------------------------------------
    @classmethod
    def start(cls, config: NetworkConfig, root: Path, evaluator: Evaluator) -> NetworkRun:
        """A new run in ``root``, which must not hold a run already (``RunLoop._begin``): its configuration,
        empty logs and first checkpoint."""
        return cls._begin(
            NetworkDirectory(root),
            lambda building: cls(config, building, evaluator),
            {"config.json": config.to_json()},
        )

    @classmethod
    def resume(cls, root: Path, evaluator: Evaluator | None) -> NetworkRun:
        """The run in ``root`` at its last checkpoint, its CSV files cut back to it (``RunLoop._reopen``)."""
        directory = NetworkDirectory(root)
        return cls._resume(
            directory,
            lambda: cls(NetworkConfig.from_json(read_json_object(directory.config)), root, evaluator),
        )

    # State -------------------------------------------------------------------------------------------
    def _state(self) -> dict:
        return {
            "optimiser": self.optimiser.to_state(),
            "best": None if self.best is None else self.best.as_json(),
            "grid": [self.grid[b].as_json() for b in sorted(self.grid)],
        }

    def _restore(self, state: dict) -> None:
        self.optimiser.restore(state["optimiser"])
        self.best = None if state["best"] is None else Evaluated.from_json(state["best"])
        members = [Evaluated.from_json(e) for e in state["grid"]]
        self.grid = {bin_of(e.descriptors): e for e in members if e.descriptors is not None}

    # Execution ---------------------------------------------------------------------------------------
    def _batch_context(self) -> AbstractContextManager[object]:
        """One BLAS thread for the batches: the optimisers' linear algebra is an eigendecomposition of a 56 x
        56 covariance a generation (pycma; pyribs' CMA-ME emitters), on which OpenBLAS's threads cost more
        than they give (0.23 ms on one thread, 1.7 ms on two, and far more beside other work:
        docs/performance.md). The results are the same."""
        return threadpool_limits(limits=1, user_api="blas")

    def _ask(self) -> list[list[float]]:
        self._counted = not self.optimiser.initial()
        return self.optimiser.ask()

    def _evaluate(self, batch: list[list[float]]) -> list[Evaluated]:
        """Each network of ``batch`` on the run's scenario seed."""
        if self.evaluator is None:
            raise RunDirectoryError("this run was opened for reading: it has no evaluator")
        texts = [to_text(Network(tuple(w))) for w in batch]
        seed, trials = self.config.scenario_seed, self.config.trials
        results = self.evaluator.evaluate([EvaluationRequest(t, seed, trials) for t in texts])
        k = world.OBJECTIVES.index(self.config.objective)
        out = []
        for offset, (weights, result) in enumerate(zip(batch, results, strict=True)):
            index = self.evaluations + offset
            if result.error is None and result.fitness is not None and result.descriptors is not None:
                out.append(Evaluated(tuple(weights), result.fitness[k], tuple(result.descriptors), index))
            else:
                out.append(Evaluated(tuple(weights), None, None, index, result.error or "no fitness"))
        return out

    def _tell(self, batch: list[list[float]], answers: list[Evaluated]) -> None:
        """Tell the optimiser, keep the best and the grid, record the batch."""
        self.optimiser.tell([e.rank for e in answers], [e.descriptors for e in answers])
        self.evaluations += len(answers)
        if self._counted:
            self.produced += len(answers)
        self._keep_best(answers)
        for e in answers:
            if e.fitness is not None and e.descriptors is not None:
                index = bin_of(e.descriptors)
                held = self.grid.get(index)
                if held is None or e.fitness > held.rank:
                    self.grid[index] = e
        self._record(answers)

    def _record(self, evaluated: Sequence[Evaluated]) -> None:
        seed, axes = str(self.config.scenario_seed), len(DESCRIPTORS)
        rows = [
            [str(e.evaluation), seed, " ".join(number(w) for w in e.genome), *e.logged(axes), e.error]
            for e in evaluated
        ]
        best = "" if self.best is None else number(self.best.fitness)
        self._append_logs(rows, [str(self.evaluations), best, number(self.coverage), number(self.qd_score)])

    @property
    def coverage(self) -> float:
        """Filled bins / 512."""
        return len(self.grid) / GRID_BINS

    @property
    def qd_score(self) -> float:
        """The sum of each bin's best fitness / 512 (the authors' analysis), summed in bin order."""
        return sum(self.grid[b].rank for b in sorted(self.grid)) / GRID_BINS

    def heldout(self) -> tuple[dict | None, float | None]:
        """The best network re-scored on the held-out seeds (``NetworkConfig.heldout_seeds``, scenarios the
        run never used), as a tree run's best tree: what was done, and the mean of its fitness (None when no
        network has a fitness or one of its held-out evaluations failed). Nothing without an evaluator or
        before the budget is spent."""
        if self.evaluator is None or not self.done or self.best is None:
            return None, None
        seeds = self.config.heldout_seeds()
        text = to_text(Network(self.best.genome))
        results = self.evaluator.evaluate([EvaluationRequest(text, s, self.config.trials) for s in seeds])
        k = world.OBJECTIVES.index(self.config.objective)
        scored = [r.fitness[k] for r in results if r.error is None and r.fitness is not None]
        done = {"seeds": seeds, "evaluations_per_tree": len(seeds), "trials": self.config.trials, "trees": 1}
        return done, math.fsum(scored) / len(seeds) if len(scored) == len(seeds) else None

    def finish(self) -> dict:
        """Write ``summary.json`` (with the best network's held-out fitness once the budget is spent),
        ``repertoire_<objective>.json`` and ``best/<objective>.json``; return the summary."""
        heldout, heldout_best = self.heldout()
        summary = {
            "kind": KIND,
            "config": self.config.to_json(),
            "evaluations": self.evaluations,
            "produced": self.produced,
            "finished": self.done,
            "best": None if self.best is None else self.best.as_json(),
            "heldout": heldout,
            "heldout_best_fitness": heldout_best,
            "coverage": self.coverage,
            "qd_score": self.qd_score,
            "repertoire_size": len(self.grid),
        }
        write_json(self.directory.summary, summary)
        items = [{"bin": list(b), **self.grid[b].as_json()} for b in sorted(self.grid)]
        write_json(self.directory.repertoire(self.config.objective), {"kind": KIND, "items": items})
        if self.best is not None:
            make_folder(self.directory.best)
            network = Network(self.best.genome)
            write_json(self.directory.best / f"{self.config.objective}.json", network_document(network))
        return summary
