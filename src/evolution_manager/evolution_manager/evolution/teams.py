"""Teams: direct heterogeneous evolution, a genome of K behaviour trees evolved together by the 2023 GP.

``evolve --team K --algorithm gp --objective O [--task T] --evaluations N --seed S --out DIR`` (``--resume``;
``docs/algorithms.md``, "Teams"). The swarm is split into K sub-groups: robot ``i`` runs tree ``i mod K``
(:func:`robot_groups`), so K = 1 is a homogeneous swarm, K = 2 splits the even and the odd robots (the
authors' two robot types, id mod 2), and K = the number of robots gives every robot a tree of its own. K need
not divide the number of robots (K = 2 of 9 robots: 5 even, 4 odd). No repertoire is involved: this is the
"evolve the heterogeneous swarm directly" arm of issue 36, against which "generate, then allocate"
(``evolution.compositions``) is compared.

The GP is the project's 2023 GP_o (``parameters.GPParameters``: population 25, tournament 3, one elite,
crossover 0.8, the insert, shrink and replace mutations, the height and size limits, the derating the tree
GP of the same task would use), over teams instead of trees: a generation keeps the elite team, fills the
population with tournament winners (on the team's fitness, derated by the mean size of its trees) and varies
them pairwise: each pair of winners draws one sub-group uniformly, and that sub-group's two trees go through
the tree GP's variation (``operators.vary``: one-point crossover with probability 0.8, then each mutation
with its probability, the static limits), the other sub-groups copied unchanged (:func:`vary_teams`; the
restricted crossover of team GP, which only crosses the trees of one position). A child no operator touched
keeps its parent's fitness and is not evaluated, as in the tree GP. The budget counts the teams produced by
the generations after the initial population (25 per generation, the elite included), as every run's; the
generation that reaches it is completed. With a start tree (``TeamConfig.start_trees``, ``--start-tree``) the
initial population is 25 copies of that tree's homogeneous swarm instead of random trees, so every sub-group's
tree evolves from it in the role its robots play beside the others; with K start trees (``--start-tree`` K
times) the 25 copies are the team whose sub-group g runs the g-th.

Every team is evaluated as a heterogeneous swarm (``swarm_sim.evaluation.SwarmRequest``) on the run's
scenario seed (fixed scenarios, the default; a team this process evaluated before is answered from
memory), or under ``--scenarios fresh`` evaluation ``i`` on a scenario of its own
(``run_config.evaluation_seed``), so that no team is chosen for one scenario's luck. Every random draw comes
from one ``random.Random`` seeded with ``derive_seed(seed, RUN_ALGORITHM)``.

A run directory is a run folder as every run's (``run_folder``): ``config.json`` (``"kind": "teams"``),
``evaluations.csv`` (evaluation, seed, the sub-group varied, the K trees as a JSON list, the objective, the
descriptors, error), ``progress.csv``, ``checkpoint.json`` (atomic, with the lengths of the CSV files and the
generator's state) and when the run ends ``summary.json`` (with the best team's held-out fitness on fresh
scenario seeds, and its held-out mean of every objective, the deliveries of each food kind among them; the
validated choice, ``validation``),
``best/<objective>_swarm.json`` (the best team as a swarm layout file, for ``evaluate --swarm``, ``trial
--swarm`` and ``animate --swarm``) and ``best/<objective>_group<g>.txt`` (its trees). A resumed run ends
with the very bytes of an uninterrupted one.
"""

from __future__ import annotations

import json
import math
import random
from collections.abc import Sequence
from dataclasses import asdict, dataclass, field
from pathlib import Path

from deap import gp

from bt_controller.draws import MAX_SEED, RUN_ALGORITHM, derive_seed
from bt_controller.language import ACTIONS, CONDITIONS
from bt_controller.model_settings import PROFILES
from bt_controller.validate import integer
from evolution_manager.errors import ConfigError, RunDirectoryError
from evolution_manager.evolution.deap_trees import make_primitive_set, tree_from_text, tree_to_text
from evolution_manager.evolution.operators import PARSIMONY_HEIGHT, full_tree, vary
from evolution_manager.evolution.parameters import DERATINGS, Derating, GPParameters
from evolution_manager.evolution.run_config import (
    DEFAULT_PROFILE,
    HELDOUT_EVALUATIONS,
    SCENARIOS,
    default_scenario_seed,
    heldout_seed,
    scenario_of_evaluation,
)
from evolution_manager.evolution.run_folder import (
    TEAMS,
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
from evolution_manager.files import number, read_json_object, write_json
from swarm_sim.evaluation import Evaluator, SwarmRequest
from swarm_sim.model import DESCRIPTORS, OBJECTIVES, Config, SwarmLayout
from swarm_sim.tasks import DEFAULT_TASK, TaskSpec, resolve_task, task_from_record, task_named, task_to_record

KIND = TEAMS
"""``config.json``'s ``kind``: what tells a team run from a tree, composition or network run."""
ALGORITHMS: tuple[str, ...] = ("gp",)
DEFAULT_EVALUATIONS = 25_000
"""The tree GP's default budget (``run_config.DEFAULT_EVALUATIONS``)."""
FAILED = -1.0
"""The fitness a team whose evaluation failed is selected by: below every real fitness (as the tree GP's)."""

EVALUATION_HEADER = ["evaluation", "seed", "group", "trees", "fitness", *DESCRIPTORS, "error"]
PROGRESS_HEADER = ["evaluations", "generation", "best_fitness"]

Texts = tuple[str, ...]
"""A team: one tree text per sub-group, sub-group 0 first."""


# Sub-groups ------------------------------------------------------------------------------------------------
def check_team_size(team: int, n_robots: int, name: str = "team") -> int:
    """``team`` when it is a number of sub-groups the swarm can have (1 to ``n_robots``); else ``ConfigError``
    in one line saying what was expected."""
    if isinstance(team, bool) or not isinstance(team, int) or not 1 <= team <= n_robots:
        raise ConfigError(
            f"{name} {team!r}: a team is 1 to {n_robots} sub-groups of the task's {n_robots} robots (robot i "
            f"runs tree i mod K); give K from 1 to {n_robots}"
        )
    return team


def robot_groups(n_robots: int, team: int) -> tuple[int, ...]:
    """The sub-group (tree) of each robot, robot 0 first: robot ``i`` runs tree ``i mod team``."""
    check_team_size(team, n_robots)
    return tuple(i % team for i in range(n_robots))


def team_layout(texts: Sequence[str], n_robots: int) -> SwarmLayout:
    """The swarm a team stands for: robot ``i`` runs ``texts[i mod len(texts)]``."""
    return SwarmLayout(tuple(texts[g] for g in robot_groups(n_robots, len(texts))))


# Variation -------------------------------------------------------------------------------------------------
@dataclass(frozen=True)
class Child:
    """A team made by :func:`vary_teams`: its trees, the sub-group it was varied in, and whether an operator
    touched that sub-group's tree (an untouched child is its parent's copy)."""

    texts: Texts
    group: int
    touched: bool


def vary_teams(
    parents: Sequence[Texts], pset: gp.PrimitiveSet, rng: random.Random, parameters: GPParameters
) -> list[Child]:
    """Offspring of ``parents`` (in order, all of one team size): each consecutive pair (the last one alone
    when their number is odd) draws one sub-group uniformly, and the pair's trees of that sub-group are varied
    by the tree GP's ``operators.vary`` (crossover with each other, then the mutations); every other sub-group
    is copied unchanged."""
    sizes = {len(p) for p in parents}
    if len(sizes) > 1:
        raise ValueError(f"teams of one size are varied together, got sizes {sorted(sizes)}")
    p = parameters
    children: list[Child] = []
    for start in range(0, len(parents), 2):
        pair = parents[start : start + 2]
        group = rng.randrange(len(pair[0]))
        trees = [tree_from_text(team[group], pset) for team in pair]
        for tree in trees:  # a valid fitness marks a tree no operator touched (operators.vary clears it)
            tree.fitness.values = (0.0,) * len(OBJECTIVES)
        varied = vary(trees, pset, rng, p.crossover, p.mutations, p.max_height, p.max_nodes)
        for team, tree in zip(pair, varied, strict=True):
            texts = (*team[:group], tree_to_text(tree), *team[group + 1 :])
            children.append(Child(texts, group, not tree.fitness.valid))
    return children


# Configuration ---------------------------------------------------------------------------------------------
@dataclass(frozen=True)
class TeamConfig:
    """One team run (``config.json``)."""

    team: int
    objective: str
    evaluations: int
    seed: int
    trials: int = 10
    profile: str = DEFAULT_PROFILE
    task: TaskSpec = field(default_factory=lambda: task_named(DEFAULT_TASK))
    """The world and the node set's conditions (``swarm_sim.tasks``); a name or file is resolved."""
    scenario_seed: int = -1
    """-1: derived from ``seed`` as every run's (``run_config.default_scenario_seed``)."""
    gp: GPParameters = field(default_factory=GPParameters)
    algorithm: str = "gp"
    scenarios: str = "fixed"
    """``fixed``: every evaluation on the scenario seed; ``fresh``: evaluation ``i`` on a scenario of its own
    (``run_config.evaluation_seed``), as a tree or composition run's. The held-out and validation scenarios
    come from the scenario seed either way."""
    start_trees: tuple[str, ...] = ()
    """The trees (texts, kept as their canonical texts) of every team of the initial population: one tree,
    that every sub-group runs (the run starts from that homogeneous swarm), or K, sub-group g running the
    g-th; the GP then varies them one sub-group at a time. Empty: the 2023 GP's random trees."""

    def __post_init__(self) -> None:
        if self.algorithm not in ALGORITHMS:
            raise ConfigError(f"teams evolve with {' or '.join(ALGORITHMS)}, got {self.algorithm!r}")
        if isinstance(self.task, str):
            object.__setattr__(self, "task", resolve_task(self.task))
        if set(self.task.nodes.actions) != set(ACTIONS):
            raise ConfigError(
                f"task {self.task.name}: nodes.actions must be every action ({', '.join(ACTIONS)}): "
                "evolution draws trees over all of them"
            )
        if self.objective not in OBJECTIVES:
            raise ConfigError(f"objective must be one of {', '.join(OBJECTIVES)}, got {self.objective!r}")
        check_team_size(self.team, self.world().n_robots)
        integer(self.evaluations, "evaluations", 1, error=ConfigError)
        integer(self.seed, "seed", 0, MAX_SEED, error=ConfigError)
        integer(self.trials, "trials", 1, error=ConfigError)
        if self.profile not in PROFILES:
            raise ConfigError(f"profile must be one of {', '.join(PROFILES)}, got {self.profile!r}")
        if self.scenario_seed == -1:
            object.__setattr__(self, "scenario_seed", default_scenario_seed(self.seed))
        integer(self.scenario_seed, "the scenario seed", 0, MAX_SEED, error=ConfigError)
        if self.scenarios not in SCENARIOS:
            raise ConfigError(f"scenarios must be one of {', '.join(SCENARIOS)}, got {self.scenarios!r}")
        object.__setattr__(self, "start_trees", self._canonical_start_trees())
        p = self.gp
        if p.population < 2 or p.elites_per_objective >= p.population or p.tournament < 1:
            raise ConfigError(
                f"the GP needs a population of at least 2, fewer elites ({p.elites_per_objective}) than its "
                f"population ({p.population}) and a tournament of at least 1 ({p.tournament})"
            )

    def _canonical_start_trees(self) -> tuple[str, ...]:
        """The start trees' canonical texts; ``ConfigError`` for a count other than 0, 1 or K, or a tree
        that names a node the task lacks."""
        if isinstance(self.start_trees, str) or not all(isinstance(t, str) for t in self.start_trees):
            raise ConfigError(f"start trees must be a list of tree texts, got {self.start_trees!r}")
        if len(self.start_trees) not in (0, 1, self.team):
            raise ConfigError(
                f"{len(self.start_trees)} start trees for a team of {self.team}; expected one (every "
                f"sub-group starts from it) or {self.team} (sub-group g from the g-th)"
            )
        pset = make_primitive_set(self.conditions)
        texts = []
        for g, text in enumerate(self.start_trees):
            which = "the start tree" if len(self.start_trees) == 1 else f"start tree {g + 1}"
            try:
                texts.append(tree_to_text(tree_from_text(text, pset)))
            except ValueError as error:
                raise ConfigError(
                    f"{which} is not a tree of task {self.task.name}'s nodes: {error}"
                ) from None
        return tuple(texts)

    def start_team(self) -> tuple[str, ...] | None:
        """The team every member of the initial population is (sub-group g's tree at g); None: random."""
        if not self.start_trees:
            return None
        return self.start_trees * self.team if len(self.start_trees) == 1 else self.start_trees

    @classmethod
    def make(
        cls,
        team: int,
        objective: str,
        evaluations: int | None,
        seed: int,
        trials: int = 10,
        profile: str | None = None,
        task: TaskSpec | str = DEFAULT_TASK,
        scenario_seed: int | None = None,
        scenarios: str = "fixed",
        start_trees: Sequence[str] = (),
    ) -> TeamConfig:
        """A configuration with the 2023 GP's parameters and the derating the tree GP of ``task`` would use
        (``RunConfig.make``: the 2024 flat baseline's on a foraging task, else the 2023 one)."""
        task = resolve_task(task)
        derating = "baseline" if "foraging" in task.objectives else "standard"
        return cls(
            team,
            objective,
            DEFAULT_EVALUATIONS if evaluations is None else evaluations,
            seed,
            trials,
            DEFAULT_PROFILE if profile is None else profile,
            task,
            -1 if scenario_seed is None else scenario_seed,
            GPParameters(derating=derating),
            scenarios=scenarios,
            start_trees=tuple(start_trees),
        )

    @property
    def label(self) -> str:
        return f"GP_team{self.team}_{self.objective}"

    def world(self) -> Config:
        """The model of every evaluation: the task's, under the run's profile."""
        return self.task.config(self.profile)

    @property
    def conditions(self) -> tuple[str, ...]:
        """The node set's conditions: the task's, in blackboard order (as a tree run's)."""
        return tuple(c for c in CONDITIONS if c in self.task.nodes.conditions)

    def evaluation_seed(self, index: int) -> int:
        """The scenario of evaluation ``index``: the scenario seed, or under fresh scenarios its own."""
        return scenario_of_evaluation(self.scenarios, self.scenario_seed, self.seed, index)

    def heldout_seeds(self) -> list[int]:
        """The seeds of the best team's held-out evaluations, as a tree run's (``heldout``)."""
        return [heldout_seed(self.scenario_seed, repeat) for repeat in range(HELDOUT_EVALUATIONS)]

    def to_json(self) -> dict:
        gp = asdict(self.gp)
        gp["mutations"] = [list(m) for m in self.gp.mutations]
        document = {
            "kind": KIND,
            "algorithm": self.algorithm,
            "team": self.team,
            "objective": self.objective,
            "evaluations": self.evaluations,
            "seed": self.seed,
            "trials": self.trials,
            "profile": self.profile,
            "task": task_to_record(self.task),
            "scenario_seed": self.scenario_seed,
            "gp": gp,
        }
        # written only when asked for: the configuration files of fixed runs stay as they were
        if self.scenarios != "fixed":
            document["scenarios"] = self.scenarios
        # one tree as its text, as the runs before per-group start trees wrote it; K trees as a list
        if len(self.start_trees) == 1:
            document["start_tree"] = self.start_trees[0]
        elif self.start_trees:
            document["start_tree"] = list(self.start_trees)
        return document

    @classmethod
    def from_json(cls, data: dict) -> TeamConfig:
        try:
            if data.get("kind") != KIND:
                raise ConfigError("not a team run's configuration")
            gp = dict(data["gp"])
            gp["mutations"] = tuple((str(n), float(p)) for n, p in gp["mutations"])
            return cls(
                data["team"],
                str(data["objective"]),
                data["evaluations"],
                data["seed"],
                data["trials"],
                str(data["profile"]),
                task_from_record(data["task"], "config.json: task"),
                data["scenario_seed"],
                GPParameters(**gp),
                str(data["algorithm"]),
                str(data.get("scenarios", "fixed")),
                _start_trees(data.get("start_tree", [])),
            )
        except (KeyError, TypeError, ValueError, AttributeError) as error:
            if isinstance(error, ConfigError):
                raise
            raise ConfigError(f"not a team run's configuration: {error}") from error


def _start_trees(value: object) -> tuple[str, ...]:
    """``config.json``'s ``start_tree``: one text, or a list of them (absent: none)."""
    if isinstance(value, str):
        return (value,)
    if not isinstance(value, list) or not all(isinstance(t, str) for t in value):
        raise ConfigError(f"start_tree must be a tree text or a list of them, got {value!r}")
    return tuple(value)


# Evaluation ------------------------------------------------------------------------------------------------
@dataclass(frozen=True)
class Member(EvaluatedGenome[Texts]):
    """An evaluated team (its trees, ``"trees"`` in JSON), and the sub-group varied to make it (-1: the
    initial population)."""

    group: int = -1

    GENOME = "trees"
    FAILED = FAILED

    @classmethod
    def _genome(cls, values: Sequence) -> Texts:
        return tuple(str(t) for t in values)

    def as_json(self) -> dict:
        return {**super().as_json(), "group": self.group}

    @classmethod
    def from_json(cls, data: dict) -> Member:
        return cls(**cls._fields_from_json(data), group=int(data["group"]))


def evaluate_teams(
    evaluator: Evaluator,
    teams: Sequence[Texts],
    n_robots: int,
    seeds: Sequence[int],
    trials: int,
) -> list[tuple[tuple[float, ...] | None, tuple[float, ...] | None, str]]:
    """Each team (with ``seeds[i]``) evaluated as a heterogeneous swarm of ``n_robots`` over ``trials``
    trials: every objective (``OBJECTIVES`` order) and the descriptors, or None and None with the error."""
    if not teams:
        return []
    requests = [SwarmRequest(team_layout(t, n_robots), s, trials) for t, s in zip(teams, seeds, strict=True)]
    results = evaluator.evaluate(requests)  # type: ignore[arg-type]  # BatchEvaluator takes swarm requests
    out: list[tuple[tuple[float, ...] | None, tuple[float, ...] | None, str]] = []
    for result in results:
        if result.error is None and result.fitness is not None and result.descriptors is not None:
            out.append((tuple(result.fitness), tuple(result.descriptors), ""))
        else:
            out.append((None, None, result.error or "no fitness"))
    return out


def _derated(rule: Derating, sizes: Sequence[int]) -> float:
    """The length derating ``rule`` of a team's mean tree size (the tree GP's of one tree when K = 1)."""
    mean = sum(sizes) / len(sizes)
    if mean > rule.free + rule.span:
        return 0.0
    return 1.0 - max(0.0, mean - rule.free) / rule.span


# The run ---------------------------------------------------------------------------------------------------
class TeamDirectory(RunFolder):
    """The paths of a team run's folder."""

    def __init__(self, root: Path) -> None:
        super().__init__(root, EVALUATION_HEADER, PROGRESS_HEADER)


class TeamRun(CountedRun[Texts, Member]):
    """One team run; create with :meth:`start` or :meth:`resume`, then :meth:`execute` (the loop every run
    shares, ``run_folder.RunLoop``, with what composition and network runs share, ``CountedRun``) and
    :meth:`write_results`."""

    def __init__(self, config: TeamConfig, root: Path, evaluator: Evaluator | None) -> None:
        super().__init__()
        self.config: TeamConfig = config
        self.directory: TeamDirectory = TeamDirectory(root)
        self.evaluator = evaluator
        self.rng = random.Random(derive_seed(config.seed, RUN_ALGORITHM))
        self.pset = make_primitive_set(config.conditions)
        self.n_robots = config.world().n_robots
        self.derating = DERATINGS[config.gp.derating]
        self.produced = 0
        """Teams produced by the generations after the initial population (what the budget counts)."""
        self.generation = 0
        self.population: list[Member] = []
        self.elites: list[Member] = []
        """The best teams so far on derated fitness, best first (``elites_per_objective`` of them)."""
        self.best: Member | None = None
        """The team of highest fitness evaluated (the first among equals)."""
        self.known: dict[Texts, tuple[tuple[float, ...] | None, tuple[float, ...] | None, str]] = {}
        """Teams evaluated by this process (fixed scenario: a team's result never changes)."""
        self._kept: list[Member] = []
        self._children: list[Child] = []
        self._parents: list[Member] = []
        """The generation being evaluated: the elites kept, the children and each child's parent."""
        self._shapes: dict[str, tuple[int, int]] = {}

    # Construction ------------------------------------------------------------------------------------
    @classmethod
    def start(cls, config: TeamConfig, root: Path, evaluator: Evaluator) -> TeamRun:
        """A new run in ``root``, which must not hold a run already (``RunLoop._begin``)."""
        return cls._begin(
            TeamDirectory(root),
            lambda building: cls(config, building, evaluator),
            {"config.json": config.to_json()},
        )

    @classmethod
    def resume(cls, root: Path, evaluator: Evaluator | None) -> TeamRun:
        """The run in ``root`` at its last checkpoint, its CSV files cut back to it (``RunLoop._reopen``)."""
        directory = TeamDirectory(root)
        return cls._resume(
            directory, lambda: cls(TeamConfig.from_json(read_json_object(directory.config)), root, evaluator)
        )

    # State -------------------------------------------------------------------------------------------
    def _state(self) -> dict:
        return {
            "generation": self.generation,
            "rng": generator_state(self.rng),
            "population": [m.as_json() for m in self.population],
            "elites": [m.as_json() for m in self.elites],
            "best": None if self.best is None else self.best.as_json(),
        }

    def _restore(self, state: dict) -> None:
        restore_generator(self.rng, state["rng"])
        self.generation = integer(state["generation"], "generation", 0)
        self.population = [Member.from_json(m) for m in state["population"]]
        self.elites = [Member.from_json(m) for m in state["elites"]]
        self.best = None if state["best"] is None else Member.from_json(state["best"])
        for member in [*self.population, *self.elites, *([self.best] if self.best else [])]:
            if len(member.genome) != self.config.team:
                raise ValueError(f"a team of {len(member.genome)} trees in a run of {self.config.team}")
            for text in member.genome:
                tree_from_text(text, self.pset)  # TreeTextError (a ValueError) for one that does not parse

    # Selection ---------------------------------------------------------------------------------------
    def _shape(self, text: str) -> tuple[int, int]:
        """A tree's nodes and height (DEAP's: a leaf has height 0)."""
        if text not in self._shapes:
            tree = tree_from_text(text, self.pset)
            self._shapes[text] = (len(tree), tree.height)
        return self._shapes[text]

    def _preferred(self, challenger: Member, holder: Member) -> bool:
        """Whether ``challenger`` beats ``holder``: higher fitness derated by the mean size of the team's
        trees, or an exact tie given to a team whose tallest tree is shorter when the holder's is taller than
        ``PARSIMONY_HEIGHT`` (the tree GP's ``operators.preferred`` over a team)."""
        shapes = [[self._shape(t) for t in m.genome] for m in (challenger, holder)]
        members = (challenger, holder)
        a, b = (
            m.rank * _derated(self.derating, [n for n, _ in s]) for m, s in zip(members, shapes, strict=True)
        )
        if a != b:
            return a > b
        tall = [max(h for _, h in s) for s in shapes]
        return tall[1] > PARSIMONY_HEIGHT and tall[0] < tall[1]

    def _best_of(self, candidates: Sequence[Member]) -> Member:
        winner = candidates[0]
        for candidate in candidates[1:]:
            if self._preferred(candidate, winner):
                winner = candidate
        return winner

    def _tournament(self, count: int) -> list[Member]:
        size = self.config.gp.tournament
        pool = self.population
        return [
            self._best_of([pool[self.rng.randrange(len(pool))] for _ in range(size)]) for _ in range(count)
        ]

    # Execution ---------------------------------------------------------------------------------------
    def _ask(self) -> list[Texts]:
        """The teams to evaluate next: the initial population (random trees, or copies of the start tree's
        homogeneous swarm), or the children of the next generation that an operator touched (a generation of
        untouched children only is completed without evaluating)."""
        p = self.config.gp
        if not self.population:
            start = self.config.start_team()
            self._children = [
                Child(
                    start
                    or tuple(
                        tree_to_text(full_tree(self.pset, self.rng, p.init_min_height, p.init_max_height))
                        for _ in range(self.config.team)
                    ),
                    -1,
                    True,
                )
                for _ in range(p.population)
            ]
            return [c.texts for c in self._children]
        while True:
            self._kept = list(self.elites)
            self._parents = self._tournament(p.population - len(self._kept))
            self._children = vary_teams([m.genome for m in self._parents], self.pset, self.rng, p)
            self.produced += len(self._kept) + len(self._children)
            batch = [c.texts for c in self._children if c.touched]
            if batch:
                return batch
            self._next_generation([])
            if self.done:
                return []

    def _evaluate(self, batch: list[Texts]) -> list[Member]:
        """Each team on the run's scenario seed; a team this process evaluated before is answered from memory
        (the same request, the same result). Under fresh scenarios each on its own scenario, nothing
        remembered."""
        if self.evaluator is None:
            raise RunDirectoryError("this run was opened for reading: it has no evaluator")
        if self.config.scenarios == "fresh":
            seeds = [self.config.evaluation_seed(self.evaluations + i) for i in range(len(batch))]
            answers = evaluate_teams(self.evaluator, batch, self.n_robots, seeds, self.config.trials)
        else:
            unseen = list(dict.fromkeys(t for t in batch if t not in self.known))
            seeds = [self.config.scenario_seed] * len(unseen)
            results = evaluate_teams(self.evaluator, unseen, self.n_robots, seeds, self.config.trials)
            self.known.update(zip(unseen, results, strict=True))
            answers = [self.known[texts] for texts in batch]
        k = OBJECTIVES.index(self.config.objective)
        groups = [c.group for c in self._children if c.touched]
        members = []
        for i, (texts, group, answer) in enumerate(zip(batch, groups, answers, strict=True)):
            fitness, descriptors, error = answer
            value = None if fitness is None else fitness[k]
            members.append(Member(texts, value, descriptors, self.evaluations + i, error, group))
        return members

    def _tell(self, batch: list[Texts], answers: list[Member]) -> None:
        self._next_generation(answers)
        self._record(answers)

    def _next_generation(self, answers: list[Member]) -> None:
        """Complete the generation being evaluated with ``answers`` (its touched children, in order; an
        untouched child is its parent, evaluation and all), then keep the elites and the best so far."""
        told = iter(answers)
        children = [
            next(told) if child.touched else self._parents[i] for i, child in enumerate(self._children)
        ]
        self.population = [*self._kept, *children]
        self._kept, self._children, self._parents = [], [], []
        self.generation += 1
        self._keep_best(answers)
        candidates = self.elites + self.population
        ranked: list[Member] = []
        for _ in range(min(self.config.gp.elites_per_objective, len(candidates))):
            others = [c for c in candidates if all(c is not r for r in ranked)]
            ranked.append(self._best_of(others))
        self.elites = ranked
        alive = {text for member in [*self.population, *self.elites] for text in member.genome}
        self._shapes = {text: shape for text, shape in self._shapes.items() if text in alive}

    def _record(self, members: Sequence[Member]) -> None:
        rows = [
            [str(m.evaluation), str(self.config.evaluation_seed(m.evaluation)),
             "" if m.group < 0 else str(m.group), json.dumps(list(m.genome)), *m.logged(len(DESCRIPTORS)),
             m.error]
            for m in members
        ]  # fmt: skip
        self.evaluations += len(members)
        best = "" if self.best is None else number(self.best.fitness)
        self._append_logs(rows, [str(self.evaluations), str(self.generation), best])

    # Results -----------------------------------------------------------------------------------------
    def heldout(self) -> tuple[dict | None, float | None, dict[str, float] | None]:
        """The best team re-scored on the held-out seeds (``TeamConfig.heldout_seeds``, scenarios the run
        never used): what was done, the mean of its fitness, and the mean of every objective (None when a
        held-out evaluation failed). Nothing without an evaluator, before the budget is spent or with no
        team evaluated."""
        if self.evaluator is None or not self.done or self.best is None:
            return None, None, None
        seeds = self.config.heldout_seeds()
        done = {"seeds": seeds, "evaluations": len(seeds), "trials": self.config.trials}
        means = self._means_on([self.best.genome], seeds)[0]
        return done, None if means is None else means[self.config.objective], means

    def _means_on(self, teams: Sequence[Texts], seeds: Sequence[int]) -> list[dict[str, float] | None]:
        """Each team's mean of every objective over the scenarios ``seeds`` (None when one of its
        evaluations failed), all evaluated in one batch."""
        assert self.evaluator is not None
        results = evaluate_teams(
            self.evaluator,
            [team for team in teams for _ in seeds],
            self.n_robots,
            [seed for _ in teams for seed in seeds],
            self.config.trials,
        )
        means: list[dict[str, float] | None] = []
        for start in range(0, len(results), len(seeds)):
            scored = [fitness for fitness, _, _ in results[start : start + len(seeds)] if fitness is not None]
            if len(scored) != len(seeds):
                means.append(None)
                continue
            means.append({o: math.fsum(f[k] for f in scored) / len(seeds) for k, o in enumerate(OBJECTIVES)})
        return means

    def validated(self) -> dict | None:
        """The validated choice (``validation``): the run's best distinct teams on its scenario re-scored on
        the validation scenarios, the one of highest mean re-scored on the held-out scenarios. None where
        :meth:`heldout` gives nothing, or when no candidate could be scored."""
        if self.evaluator is None or not self.done or self.best is None:
            return None
        seeds = validation_seeds(self.config.scenario_seed)
        objective = self.config.objective

        def score(teams: Sequence[Texts]) -> list[float | None]:
            return [None if m is None else m[objective] for m in self._means_on(teams, seeds)]

        scored = [
            (tuple(json.loads(row["trees"])), float(row["fitness"]))
            for row in self.directory.evaluations.read()
            if row["fitness"] != ""
        ]
        chosen = choose_on_validation(best_distinct(scored), score)
        if chosen is None:
            return None
        means = self._means_on([chosen.genome], self.config.heldout_seeds())[0]
        return {
            "trees": list(chosen.genome),
            "fitness": chosen.fitness,
            "validation_fitness": chosen.validation_fitness,
            "heldout_best_fitness": None if means is None else means[objective],
            "heldout_objectives": means,
            "candidates": [
                {"trees": list(team), "fitness": fitness, "validation_fitness": validation}
                for team, fitness, validation in chosen.candidates
            ],
        }

    def write_results(self) -> list[Path]:
        """``summary.json`` and, when a team was evaluated, the best team in ``best/``: its swarm layout
        file and each sub-group's tree."""
        heldout, heldout_best, means = self.heldout()
        summary: dict = {
            "run": self.config.label,
            "kind": KIND,
            "config": self.config.to_json(),
            "robot_groups": list(robot_groups(self.n_robots, self.config.team)),
            "evaluations": self.evaluations,
            "individuals_produced": self.produced,
            "generations": self.generation,
            "finished": self.done,
            "best_fitness": None if self.best is None else self.best.fitness,
            "best": None if self.best is None else self.best.as_json(),
            "heldout": heldout,
            "heldout_best_fitness": heldout_best,
            "heldout_objectives": means,
        }
        validated = self.validated()
        if validated is not None:
            summary["validation"] = validation_settings(self.config.scenario_seed, self.config.trials)
            summary["validated"] = validated
        directory = self.directory
        write_json(directory.summary, summary)
        written = [directory.summary]
        if self.best is not None:
            layout = team_layout(self.best.genome, self.n_robots).as_json()
            written += directory.write_best_swarm(self.config.objective, layout, self.best.genome, "group")
        return written
