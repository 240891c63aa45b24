"""Using a repertoire when the world changes: Intelligent Trial and Error and the baselines it is measured by.

Intelligent Trial and Error (Cully, Clune, Tarapore and Mouret, "Robots that can adapt like animals", Nature
521, 2015; their M-BOA) searches the repertoire instead of evolving again. Each filled bin offers one tree,
its best; a Gaussian process over the three descriptors models the fitness under the changed condition, with
the repertoire's own fitness as prior mean, so that at first the best trees of the map are believed and a
poor trial lowers the expectation of its neighbours in behaviour space. Each trial evaluates the tree of the
bin with the highest upper confidence bound ``mu + kappa * sigma`` not tried yet. The search stops when the
best fitness observed reaches ``stop_fraction`` of the highest expected fitness of any bin (the paper's rule,
alpha = 0.9), or when the budget is spent, or when every bin has been tried.

Parameters (``ITEParameters``): a Matern 5/2 kernel (as the paper) of length scale 0.25 over descriptors in
[0, 1] (two bins of the 8 x 8 x 8 grid; the paper's 0.4 was for a coarser six-dimensional map), signal
variance 0.04 (a fitness change of about 0.2 is one standard deviation), observation noise variance 0.001
(a fixed scenario gives each tree one exact fitness; the noise keeps the GP well conditioned), kappa 0.05 (the
paper's value: the search follows the posterior mean and explores only to break near ties).

Adaptation per robot (``CompositionEvaluation``): the same search, but the asked tree goes only to the robots
a condition strikes (``struck_robots``: the robots with a per-robot fault, the dead ones, the ones with a
weak wheel) while every other robot keeps the swarm's tree from before the fault (the repertoire's best); the
swarm's fitness is scored as the task's. Why this search space: the robots that must change are the ones
whose body changed, and a fault is known where it struck (a robot can tell that its own wheel or sensor
failed). One tree shared by the struck robots keeps the space the repertoire's bins, so Intelligent Trial and
Error's prior (the repertoire's fitness) and its Gaussian process over the descriptors still apply and the
budget of a few tens of trials still covers it; one tree per struck robot would multiply the space by the
number of bins per robot, beyond any such budget. On a scenario where no robot is struck every composition is
the swarm from before (one simulation, cached). The healthy robots keep the best tree: that tree is what made
the swarm good before the fault, and changing them is what homogeneous Intelligent Trial and Error already
tries.

Every algorithm here is an ask/tell object that never evaluates: the caller evaluates the asked tree on
the changed world (one "trial" of adaptation is one evaluation, 10 simulated trials) and tells its fitness.
Baselines: ``RandomPicks`` (distinct bins drawn at random) and ``reevolve`` (GP_o or MAP-Elites from
scratch). Nothing here imports ``rclpy``; of the simulator, only which robots a condition strikes
(``swarm_sim.core.trial_data.robot_faults``).
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable, Sequence
from dataclasses import asdict, dataclass
from pathlib import Path

import numpy as np
from sklearn.gaussian_process import GaussianProcessRegressor
from sklearn.gaussian_process.kernels import ConstantKernel, Matern

from bt_controller.draws import root_key
from bt_controller.errors import TreeError
from bt_controller.language import Library, parse, to_text
from bt_controller.validate import integer
from evolution_manager.errors import AskTellError, ConfigError, EvolutionError
from evolution_manager.evolution.algorithms import AskTell, Outcome, as_outcome
from evolution_manager.evolution.archive import Repertoire
from evolution_manager.evolution.run import RunDirectory
from evolution_manager.evolution.run_config import OBJECTIVES, RunConfig
from evolution_manager.files import read_json_object, write_json
from swarm_sim.core import robot_faults
from swarm_sim.evaluation import EvaluationRequest, Evaluator, SwarmRequest
from swarm_sim.model import Config, SwarmLayout


class AdaptationError(EvolutionError, ValueError):
    """A repertoire that cannot be adapted from, or an adaptation option that cannot be used."""


@dataclass(frozen=True)
class Candidate:
    """One bin of the repertoire as adaptation sees it: its best tree, that tree's fitness in the
    repertoire (the prior) and its descriptors (where the GP places it)."""

    bin: tuple[int, ...]
    tree: str
    prior: float
    descriptors: tuple[float, float, float]


def load_candidates(run_dir: Path, objective: str, library: Library | None = None) -> list[Candidate]:
    """Every filled bin's best tree of ``run_dir/repertoire_<objective>.json``, in bin order (trees that name
    primitives parse with the run's ``library``: ``repertoire_setting``)."""
    if objective not in OBJECTIVES:
        raise AdaptationError(f"objective must be one of {', '.join(OBJECTIVES)}, got {objective!r}")
    path = Path(run_dir) / f"repertoire_{objective}.json"
    if not path.is_file():
        raise AdaptationError(f"{run_dir} holds no repertoire of {objective} (no {path.name})")
    grid = Repertoire()
    try:
        document = read_json_object(path)
        best: dict[tuple[int, ...], Candidate] = {}
        for item in document["items"]:
            index = tuple(integer(v, "a bin index") for v in item["bin"])
            descriptors = tuple(float(v) for v in item["descriptors"])
            fitness = float(item["fitness"])
            if len(descriptors) != 3 or not all(0.0 <= d <= 1.0 for d in descriptors):
                raise ValueError(f"descriptors of bin {list(index)} are not three values in [0, 1]")
            if index != grid.bin_of(descriptors):
                raise ValueError(
                    f"bin {list(index)} is not the bin {list(grid.bin_of(descriptors))} of its descriptors "
                    f"{list(descriptors)} in the {'x'.join(map(str, grid.shape))} grid"
                )
            if not math.isfinite(fitness):
                raise ValueError(f"fitness of bin {list(index)} is not finite")
            tree = item["tree"]
            if not isinstance(tree, str):
                raise ValueError(f"the tree of bin {list(index)} must be tree text, got {tree!r}")
            try:
                parse(tree, library=library)
            except TreeError as error:
                raise ValueError(f"the tree of bin {list(index)} is not a tree: {error}") from None
            if index not in best or fitness > best[index].prior:
                best[index] = Candidate(index, tree, fitness, descriptors)
    except EvolutionError as error:
        raise AdaptationError(str(error)) from None
    except (KeyError, TypeError, ValueError) as error:
        raise AdaptationError(f"{path} is not a repertoire file: {error}") from None
    if not best:
        raise AdaptationError(f"the repertoire {path} is empty: nothing to adapt from")
    return [best[index] for index in sorted(best)]


def written_out(candidates: Sequence[Candidate], library: Library | None) -> list[Candidate]:
    """``candidates`` with each tree's primitives of ``library`` written out (the same tree, in text a
    controller parses without the library: what ``load_tree`` sends to a running robot); as given for a
    repertoire without a library."""
    if library is None:
        return list(candidates)
    return [Candidate(c.bin, to_text(library.parse(c.tree)), c.prior, c.descriptors) for c in candidates]


@dataclass(frozen=True)
class RepertoireSetting:
    """What a repertoire was evolved in, which adaptation keeps: the run's configuration (its profile, task,
    objective and budget) and its copy of the primitive library (None for a run without one)."""

    config: RunConfig
    library: Library | None

    @property
    def world(self) -> Config:
        """The task's world under the run's profile, before any condition."""
        return self.config.world()


def repertoire_setting(run_dir: Path) -> RepertoireSetting:
    """The setting of the repertoire in ``run_dir`` (its ``config.json`` and library copy)."""
    directory = RunDirectory(Path(run_dir))
    try:
        config = directory.read_config()
        return RepertoireSetting(config, directory.read_library(config))
    except EvolutionError as error:
        raise AdaptationError(f"{run_dir} is not a run directory: {error}") from None


@dataclass(frozen=True)
class ITEParameters:
    """Intelligent Trial and Error's parameters (see the module's docstring for the choices)."""

    length_scale: float = 0.25
    signal_variance: float = 0.04
    noise_variance: float = 1e-3
    kappa: float = 0.05
    stop_fraction: float | None = 0.9
    """The paper's alpha; None never stops before the budget."""

    def __post_init__(self) -> None:
        for name in ("length_scale", "signal_variance", "noise_variance"):
            value = getattr(self, name)
            if not (isinstance(value, (int, float)) and math.isfinite(value) and value > 0):
                raise ConfigError(f"{name} must be a positive number, got {value!r}")
        if not (isinstance(self.kappa, (int, float)) and math.isfinite(self.kappa) and self.kappa >= 0):
            raise ConfigError(f"kappa must be a number >= 0, got {self.kappa!r}")
        if self.stop_fraction is not None and not 0.0 < self.stop_fraction <= 1.0:
            raise ConfigError(f"stop_fraction must be in (0, 1], got {self.stop_fraction!r}")

    def as_dict(self) -> dict[str, object]:
        return asdict(self)


@dataclass(frozen=True)
class Tried:
    """One adaptation trial: which bin, its tree, its prior and the fitness observed under the condition;
    ``expected_max`` is the highest posterior mean of any bin after it was told (the stopping rule's bar)."""

    bin: tuple[int, ...]
    tree: str
    prior: float
    fitness: float
    descriptors: tuple[float, float, float]
    """The tree's descriptors measured under the condition."""
    expected_max: float


def _check_budget(budget: int) -> None:
    if isinstance(budget, bool) or not isinstance(budget, int) or budget < 1:
        raise ConfigError(f"the budget must be a positive number of trials, got {budget!r}")


class _Picker:
    """Ask/tell over the bins of a repertoire: never a bin twice, never beyond the budget."""

    def __init__(self, candidates: Sequence[Candidate], budget: int) -> None:
        if not candidates:
            raise AdaptationError("no candidates: the repertoire is empty")
        _check_budget(budget)
        self.candidates = list(candidates)
        self.budget = budget
        self.tried: list[Tried] = []
        self._untried = np.ones(len(self.candidates), dtype=bool)
        self._asked: int | None = None
        self.stop_reason: str | None = None

    @property
    def done(self) -> bool:
        """Whether the search is over (``stop_reason`` says why)."""
        if self.stop_reason is None:
            if len(self.tried) >= self.budget:
                self.stop_reason = "budget"
            elif not self._untried.any():
                self.stop_reason = "every bin tried"
        return self.stop_reason is not None

    def ask(self) -> Candidate:
        """The next bin to try."""
        if self._asked is not None:
            raise AskTellError("ask() called twice: tell() the fitness of the last candidate first")
        if self.done:
            raise AskTellError(f"the adaptation is over ({self.stop_reason})")
        self._asked = self._choose()
        return self.candidates[self._asked]

    def tell(self, fitness: float, descriptors: Sequence[float] = (math.nan,) * 3) -> None:
        """The fitness (and descriptors) of the last asked candidate under the changed condition."""
        if self._asked is None:
            raise AskTellError("tell() called without a candidate: call ask() first")
        if not math.isfinite(fitness):
            raise AskTellError(f"fitness must be a finite number, got {fitness!r}")
        index, self._asked = self._asked, None
        self._untried[index] = False
        candidate = self.candidates[index]
        measured = (float(descriptors[0]), float(descriptors[1]), float(descriptors[2]))
        self.tried.append(
            Tried(candidate.bin, candidate.tree, candidate.prior, float(fitness), measured, math.nan)
        )
        self._after_tell()

    @property
    def best(self) -> Tried | None:
        """The best tried so far (the first on ties)."""
        best = None
        for t in self.tried:
            if best is None or t.fitness > best.fitness:
                best = t
        return best

    def _choose(self) -> int:
        raise NotImplementedError

    def _after_tell(self) -> None:
        pass


class IntelligentTrialAndError(_Picker):
    """Intelligent Trial and Error over a repertoire's bins (module docstring). Deterministic: ties go to
    the first bin in bin order."""

    def __init__(
        self, candidates: Sequence[Candidate], budget: int, parameters: ITEParameters | None = None
    ) -> None:
        super().__init__(candidates, budget)
        self.parameters = parameters or ITEParameters()
        self._x = np.array([c.descriptors for c in self.candidates], dtype=np.float64)
        self._prior = np.array([c.prior for c in self.candidates], dtype=np.float64)
        self._tried_index: list[int] = []
        self.mean = self._prior.copy()
        self.sigma = np.full(len(self.candidates), math.sqrt(self.parameters.signal_variance))

    def _choose(self) -> int:
        ucb = self.mean + self.parameters.kappa * self.sigma
        ucb[~self._untried] = -np.inf
        return int(np.argmax(ucb))

    def tell(self, fitness: float, descriptors: Sequence[float] = (math.nan,) * 3) -> None:
        """As ``_Picker.tell``; then the GP is refitted and the stopping rule checked."""
        if self._asked is not None and math.isfinite(fitness):
            self._tried_index.append(self._asked)
        super().tell(fitness, descriptors)

    def _after_tell(self) -> None:
        p = self.parameters
        kernel = ConstantKernel(p.signal_variance, "fixed") * Matern(p.length_scale, "fixed", nu=2.5)
        gp = GaussianProcessRegressor(kernel, alpha=p.noise_variance, optimizer=None, normalize_y=False)
        index = np.array(self._tried_index)
        observed = np.array([t.fitness for t in self.tried])
        gp.fit(self._x[index], observed - self._prior[index])
        residual, sigma = gp.predict(self._x, return_std=True)
        self.mean = self._prior + residual
        self.sigma = sigma
        expected_max = float(self.mean.max())
        last = self.tried[-1]
        self.tried[-1] = Tried(last.bin, last.tree, last.prior, last.fitness, last.descriptors, expected_max)
        best = max(t.fitness for t in self.tried)
        if p.stop_fraction is not None and best >= p.stop_fraction * expected_max:
            self.stop_reason = f"best observed >= {p.stop_fraction} x the highest expected fitness"


class RandomPicks(_Picker):
    """The baseline: distinct bins in an order drawn from ``seed``."""

    def __init__(self, candidates: Sequence[Candidate], budget: int, seed: int) -> None:
        super().__init__(candidates, budget)
        self._order = list(np.random.default_rng(seed).permutation(len(self.candidates)))

    def _choose(self) -> int:
        return int(self._order[len(self.tried)])


class ConditionEvaluation:
    """Evaluations in the changed world: every tree with the same seed (one fixed scenario, so each tree has
    one exact fitness and a tree seen before is not simulated again) through any evaluator of the contract
    (``swarm_sim.evaluation.batch.BatchEvaluator`` built with the condition's config, or the node graph)."""

    def __init__(self, evaluator: Evaluator, seed: int, trials: int = 10) -> None:
        self.evaluator = evaluator
        self.seed = seed
        self.trials = trials
        self.simulated = 0
        self._cache: dict[str, Outcome] = {}

    def __call__(self, trees: Sequence[str]) -> list[Outcome]:

        new = [t for t in dict.fromkeys(trees) if t not in self._cache]
        if new:
            requests = [EvaluationRequest(t, self.seed, self.trials) for t in new]
            results = self.evaluator.evaluate(requests)
            self.simulated += len(new)
            for tree, result in zip(new, results, strict=True):
                outcome = as_outcome(result)
                if not outcome.ok:
                    raise AdaptationError(f"the evaluator could not evaluate {tree}: {outcome.error}")
                self._cache[tree] = outcome
        return [self._cache[t] for t in trees]

    def to_state(self) -> dict:
        """What was simulated, as JSON-able data: ``restore`` continues with the same cache and count."""
        outcomes = [[t, list(o.fitness or ()), list(o.descriptors or ())] for t, o in self._cache.items()]
        return {"seed": self.seed, "trials": self.trials, "simulated": self.simulated, "outcomes": outcomes}

    def restore(self, state: dict) -> None:
        """Continue from ``to_state()``'s data, which must be of this seed and number of trials."""
        if state["seed"] != self.seed or state["trials"] != self.trials:
            raise ValueError(f"saved evaluations of seed {state['seed']}, {state['trials']} trials")
        self.simulated = integer(state["simulated"], "simulated", 0)
        self._cache = {
            str(tree): Outcome(tuple(float(v) for v in fitness), tuple(float(v) for v in descriptors))
            for tree, fitness, descriptors in state["outcomes"]
        }


def struck_robots(config: Config, seed: int) -> tuple[int, ...]:
    """The robots that ``config``'s conditions strike in evaluations of ``seed``, in id order: a per-robot
    fault (drawn from the seed under a fault rate), one of the ``dead_robots`` first robots, or one of the
    ``weak_robots`` last ones. Swarm-wide conditions (message loss, the swarm's size, the gap) strike none."""
    faults = robot_faults(config, root_key(int(seed)))
    n = config.n_robots
    return tuple(
        i for i in range(n) if faults[i] != 0 or i < config.dead_robots or i >= n - config.weak_robots
    )


def composition(base: str, tree: str, robots: Sequence[int], n_robots: int) -> SwarmLayout:
    """A swarm of ``n_robots`` where the robots in ``robots`` run ``tree`` and every other robot ``base``."""
    chosen = set(robots)
    if not all(isinstance(r, int) and 0 <= r < n_robots for r in chosen):
        raise AdaptationError(f"robots must be robot ids in [0, {n_robots - 1}], got {sorted(chosen)}")
    return SwarmLayout(tuple(tree if i in chosen else base for i in range(n_robots)))


class CompositionEvaluation:
    """Adaptation per robot (module docstring): each asked tree evaluated as the swarm where the robots
    ``struck_robots`` names for ``seed`` run it and the others keep ``base``; every layout with the same seed
    and each layout simulated once (as ``ConditionEvaluation``). Takes the same ``Evaluator`` (it must take
    ``SwarmRequest``s, as ``BatchEvaluator`` does)."""

    def __init__(self, evaluator: Evaluator, config: Config, seed: int, base: str, trials: int = 10) -> None:
        self.evaluator = evaluator
        self.seed = seed
        self.trials = trials
        self.base = base
        self.n_robots = config.n_robots
        self.robots = struck_robots(config, seed)
        self.simulated = 0
        self._cache: dict[tuple[str, ...], Outcome] = {}

    def layout(self, tree: str) -> SwarmLayout:
        """The swarm that trying ``tree`` evaluates."""
        return composition(self.base, tree, self.robots, self.n_robots)

    def __call__(self, trees: Sequence[str]) -> list[Outcome]:
        layouts = [self.layout(t) for t in trees]
        new = [layout for layout in dict.fromkeys(layouts) if layout.trees not in self._cache]
        if new:
            requests = [SwarmRequest(layout, self.seed, self.trials) for layout in new]
            results = self.evaluator.evaluate(requests)  # type: ignore[arg-type]  # BatchEvaluator takes them
            self.simulated += len(new)
            for layout, result in zip(new, results, strict=True):
                outcome = as_outcome(result)
                if not outcome.ok:
                    raise AdaptationError(f"the evaluator could not evaluate {layout.trees}: {outcome.error}")
                self._cache[layout.trees] = outcome
        return [self._cache[layout.trees] for layout in layouts]


Evaluate = Callable[[Sequence[str]], list[Outcome]]
"""Outcomes of tree texts under the changed condition (one adaptation trial each), in order."""


def run_picker(
    picker: _Picker, evaluate: Evaluate, objective: str, on_trial: Callable[[Tried], None] | None = None
) -> None:
    """Drive ``picker`` to its end, one evaluation per trial, scored on ``objective``."""
    k = OBJECTIVES.index(objective)
    while not picker.done:
        candidate = picker.ask()
        outcome = evaluate([candidate.tree])[0]
        assert outcome.fitness is not None and outcome.descriptors is not None
        picker.tell(outcome.fitness[k], outcome.descriptors)
        if on_trial is not None:
            on_trial(picker.tried[-1])


@dataclass(frozen=True)
class SearchCheckpoint:
    """Where a long ``reevolve`` saves itself between batches (atomically, at most every ``every`` seconds)
    so that a killed one continues from there with the same results, and which search it is: a file saved
    for another ``key`` is not resumed, and the first save replaces it."""

    path: Path
    key: dict[str, object]
    every: float = 120.0


def saved_search(checkpoint: SearchCheckpoint) -> dict | None:
    """The state saved at ``checkpoint.path`` for ``checkpoint.key``: None when there is no file or it is
    another search's. A damaged file raises ``AdaptationError`` naming it (nothing is overwritten)."""
    if not checkpoint.path.exists():
        return None
    try:
        saved = read_json_object(checkpoint.path)
    except EvolutionError as error:
        raise AdaptationError(f"{error}; remove it to start that search afresh") from error
    return saved if saved.get("key") == checkpoint.key else None


def _save_search(
    checkpoint: SearchCheckpoint, search: AskTell, trees: list[str], fitness: list[float], evaluate: Evaluate
) -> None:
    state = {
        "key": checkpoint.key,
        "search": search.to_state(),
        "trees": trees,
        "fitness": fitness,
        "evaluations": evaluate.to_state() if isinstance(evaluate, ConditionEvaluation) else None,
    }
    write_json(checkpoint.path, state, indent=None)


def reevolve(
    algorithm: str,
    objective: str,
    budget: int,
    seed: int,
    evaluate: Evaluate,
    setting: RepertoireSetting | None = None,
    checkpoint: SearchCheckpoint | None = None,
) -> tuple[list[str], list[float]]:
    """Evolve from scratch under the changed condition with ``algorithm`` (``gp``: GP_o, ``qd``:
    MAP-Elites, with the paper's parameters) for ``budget`` evaluations; every evaluated tree and its fitness
    in the order produced. With ``setting``, on the repertoire's task, profile and library (a foraging
    repertoire's primitives as leaves); without, the default task's flat node set. With ``checkpoint``, it
    continues the search saved there for the same key (the search, the trees and, for a
    ``ConditionEvaluation``, what it simulated, so the results and the count of simulations are those of an
    uninterrupted run) and saves itself as it goes; the caller removes the file when it has the result."""
    if algorithm not in ("gp", "qd"):
        raise ConfigError(f"re-evolution uses gp or qd, got {algorithm!r}")
    if setting is None:
        search = RunConfig.make(algorithm, objective, budget, seed).make_algorithm()
    else:
        c = setting.config
        made = RunConfig.make(
            algorithm,
            objective,
            budget,
            seed,
            trials=c.trials,
            profile=c.profile,
            task=c.task,
            library=c.library,
            library_digest=c.library_digest,
            nodes=c.nodes,
        )
        search = made.make_algorithm(setting.library)
    k = OBJECTIVES.index(objective)
    trees: list[str] = []
    fitness: list[float] = []
    if checkpoint is not None and (saved := saved_search(checkpoint)) is not None:
        try:
            search.restore(saved["search"])
            trees = [str(t) for t in saved["trees"]]
            fitness = [float(v) for v in saved["fitness"]]
            if isinstance(evaluate, ConditionEvaluation) and saved["evaluations"] is not None:
                evaluate.restore(saved["evaluations"])
        except (KeyError, TypeError, ValueError) as error:
            raise AdaptationError(
                f"{checkpoint.path} is damaged ({error}); remove it to start that search afresh"
            ) from error
    saved_at = time.monotonic()
    while not search.done and len(trees) < budget:
        asked = search.ask()
        # The budget counts evaluations, as adaptation's trials do (the algorithms' own budgets count the
        # individuals produced after their initial population): the batch that reaches it is cut there, and
        # the search, which cannot be told part of a batch, ends with it.
        batch = asked[: budget - len(trees)]
        outcomes = evaluate(batch)
        trees.extend(batch)
        fitness.extend(o.objective(k) for o in outcomes)
        if len(batch) < len(asked):
            break
        search.tell(outcomes)
        if checkpoint is not None and time.monotonic() - saved_at >= checkpoint.every:
            _save_search(checkpoint, search, trees, fitness, evaluate)
            saved_at = time.monotonic()
    return trees, fitness


def best_so_far(fitness: Sequence[float]) -> list[float]:
    """The running maximum of a sequence of fitness values."""
    return [float(v) for v in np.maximum.accumulate(np.asarray(fitness, dtype=np.float64))] if fitness else []
