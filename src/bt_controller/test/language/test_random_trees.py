"""``random_trees.random_tree`` over a node set of its own: the same draws as before by default."""

from __future__ import annotations

import numpy as np

from bt_controller.language.random_trees import random_tree, random_trees
from bt_controller.language.tree import Composite, Node, parse
from bt_controller.language.vocabulary import ACTIONS, CONDITIONS, CONDITIONS_2024


def _leaves(node: Node) -> list[str]:
    if isinstance(node, Composite):
        return [name for child in node.children for name in _leaves(child)]
    return [str(node)]


def test_the_2024_node_set_is_the_default_and_draws_as_before():
    """The default is the nine conditions every task's world can read (the food kinds' numbered ones are
    asked for), so a seed gives the trees it gave before they came."""
    for seed in range(20):
        a = random_tree(np.random.default_rng(seed), 25)
        b = random_tree(np.random.default_rng(seed), 25, 0.5, 0.0, CONDITIONS_2024, ACTIONS)
        assert a == b
        assert set(_leaves(a)) <= set(CONDITIONS_2024) | set(ACTIONS)
    leaves = {name for text in random_trees(4, 30, conditions=CONDITIONS) for name in _leaves(parse(text))}
    assert {"on_food2", "got_food3"} <= leaves  # every condition when asked


def test_a_node_set_without_got_food_gives_trees_of_the_size_without_it():
    conditions = tuple(c for c in CONDITIONS if c != "got_food")
    rng = np.random.default_rng(3)
    for size in (1, 3, 7, 15, 37):
        for _ in range(50):
            tree = random_tree(rng, size, conditions=conditions, actions=ACTIONS)
            assert tree.size == size and "got_food" not in _leaves(tree)
            assert set(_leaves(tree)) <= set(conditions) | set(ACTIONS)
