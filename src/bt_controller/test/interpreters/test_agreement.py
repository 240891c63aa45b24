"""The compiled interpreter agrees with the reference tick for tick: status, action, counts and memory."""

from __future__ import annotations

import numba
import numpy as np
from bt_strategies import blackboards, keys, trees
from hypothesis import given, settings
from hypothesis import strategies as st

from bt_controller.interpreters import semantics
from bt_controller.interpreters.agreement import check_random, compare, random_forest
from bt_controller.interpreters.compiled import (
    N_COUNTS,
    CompiledRobot,
    flatten,
    pack,
    run_ticks,
    start_memory,
    tick,
)
from bt_controller.language.random_trees import random_blackboards, random_tree
from bt_controller.language.tree import parse
from bt_controller.language.vocabulary import N_CONDITIONS
from bt_controller.model_settings import CLEAN, PAPER


@settings(max_examples=600, derandomize=True, deadline=None)
@given(
    tree=trees,
    key=keys,
    boards=st.lists(blackboards, min_size=1, max_size=30),
    profile=st.sampled_from((PAPER, CLEAN)),
)
def test_compiled_agrees_with_reference_on_hypothesis_trees(tree, key, boards, profile):
    ref = semantics.ReferenceRobot(tree, key, profile)
    fast = CompiledRobot(tree, key, profile)
    for board in boards:
        assert fast.step(board) == ref.step(board)
        assert list(fast.memory) == ref.memory
        assert list(fast.counts) == ref.counts


def test_compiled_agrees_with_reference_on_10000_random_trees():
    mismatch = check_random(seed=20230412, n_trees=10_000, n_ticks=24)
    assert mismatch is None, str(mismatch)


def test_run_ticks_ends_where_tick_by_tick_ticking_ends():
    rng = np.random.default_rng(11)
    forest = random_forest(rng, 300)
    packed = pack(forest)
    keys_ = rng.integers(0, 2**64, size=300, dtype=np.uint64)
    boards = random_blackboards(rng, 300, 40)
    run = run_ticks(packed, np.arange(300), keys_, boards)
    for r, tree in enumerate(forest):
        robot = semantics.ReferenceRobot(tree, int(keys_[r]))
        results = [robot.step(boards[r, k]) for k in range(40)]
        assert [s for s, _ in results] == run.status[r].tolist()
        assert [a for _, a in results] == run.action[r].tolist()
        assert robot.counts == run.counts[r].tolist()
        assert robot.memory == run.memory[r, : tree.size].tolist()


def test_a_planted_difference_is_reported(monkeypatch):
    forest = [parse("seq(on_food, forward)")]
    boards = np.ones((1, 3, 8), bool)
    assert compare(forest, np.array([1], np.uint64), boards) is None
    real_tick = semantics.tick

    def wrong_tick(*args):
        status, action = real_tick(*args)
        return (status, action) if args[4] < 2 else (1 - status, action)

    monkeypatch.setattr(semantics, "tick", wrong_tick)
    mismatch = compare(forest, np.array([1], np.uint64), boards)
    assert mismatch is not None and mismatch.tick_index == 2 and mismatch.what == "status and action"
    assert "seq(on_food, forward)" in str(mismatch)


def test_tick_accepts_int_blackboards_and_leaves_other_rows_alone():
    rng = np.random.default_rng(3)
    forest = [random_tree(rng, 30) for _ in range(3)]
    packed = pack(forest)
    boards = random_blackboards(rng, 3, 10)
    a = run_ticks(packed, [0, 1, 2], np.arange(3, dtype=np.uint64), boards)
    b = run_ticks(packed, [0, 1, 2], np.arange(3, dtype=np.uint64), boards.astype(np.uint8))
    assert np.array_equal(a.status, b.status) and np.array_equal(a.counts, b.counts)
    c = run_ticks(packed, [1], np.arange(1, 2, dtype=np.uint64), boards[1:2])
    assert np.array_equal(c.status[0], a.status[1])


@numba.njit
def _simulator_like_kernel(tree, key, n_ticks):
    """A kernel in another module calling ``tick`` as the simulator does: one robot, boards from a rule."""
    memory = np.empty(len(tree.op), np.int8)
    start_memory(tree.op, memory, PAPER)
    counts = np.zeros(N_COUNTS, np.int64)
    blackboard = np.zeros(N_CONDITIONS, np.bool_)
    actions = np.empty(n_ticks, np.int64)
    for k in range(n_ticks):
        blackboard[k % N_CONDITIONS] = not blackboard[k % N_CONDITIONS]
        _, actions[k] = tick(tree, memory, blackboard, key, k, counts)
    return actions, counts


def test_tick_is_callable_from_another_kernel():
    tree = random_tree(np.random.default_rng(5), 30)
    flat = flatten(tree)
    actions, counts = _simulator_like_kernel(flat, np.uint64(99), 40)
    ref = semantics.ReferenceRobot(tree, 99)
    board = [False] * N_CONDITIONS
    for k in range(40):
        board[k % N_CONDITIONS] = not board[k % N_CONDITIONS]
        assert ref.step(board)[1] == actions[k]
    assert ref.counts == counts.tolist()
