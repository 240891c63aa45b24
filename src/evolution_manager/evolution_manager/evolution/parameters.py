"""The parameters of the algorithms (model.md, "Algorithms"; paper, table 5), as frozen dataclasses.

A light module (no DEAP, no qdpy) so that command lines can check options before importing the heavy
libraries.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, fields
from typing import TYPE_CHECKING

from evolution_manager.errors import ConfigError

if TYPE_CHECKING:  # typeshed's name for "an instance of any dataclass"
    from _typeshed import DataclassInstance

MAX_TREE_NODES = 1000
"""The most nodes a tree may have: the evaluator's limit (``bt_controller.language.tree.MAX_NODES``; a test
checks they agree), so that the operators never make a tree the evaluator would refuse."""

MAX_TREE_HEIGHT = 17
"""The tallest tree the operators make: the evaluator's depth limit
(``bt_controller.language.tree.MAX_DEPTH``, a leaf has height 0 as in DEAP; a test checks they agree). The
authors' operators have no height limit (gp/ea.py:73-77); their selection derates long trees instead (see
``operators.selection_fitness``)."""


NODE_SETS: tuple[str, ...] = ("flat", "hierarchical")
"""The node sets a run evolves over (``deap_trees.make_primitive_set``): ``flat``, composites, the run's
conditions, the actions and a library's names if it has one; ``hierarchical``, composites,
``HIERARCHICAL_CONDITIONS`` and a library's names, no actions (the 2024 follow-up's high-level trees)."""

HIERARCHICAL_CONDITIONS: tuple[str, ...] = ("got_food", "on_food", "in_nest")
"""The conditions of the hierarchical node set: ifGotFood, ifOnFood, ifInNest (params.py:134-166 at
a73e4af; ``docs/algorithms.md``, "Hierarchical GP and the flat baseline")."""


@dataclass(frozen=True)
class Derating:
    """A length derating: selection compares fitness x ``1 - max(0, nodes - free) / span`` (the authors'
    parsimony, ``operators`` module docstring): trees of ``free`` nodes or fewer are not favoured (the factor
    is at most 1) and a tree of more than ``free + span`` nodes rates 0."""

    free: int
    span: int

    def __call__(self, nodes: int) -> float:
        if nodes > self.free + self.span:
            return 0.0
        return 1.0 - max(0, nodes - self.free) / self.span


DERATINGS: dict[str, Derating] = {
    "standard": Derating(10, 990),
    "baseline": Derating(64, 6930),
}
"""The named deratings (``docs/algorithms.md``, "Hierarchical GP and the flat baseline"; the authors' code
at a73e4af):
``standard``, 1 - max(0, len - 10)/990, of the 2023 GP and MAP-Elites (gp/ea.py:762-770 at 6c65001) and of
the 2024 hierarchical GP, where a primitive's name is one node (gp/ea.py:949-959); ``baseline``,
1 - max(0, len - 64)/6930, of the 2024 flat baseline over the low-level nodes (params.py:12, 8b049a6; at
a73e4af its lines are commented out in gp/ea.py:953-954, which floor it at 64 nodes and rate a tree of more
than 6,994 nodes 0, as the standard one at 10 and 1,000)."""


def _check_kinds(parameters: DataclassInstance) -> None:
    """Each field of the parameters dataclass of its declared kind (``int``, ``float`` or the mutations'
    ``(name, probability)`` pairs); the algorithms check the ranges. A run's config.json is read into these,
    so a damaged file is refused here in one line rather than failing deep inside an algorithm."""
    for field in fields(parameters):
        value = getattr(parameters, field.name)
        name = f"{type(parameters).__name__}.{field.name}"
        if field.type == "int" and (isinstance(value, bool) or not isinstance(value, int)):
            raise ConfigError(f"{name} must be an integer, got {value!r}")
        if field.type == "float" and (
            isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value)
        ):
            raise ConfigError(f"{name} must be a number, got {value!r}")
        if field.name == "mutations" and not all(
            isinstance(m, tuple) and len(m) == 2 and isinstance(m[0], str) and isinstance(m[1], float)
            for m in value
        ):
            raise ConfigError(f"{name} must be (name, probability) pairs, got {value!r}")


@dataclass(frozen=True)
class GPParameters:
    """GP_o and GP_fnd (model.md, "Algorithms"; paper, table 5)."""

    population: int = 25
    tournament: int = 3
    elites_per_objective: int = 1
    crossover: float = 0.8
    mutations: tuple[tuple[str, float], ...] = (("insert", 0.05), ("shrink", 0.1), ("replace", 0.5))
    init_min_height: int = 1
    init_max_height: int = 4
    max_height: int = MAX_TREE_HEIGHT
    max_nodes: int = MAX_TREE_NODES
    derating: str = "standard"
    """The length derating of every selection (``DERATINGS``): ``baseline`` for the 2024 flat baseline."""

    def __post_init__(self) -> None:
        _check_kinds(self)
        if self.derating not in DERATINGS:
            raise ConfigError(
                f"GPParameters.derating must be one of {', '.join(DERATINGS)}, got {self.derating!r}"
            )


@dataclass(frozen=True)
class QDParameters:
    """MAP-Elites in a qdpy grid with the GP operators as variation (model.md, "Algorithms").

    Parents are drawn by tournaments of ``tournament`` items of the grid on their (derated) fitness, as
    the authors' qdpy/main.py:160 with params.py:38; ``tournament=1`` is the uniform draw of textbook
    MAP-Elites."""

    init_batch: int = 100
    batch: int = 50
    tournament: int = 3
    crossover: float = 0.8
    mutations: tuple[tuple[str, float], ...] = (("insert", 0.05), ("shrink", 0.1), ("replace", 0.5))
    init_min_height: int = 1
    init_max_height: int = 4
    max_height: int = MAX_TREE_HEIGHT
    max_nodes: int = MAX_TREE_NODES

    def __post_init__(self) -> None:
        _check_kinds(self)
