"""Random trees and blackboards for tests, benchmarks and measurements (not the evolution's initialisation,
which is DEAP's, in ``evolution_manager.evolution.deap_trees``). Every function takes its own generator or
seed.

``random_tree`` (exactly ``size`` nodes) and ``random_tree_grow`` (at most ``max_depth`` deep) build trees;
``random_trees`` gives tree text for requests; ``random_blackboards`` gives blackboards to tick against."""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from bt_controller.language.tree import Action, Composite, Condition, Node
from bt_controller.language.vocabulary import (
    ACTIONS,
    COMPOSITES,
    CONDITIONS_2024,
    MAX_CHILDREN,
    MIN_CHILDREN,
    N_CONDITIONS,
)


def random_leaf(
    rng: np.random.Generator,
    p_condition: float = 0.5,
    conditions: Sequence[str] = CONDITIONS_2024,
    actions: Sequence[str] = ACTIONS,
) -> Node:
    """A uniformly chosen condition (with probability ``p_condition``) or action, of ``conditions`` and
    ``actions`` (by default the 2024 node set, which every task's world can read, and with which every
    seed gives the trees it gave before the food kinds' conditions came; a task's node set, or
    ``vocabulary.CONDITIONS`` for all of them)."""
    if rng.random() < p_condition:
        return Condition(conditions[int(rng.integers(len(conditions)))])
    return Action(actions[int(rng.integers(len(actions)))])


def random_tree(
    rng: np.random.Generator,
    size: int,
    p_condition: float = 0.5,
    p_success: float = 0.0,
    conditions: Sequence[str] = CONDITIONS_2024,
    actions: Sequence[str] = ACTIONS,
) -> Node:
    """A random tree of exactly ``size`` nodes (``size`` is 1 or at least 3: 2 nodes make no tree without
    decorators); with ``p_success`` > 0 an inner node is a success decorator with that probability (any
    ``size`` >= 1 then works). Its leaves are of ``conditions`` and ``actions`` (``random_leaf``)."""
    if size < 1 or (size == 2 and p_success <= 0.0):
        raise ValueError(f"no tree has {size} nodes; size must be 1 or at least 3")
    if size == 1:
        return random_leaf(rng, p_condition, conditions, actions)
    if p_success > 0.0 and (size == 2 or rng.random() < p_success):
        return Composite(
            "success", (random_tree(rng, size - 1, p_condition, p_success, conditions, actions),)
        )
    rest = size - 1
    while True:
        n = int(rng.integers(MIN_CHILDREN, min(MAX_CHILDREN, rest) + 1))
        # Split ``rest`` nodes among ``n`` children, none of them 2 nodes unless decorators make such trees.
        cuts: np.ndarray | list[int] = []
        if n > 1:
            cuts = np.sort(rng.choice(np.arange(1, rest), size=n - 1, replace=False))
        parts = np.diff(np.concatenate(([0], cuts, [rest]))).astype(int)
        if p_success > 0.0 or np.all(parts != 2):
            break
    kind = COMPOSITES[rng.integers(len(COMPOSITES))]
    return Composite(
        kind, tuple(random_tree(rng, int(p), p_condition, p_success, conditions, actions) for p in parts)
    )


def random_tree_grow(
    rng: np.random.Generator, max_depth: int, p_leaf: float = 0.3, p_success: float = 0.0
) -> Node:
    """A random tree at most ``max_depth`` deep: the root is a composite (unless ``max_depth`` is 0) and
    every node below it is a leaf with probability ``p_leaf`` (always at ``max_depth``); with ``p_success`` >
    0 an inner node is a success decorator with that probability (no draw is made for it otherwise, so the
    trees of a seed are as before)."""
    return _grow(rng, max_depth, 0.0 if max_depth > 0 else 1.0, p_leaf, p_success)


def _grow(rng: np.random.Generator, max_depth: int, p_here: float, p_leaf: float, p_success: float) -> Node:
    if max_depth == 0 or rng.random() < p_here:
        return random_leaf(rng)
    if p_success > 0.0 and rng.random() < p_success:
        return Composite("success", (_grow(rng, max_depth - 1, p_leaf, p_leaf, p_success),))
    n = int(rng.integers(MIN_CHILDREN, MAX_CHILDREN + 1))
    kind = COMPOSITES[rng.integers(len(COMPOSITES))]
    return Composite(kind, tuple(_grow(rng, max_depth - 1, p_leaf, p_leaf, p_success) for _ in range(n)))


def random_blackboards(rng: np.random.Generator, n_robots: int, n_ticks: int) -> np.ndarray:
    """Blackboards (robots, ticks, ``N_CONDITIONS``) bool; each robot has its own probability of true per
    condition (no world facts: any combination)."""
    p_true = rng.random((n_robots, 1, N_CONDITIONS))
    return rng.random((n_robots, n_ticks, N_CONDITIONS)) < p_true


def random_trees(
    seed: int,
    count: int,
    min_size: int = 10,
    max_size: int = 60,
    p_success: float = 0.0,
    conditions: Sequence[str] = CONDITIONS_2024,
) -> list[str]:
    """``count`` random tree texts of ``min_size + 1`` to ``max_size`` nodes (``random_tree``, over
    ``conditions``; with ``p_success`` > 0 some inner nodes are success decorators), reproducible from
    ``seed``."""
    rng = np.random.default_rng(seed)
    sizes = [int(rng.integers(min_size + 1, max_size + 1)) for _ in range(count)]
    size_of = [3 if size == 2 and p_success <= 0 else size for size in sizes]
    return [str(random_tree(rng, size, p_success=p_success, conditions=conditions)) for size in size_of]
