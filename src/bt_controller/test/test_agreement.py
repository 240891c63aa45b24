"""The compiled interpreter agrees with the reference tick for tick: status, action, counts and memory."""

from __future__ import annotations

import numba
import numpy as np
from bt_strategies import blackboards, keys, trees
from hypothesis import given, settings
from hypothesis import strategies as st

from bt_controller import reference
from bt_controller.compiled import (
    N_COUNTS,
    CompiledRobot,
    flatten,
    new_memory,
    pack,
    reset_memory,
    run_ticks,
    tick,
    tick_batch,
)
from bt_controller.random_trees import random_blackboards, random_tree, random_tree_grow


@settings(max_examples=1500, derandomize=True, deadline=None)
@given(tree=trees, key=keys, boards=st.lists(blackboards, min_size=1, max_size=30))
def test_compiled_agrees_with_reference_on_hypothesis_trees(tree, key, boards):
    ref = reference.ReferenceRobot(tree, key)
    fast = CompiledRobot(tree, key)
    for board in boards:
        assert fast.step(board) == ref.step(board)
        assert list(fast.memory) == ref.memory
        assert list(fast.counts) == ref.counts


def _random_forest(rng: np.random.Generator, n: int) -> list:
    trees_ = []
    for i in range(n):
        if i % 2:
            size = int(rng.integers(1, 60))
            trees_.append(random_tree(rng, size if size != 2 else 3))
        else:
            trees_.append(random_tree_grow(rng, int(rng.integers(0, 7)), p_leaf=float(rng.uniform(0.1, 0.6))))
    return trees_


def test_compiled_agrees_with_reference_on_10000_random_trees():
    rng = np.random.default_rng(20230412)
    n_trees, n_ticks = 10_000, 24
    forest = _random_forest(rng, n_trees)
    packed = pack(forest)
    robot_tree = np.arange(n_trees)
    keys_ = rng.integers(0, 2**64, size=n_trees, dtype=np.uint64)
    boards = random_blackboards(rng, n_trees, n_ticks)
    memory = new_memory(packed, robot_tree)
    counts = np.zeros((n_trees, N_COUNTS), np.int64)
    status = np.empty(n_trees, np.int8)
    action = np.empty(n_trees, np.int8)
    ref_memory = [reference.new_memory(t) for t in forest]
    ref_counts = [reference.new_counts() for _ in forest]
    for k in range(n_ticks):
        tick_batch(
            packed.op, packed.arg, packed.first, packed.nchild, packed.children, packed.node_offset,
            packed.child_offset, robot_tree, memory, boards[:, k], keys_, k, counts, status, action,
        )  # fmt: skip
        for r, tree in enumerate(forest):
            expected = reference.tick(tree, ref_memory[r], boards[r, k], int(keys_[r]), k, ref_counts[r])
            assert (status[r], action[r]) == expected, (str(tree), k)
            assert list(memory[r, : tree.size]) == ref_memory[r], (str(tree), k)
    assert counts.tolist() == ref_counts
    # run_ticks (all ticks in one kernel call) ends in the same state.
    run = run_ticks(packed, robot_tree, keys_, boards)
    assert run.counts.tolist() == ref_counts
    assert np.array_equal(run.memory, memory)
    assert np.array_equal(run.status[:, -1], status) and np.array_equal(run.action[:, -1], action)


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
def _simulator_like_kernel(op, arg, first, nchild, children, key, n_ticks):
    """A kernel in another module calling ``tick`` as the simulator does: one robot, boards from a rule."""
    memory = np.empty(len(op), np.int8)
    reset_memory(op, memory)
    counts = np.zeros(N_COUNTS, np.int64)
    blackboard = np.zeros(8, np.bool_)
    actions = np.empty(n_ticks, np.int64)
    for k in range(n_ticks):
        blackboard[k % 8] = not blackboard[k % 8]
        _, actions[k] = tick(op, arg, first, nchild, children, memory, blackboard, key, k, counts)
    return actions, counts


def test_tick_is_callable_from_another_kernel():
    tree = random_tree(np.random.default_rng(5), 30)
    flat = flatten(tree)
    actions, counts = _simulator_like_kernel(*flat.arrays(), np.uint64(99), 40)
    ref = reference.ReferenceRobot(tree, 99)
    board = [False] * 8
    for k in range(40):
        board[k % 8] = not board[k % 8]
        assert ref.step(board)[1] == actions[k]
    assert ref.counts == counts.tolist()
