"""GP_o, GP_fnd and MAP-Elites (QD_o) as ask/tell objects.

An algorithm proposes a batch of tree texts with :meth:`ask` and is told the evaluator's results for
exactly that batch, in order, with :meth:`tell`; calling them out of order raises :class:`AskTellError`.
Algorithms never evaluate, never write files and never read the clock: a run loop, a ROS 2 node or a test
drives them. Each owns a ``random.Random`` seeded from its configuration (see :mod:`.operators`), and
:meth:`to_state` / :meth:`from_state` turn it into JSON-able data and back, between a ``tell`` and the next
``ask``, so that a resumed run continues exactly where it stopped.

A budget is part of every algorithm: it counts the individuals produced by the generations (GP) or
batches (MAP-Elites) after the initial population, as the authors' generations do (paper, table 5: 1000
generations of 25 individuals, 500 batches of 50), whether or not an individual needs evaluating (an
offspring no operator touched keeps its parent's fitness and is not asked for). The initial population
(25, 75 or 100 trees) comes on top. :attr:`done` says when the budget is spent; the generation or batch
that reaches it is completed. Trees whose evaluation failed (``result.error``) never enter an archive and
lose every tournament.
"""

from __future__ import annotations

import random
from collections.abc import Sequence
from dataclasses import dataclass

from bt_controller.language import CONDITIONS_2023, Library
from bt_controller.validate import integer
from evolution_manager.errors import AskTellError, ConfigError, EvolutionError
from evolution_manager.evolution.archive import Entry, Repertoire, SimplifiedForms
from evolution_manager.evolution.deap_trees import (
    OBJECTIVES,
    BehaviourTree,
    make_primitive_set,
    tree_from_text,
    tree_to_text,
)
from evolution_manager.evolution.operators import best_of, full_tree, tournament, vary
from evolution_manager.evolution.parameters import DERATINGS, GPParameters, QDParameters
from evolution_manager.evolution.run_folder import generator_state, restore_generator
from swarm_sim.model import fitness_ceiling

FAILED = -1.0
"""The fitness given, on every objective, to a tree whose evaluation failed: below every real fitness."""


@dataclass(frozen=True)
class Outcome:
    """What an algorithm needs to know of one evaluation (see
    ``swarm_sim.evaluation.batch.EvaluationResult``)."""

    fitness: tuple[float, ...] | None
    """Every objective (``OBJECTIVES`` order), or None for a failed evaluation."""
    descriptors: tuple[float, ...] | None
    """(movement, rotation, conditionality), or None for a failed evaluation."""
    error: str | None = None

    @property
    def ok(self) -> bool:
        return self.measured() is not None

    def measured(self) -> tuple[tuple[float, ...], tuple[float, ...]] | None:
        """``(fitness, descriptors)`` of a successful evaluation; None for a failed one."""
        if self.error is None and self.fitness is not None and self.descriptors is not None:
            return self.fitness, self.descriptors
        return None

    def objective(self, k: int) -> float:
        """Objective ``k`` of a successful evaluation (``EvolutionError`` for a failed one)."""
        measured = self.measured()
        if measured is None:
            raise EvolutionError(f"a failed evaluation has no fitness: {self.error}")
        return measured[0][k]


def as_outcome(result: object) -> Outcome:
    """An evaluator's result (anything with ``fitness``, ``descriptors`` and ``error``) as an Outcome."""
    fitness = getattr(result, "fitness", None)
    descriptors = getattr(result, "descriptors", None)
    error = getattr(result, "error", None)
    return Outcome(
        tuple(float(v) for v in fitness) if fitness is not None else None,
        tuple(float(v) for v in descriptors) if descriptors is not None else None,
        error,
    )


def _check_probability(value: float, name: str) -> None:
    if not 0.0 <= value <= 1.0:
        raise ConfigError(f"{name} must be a probability in [0, 1], got {value}")


class AskTell:
    """The ask/tell protocol, the budget and the generator shared by every algorithm."""

    name = "base"

    def __init__(
        self,
        budget: int,
        seed: int,
        conditions: Sequence[str] = CONDITIONS_2023,
        library: Library | None = None,
        nodes: str = "flat",
    ) -> None:
        integer(budget, "the budget (evaluations)", 1, error=ConfigError)
        self.budget = budget
        self.seed = seed
        self.rng = random.Random(seed)
        self.library = library
        """The primitive library whose names are terminals (None: none)."""
        try:
            self.pset = make_primitive_set(conditions, library, nodes)
        except ValueError as error:
            raise ConfigError(str(error)) from None
        self.evaluations = 0
        self.produced = 0
        """Individuals produced after the initial population: what the budget counts."""
        self._asked: list[BehaviourTree] | None = None
        self._asked_texts: list[str] = []

    @property
    def done(self) -> bool:
        """Whether the budget is spent."""
        return self.produced >= self.budget

    def ask(self) -> list[str]:
        """The next batch of tree texts to evaluate (possibly empty when the last generation needed none)."""
        if self._asked is not None:
            raise AskTellError("ask() called twice: tell() the results of the last batch first")
        if self.done:
            raise AskTellError(f"the budget of {self.budget} individuals is spent")
        batch = self._propose()
        self._asked = batch
        self._asked_texts = [tree_to_text(tree) for tree in batch]
        return list(self._asked_texts)

    def tell(self, results: Sequence[object]) -> None:
        """The evaluator's results for the last batch, in the order it was asked."""
        if self._asked is None:
            raise AskTellError("tell() called without a batch: call ask() first")
        if len(results) != len(self._asked):
            raise AskTellError(
                f"tell() needs {len(self._asked)} results, one per asked tree, got {len(results)}"
            )
        batch, self._asked = self._asked, None
        outcomes = [as_outcome(r) for r in results]
        for tree, outcome in zip(batch, outcomes, strict=True):
            tree.fitness.values = outcome.fitness if outcome.ok else (FAILED,) * len(OBJECTIVES)
            tree.descriptors = outcome.descriptors if outcome.ok else None
        self.evaluations += len(batch)
        self._accept(batch, outcomes, self._asked_texts)

    # State -------------------------------------------------------------------------------------------
    def restore(self, state: dict) -> None:
        """Continue from ``to_state()``'s data (each algorithm restores its own)."""
        raise NotImplementedError

    def to_state(self) -> dict:
        """Everything needed to continue, as JSON-able data (only between a tell and the next ask)."""
        if self._asked is not None:
            raise AskTellError("to_state() between ask() and tell(): the asked batch would be lost")
        return {
            "algorithm": self.name,
            "budget": self.budget,
            "seed": self.seed,
            "evaluations": self.evaluations,
            "produced": self.produced,
            "rng": generator_state(self.rng),
            **self._state(),
        }

    def _restore_common(self, state: dict) -> None:
        if state.get("algorithm") != self.name:
            raise ValueError(f"a state of {state.get('algorithm')!r} cannot restore {self.name!r}")
        self.budget = int(state["budget"])
        self.evaluations = int(state["evaluations"])
        self.produced = int(state.get("produced", state["evaluations"]))
        restore_generator(self.rng, state["rng"])

    def _tree(
        self, text: str, fitness: Sequence[float] | None, descriptors: Sequence[float] | None = None
    ) -> BehaviourTree:
        tree = tree_from_text(text, self.pset, library=self.library)
        if fitness is not None:
            tree.fitness.values = tuple(float(v) for v in fitness)
        if descriptors is not None:
            tree.descriptors = tuple(float(v) for v in descriptors)
        return tree

    @staticmethod
    def _record(tree: BehaviourTree) -> list:
        return [
            tree_to_text(tree),
            list(tree.fitness.values) if tree.fitness.valid else None,
            list(tree.descriptors) if tree.descriptors is not None else None,
        ]

    # For subclasses ----------------------------------------------------------------------------------
    def _propose(self) -> list[BehaviourTree]:
        raise NotImplementedError

    def _accept(self, batch: list[BehaviourTree], outcomes: list[Outcome], texts: list[str]) -> None:
        raise NotImplementedError

    def _state(self) -> dict:
        raise NotImplementedError


class GeneticProgramming(AskTell):
    """Generational GP with tournaments, the parsimony tie-break and elitism.

    ``objectives`` are indices into ``OBJECTIVES``. With one objective this is GP_o (population 25,
    tournament 3, one elite). With several (the paper's three; any set works alike) it is GP_fnd: every
    tournament compares on an objective drawn uniformly, and the best tree found so far on each objective is
    kept as an elite (population 75, tournament 5). A generation copies the elites, fills the population with
    varied tournament winners
    and asks for the evaluation of every offspring that an operator touched; untouched ones keep their
    parent's fitness (as DEAP's ``eaSimple``).
    """

    name = "gp"

    def __init__(
        self,
        objectives: Sequence[int],
        budget: int,
        seed: int,
        parameters: GPParameters,
        conditions: Sequence[str] = CONDITIONS_2023,
        library: Library | None = None,
        nodes: str = "flat",
    ) -> None:
        super().__init__(budget, seed, conditions, library, nodes)
        objectives = tuple(int(o) for o in objectives)
        if (
            not objectives
            or any(o not in range(len(OBJECTIVES)) for o in objectives)
            or len(set(objectives)) != len(objectives)
        ):
            raise ConfigError(f"objectives must be distinct indices into {OBJECTIVES}, got {objectives}")
        p = parameters
        elites = p.elites_per_objective * len(objectives)
        if p.population < 2 or elites >= p.population:
            raise ConfigError(
                f"the population ({p.population}) must exceed the elites ({elites}) and be >= 2"
            )
        if p.tournament < 1:
            raise ConfigError(f"the tournament size must be >= 1, got {p.tournament}")
        _check_probability(p.crossover, "the crossover probability")
        for mutation, probability in p.mutations:
            _check_probability(probability, f"the {mutation} mutation probability")
        if not 1 <= p.init_min_height <= p.init_max_height <= p.max_height:
            raise ConfigError("heights must satisfy 1 <= init_min_height <= init_max_height <= max_height")
        self.objectives = objectives
        self.parameters = p
        self.derating = DERATINGS[p.derating]
        """The length derating of every selection (``parameters.DERATINGS``)."""
        self.population: list[BehaviourTree] = []
        self.elites: list[list[BehaviourTree]] = [[] for _ in objectives]  # per objective, best first
        self.generation = 0
        self._offspring: list[BehaviourTree] = []
        self._completed: list[list[BehaviourTree]] = []

    def _propose(self) -> list[BehaviourTree]:
        p = self.parameters
        if not self.population:
            self._offspring = [
                full_tree(self.pset, self.rng, p.init_min_height, p.init_max_height)
                for _ in range(p.population)
            ]
            return list(self._offspring)
        while True:
            kept = [tree.clone() for trees in self.elites for tree in trees]
            parents = tournament(
                self.population,
                p.population - len(kept),
                p.tournament,
                self.rng,
                self.objectives,
                self.derating,
            )
            offspring = vary(
                parents, self.pset, self.rng, p.crossover, p.mutations, p.max_height, p.max_nodes
            )
            self._offspring = kept + offspring
            self.produced += len(self._offspring)
            batch = [tree for tree in offspring if not tree.fitness.valid]
            if batch:
                return batch
            self._next_generation(self._offspring)  # nothing changed: the generation is complete as it is
            if self.done:
                return []

    def _accept(self, batch: list[BehaviourTree], outcomes: list[Outcome], texts: list[str]) -> None:
        self._next_generation(self._offspring)

    def take_generations(self) -> list[list[BehaviourTree]]:
        """The populations of the generations completed since the last call, generation 1 onwards (the
        initial population is not included): the individuals the authors' analysis offers to the
        repertoire grid (charts/analysis.py:96-121)."""
        taken, self._completed = self._completed, []
        return taken

    def _next_generation(self, population: list[BehaviourTree]) -> None:
        if self.population:  # not the initial population
            self._completed.append(population)
        self.population = population
        self._offspring = []
        self.generation += 1
        for k, objective in enumerate(self.objectives):
            candidates = self.elites[k] + self.population
            ranked: list[BehaviourTree] = []
            for _ in range(min(self.parameters.elites_per_objective, len(candidates))):
                others = [c for c in candidates if all(c is not r for r in ranked)]
                winner = best_of(others, objective, self.derating)
                ranked.append(winner)
            self.elites[k] = [tree.clone() for tree in ranked]

    def best(self, objective: int) -> BehaviourTree | None:
        """The best tree found so far on ``objective`` (one of this algorithm's objectives)."""
        k = self.objectives.index(objective)
        return self.elites[k][0] if self.elites[k] else None

    def _state(self) -> dict:
        return {
            "objectives": list(self.objectives),
            "generation": self.generation,
            "population": [self._record(t) for t in self.population],
            "elites": [[self._record(t) for t in trees] for trees in self.elites],
        }

    def restore(self, state: dict) -> None:
        """Continue from a state written by :meth:`to_state` of an algorithm with the same configuration."""
        self._restore_common(state)
        if tuple(state["objectives"]) != self.objectives:
            raise ValueError(
                f"the state is for objectives {state['objectives']}, not {list(self.objectives)}"
            )
        self.generation = int(state["generation"])
        self.population = [self._tree(*record) for record in state["population"]]
        self.elites = [[self._tree(*record) for record in trees] for trees in state["elites"]]


class MapElites(AskTell):
    """MAP-Elites (QD_o): a qdpy grid of 8 x 8 x 8 bins, 3 trees per bin, as the population.

    First ``init_batch`` random full trees; then, batch after batch, ``batch`` parents, each the winner of a
    tournament of ``tournament`` items drawn uniformly with replacement from the archive (derated fitness,
    see :mod:`.operators`; the authors' qdpy/ea.py:536-555), are varied by the GP operators (qdpy's
    ``qdSimple`` with DEAP's ``varAnd``) and every touched offspring is evaluated and offered to the
    archive on ``objective``. A tree the archive already holds is not stored again (qdpy/ea.py:394); with
    ``forms`` (the ``clean`` profile) nor is a tree whose simplified form is already in its bin
    (:class:`~evolution_manager.evolution.archive.Repertoire`). Items are drawn in the archive's canonical
    order (bin index, then arrival), so the draw does not depend on the order in which qdpy keeps its items.
    """

    name = "qd"

    def __init__(
        self,
        objective: int,
        budget: int,
        seed: int,
        parameters: QDParameters,
        conditions: Sequence[str] = CONDITIONS_2023,
        library: Library | None = None,
        forms: SimplifiedForms | None = None,
        nodes: str = "flat",
    ) -> None:
        super().__init__(budget, seed, conditions, library, nodes)
        if objective not in range(len(OBJECTIVES)):
            raise ConfigError(f"objective must be an index into {OBJECTIVES}, got {objective}")
        p = parameters
        if p.init_batch < 1 or p.batch < 1:
            raise ConfigError(f"batch sizes must be >= 1, got init {p.init_batch} and batch {p.batch}")
        _check_probability(p.crossover, "the crossover probability")
        for mutation, probability in p.mutations:
            _check_probability(probability, f"the {mutation} mutation probability")
        if not 1 <= p.init_min_height <= p.init_max_height <= p.max_height:
            raise ConfigError("heights must satisfy 1 <= init_min_height <= init_max_height <= max_height")
        if p.tournament < 1:
            raise ConfigError(f"the tournament size must be >= 1, got {p.tournament}")
        self.objective = objective
        self.parameters = p
        self.archive = Repertoire(forms=forms, fitness_max=fitness_ceiling(OBJECTIVES[objective]))
        self.batches = 0

    def _random_batch(self, size: int) -> list[BehaviourTree]:
        p = self.parameters
        return [full_tree(self.pset, self.rng, p.init_min_height, p.init_max_height) for _ in range(size)]

    def _propose(self) -> list[BehaviourTree]:
        p = self.parameters
        entries = self.archive.entries()
        if not entries:
            if self.batches:  # every tree so far failed: start again, counted
                self.produced += p.batch
                return self._random_batch(p.batch)
            return self._random_batch(p.init_batch)
        while True:
            parents = [self._tournament(entries) for _ in range(p.batch)]
            offspring = vary(
                parents, self.pset, self.rng, p.crossover, p.mutations, p.max_height, p.max_nodes
            )
            self.produced += len(offspring)
            batch = [tree for tree in offspring if not tree.fitness.valid]
            if batch or self.done:
                return batch

    def _tournament(self, entries: list[Entry]) -> BehaviourTree:
        size = self.parameters.tournament
        aspirants = [self._parent(entries[self.rng.randrange(len(entries))]) for _ in range(size)]
        return best_of(aspirants, self.objective)

    def _parent(self, entry: Entry) -> BehaviourTree:
        if entry.genome is None:
            entry.genome = tree_from_text(entry.tree, self.pset, library=self.library)
        tree = entry.genome
        assert isinstance(tree, BehaviourTree), "MAP-Elites keeps its DEAP tree as an entry's genome"
        tree.fitness.values = (entry.value,) * len(OBJECTIVES)
        return tree

    def _accept(self, batch: list[BehaviourTree], outcomes: list[Outcome], texts: list[str]) -> None:
        self.batches += 1
        first = self.evaluations - len(batch)
        for offset, (tree, outcome) in enumerate(zip(batch, outcomes, strict=True)):
            measured = outcome.measured()
            if measured is not None:
                fitness, descriptors = measured
                self.archive.offer(texts[offset], fitness[self.objective], descriptors, first + offset, tree)

    def _state(self) -> dict:
        return {"objective": self.objective, "batches": self.batches, "archive": self.archive.to_state()}

    def restore(self, state: dict) -> None:
        """Continue from a state written by :meth:`to_state` of an algorithm with the same configuration."""
        self._restore_common(state)
        if int(state["objective"]) != self.objective:
            raise ValueError(f"the state is for objective {state['objective']}, not {self.objective}")
        self.batches = int(state["batches"])
        self.archive = Repertoire.from_state(state["archive"], self.archive.forms, self.archive.fitness_max)
