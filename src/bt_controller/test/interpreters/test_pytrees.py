"""The py_trees mapping agrees with the reference tick for tick (status, action, counts and memory)."""

from __future__ import annotations

import numpy as np
import py_trees
from bt_strategies import blackboards, keys, trees
from hypothesis import given, settings
from hypothesis import strategies as st

from bt_controller.interpreters.agreement import random_forest
from bt_controller.interpreters.pytrees import PyTreesRobot
from bt_controller.interpreters.semantics import ReferenceRobot
from bt_controller.language.random_trees import random_blackboards
from bt_controller.language.tree import parse
from bt_controller.model_settings import CLEAN, PAPER


def _agree(tree, key, boards) -> None:
    for profile in (PAPER, CLEAN):
        ref = ReferenceRobot(tree, key, profile)
        pyt = PyTreesRobot(tree, key, profile)
        for k, board in enumerate(boards):
            assert pyt.step(board) == ref.step(board), (str(tree), k, profile)
            assert pyt.memory == ref.memory, (str(tree), k, profile)
            assert pyt.counts == ref.counts, (str(tree), k, profile)


@settings(max_examples=300, derandomize=True, deadline=None)
@given(tree=trees, key=keys, boards=st.lists(blackboards, min_size=1, max_size=20))
def test_py_trees_agrees_with_reference_on_hypothesis_trees(tree, key, boards):
    _agree(tree, key, boards)


def test_py_trees_agrees_with_reference_on_random_trees():
    rng = np.random.default_rng(7)
    forest = random_forest(rng, 300)
    boards = random_blackboards(rng, len(forest), 24).tolist()
    for tree, key, robot_boards in zip(forest, range(len(forest)), boards, strict=True):
        _agree(tree, key, robot_boards)


def test_py_trees_display_shows_our_tree():
    robot = PyTreesRobot(parse("sel(seq(in_nest, stop), prob(forward, reverse))"), 1)
    robot.step([False, True] + [False] * 6)
    text = py_trees.display.unicode_tree(robot.root, show_status=True)
    assert "in_nest" in text and "prob" in text
