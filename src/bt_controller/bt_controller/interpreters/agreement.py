"""One checker for the two interpreters: the compiled one must agree with the reference on every tick.

Used by the property tests (with a fixed seed) and by ``bench --agreement N`` for longer runs.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from bt_controller.interpreters import semantics
from bt_controller.interpreters.compiled import N_COUNTS, new_memory, pack, tick_batch
from bt_controller.language.random_trees import random_blackboards, random_tree, random_tree_grow
from bt_controller.language.tree import Node


@dataclass(frozen=True)
class Mismatch:
    """The first tick on which the interpreters disagree."""

    tree: str
    key: int
    tick_index: int
    what: str
    reference: object
    compiled: object

    def __str__(self) -> str:
        return (
            f"{self.what} differs at tick {self.tick_index} of {self.tree} (key {self.key}): "
            f"reference {self.reference}, compiled {self.compiled}"
        )


def random_forest(
    rng: np.random.Generator, n_trees: int, max_size: int = 60, p_success: float = 0.1
) -> list[Node]:
    """Random trees for agreement checks: half of exact random sizes, half grown to random depths; an inner
    node is a success decorator with probability ``p_success``."""
    forest: list[Node] = []
    for i in range(n_trees):
        if i % 2:
            size = int(rng.integers(1, max_size))
            forest.append(random_tree(rng, size, p_success=p_success))
        else:
            depth = int(rng.integers(0, 7))
            p_leaf = float(rng.uniform(0.1, 0.6))
            forest.append(random_tree_grow(rng, depth, p_leaf=p_leaf, p_success=p_success))
    return forest


def compare(forest: Sequence[Node], keys: np.ndarray, boards: np.ndarray) -> Mismatch | None:
    """Tick tree ``i`` of ``forest`` as robot ``i`` with key ``keys[i]`` over ``boards[i]`` (ticks, 8) in
    both interpreters; return the first disagreement (status, action, memory or counts), or None."""
    n_robots, n_ticks = boards.shape[0], boards.shape[1]
    packed = pack(forest)
    robot_tree = np.arange(n_robots, dtype=np.int64)
    keys = np.asarray(keys, np.uint64)
    memory = new_memory(packed, robot_tree)
    counts = np.zeros((n_robots, N_COUNTS), np.int64)
    status = np.empty(n_robots, np.int8)
    action = np.empty(n_robots, np.int8)
    ref_memory = [semantics.new_memory(t) for t in forest]
    ref_counts = [semantics.new_counts() for _ in forest]
    for k in range(n_ticks):
        tick_batch(packed, robot_tree, memory, boards[:, k], keys, k, counts, status, action)
        for r, tree in enumerate(forest):
            expected = semantics.tick(tree, ref_memory[r], boards[r, k], int(keys[r]), k, ref_counts[r])
            checks = (
                ("status and action", expected, (int(status[r]), int(action[r]))),
                ("memory", ref_memory[r], memory[r, : tree.size].tolist()),
                ("counts", ref_counts[r], counts[r].tolist()),
            )
            for what, want, got in checks:
                if want != got:
                    return Mismatch(str(tree), int(keys[r]), k, what, want, got)
    return None


def check_random(seed: int, n_trees: int, n_ticks: int = 40) -> Mismatch | None:
    """``compare`` on ``n_trees`` random trees with random keys and blackboards drawn from ``seed``."""
    rng = np.random.default_rng(seed)
    forest = random_forest(rng, n_trees)
    keys = rng.integers(0, 2**64, size=n_trees, dtype=np.uint64)
    boards = random_blackboards(rng, n_trees, n_ticks)
    return compare(forest, keys, boards)
