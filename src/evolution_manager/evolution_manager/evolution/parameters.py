"""The parameters of the algorithms (model.md, "Algorithms"; paper, table 5), as frozen dataclasses.

A light module (no DEAP, no qdpy) so that command lines can check options before importing the heavy
libraries.
"""

from __future__ import annotations

from dataclasses import dataclass

MAX_TREE_NODES = 1000
"""The most nodes a tree may have: the evaluator's limit (``bt_controller.tree.MAX_NODES``; a test checks
they agree), so that the operators never make a tree the evaluator would refuse."""

MAX_TREE_HEIGHT = 17
"""The tallest tree the operators make: the evaluator's depth limit (``bt_controller.tree.MAX_DEPTH``, a
leaf has height 0 as in DEAP; a test checks they agree). The authors' operators have no height limit
(gp/ea.py:73-77); their selection derates long trees instead (see ``operators.selection_fitness``)."""


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
