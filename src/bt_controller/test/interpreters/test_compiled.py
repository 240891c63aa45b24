"""The flat layout is exactly the contract of docs/interfaces.md."""

from __future__ import annotations

import numpy as np
import pytest

from bt_controller.errors import TreeLimitError
from bt_controller.interpreters.compiled import (
    MAX_COMPILED_DEPTH,
    CompiledRobot,
    flatten,
    new_memory,
    pack,
    reset_memory,
)
from bt_controller.language.tree import parse
from bt_controller.model_settings import CLEAN, PAPER


def test_flatten_example():
    flat = flatten(parse("sel(seq(in_nest, stop), prob(forward, reverse, on_food))"))
    assert flat.op.dtype == np.int8 and flat.arg.dtype == np.int8 and flat.nchild.dtype == np.int8
    assert flat.first.dtype == np.int32 and flat.children.dtype == np.int32 and flat.draw.dtype == np.int32
    assert flat.op.tolist() == [1, 0, 3, 4, 2, 4, 4, 3]
    assert flat.arg.tolist() == [-1, -1, 1, 0, -1, 1, 4, 0]
    assert flat.first.tolist() == [0, 2, -1, -1, 4, -1, -1, -1]
    assert flat.nchild.tolist() == [2, 2, 0, 0, 3, 0, 0, 0]
    assert flat.children.tolist() == [1, 4, 2, 3, 5, 6, 7]
    assert flat.draw.tolist() == [-1, -1, -1, -1, 4, -1, -1, -1]  # a plain prob draws with its index


def test_flatten_keeps_draw_keys():
    flat = flatten(parse("prob@2147483647(prob@0(stop, stop), prob(stop, stop), prob@5(stop, stop))"))
    assert flat.draw.tolist() == [2**31 - 1, 0, -1, -1, 4, -1, -1, 5, -1, -1]


def test_single_leaf_flattens():
    flat = flatten(parse("forward"))
    assert (flat.op.tolist(), flat.arg.tolist(), flat.children.tolist()) == ([4], [1], [])
    assert CompiledRobot(flat, 0).step([False] * 8) == (2, 1)


def test_reset_memory():
    flat = flatten(parse("sel(seq(in_nest, stop), forward)"))
    memory = np.full(5, 7, np.int8)
    reset_memory(flat.op, memory)
    assert memory.tolist() == [-1, -1, 0, 0, 0]


def test_pack_offsets_and_views():
    trees = [parse("stop"), parse("seq(on_food, stop)"), parse("prob@9(stop, sel(on_food, stop), forward)")]
    packed = pack(trees)
    assert packed.draw.tolist() == [-1, -1, -1, -1, 9, -1, -1, -1, -1, -1]
    assert packed.node_offset.tolist() == [0, 1, 4, 10]
    assert packed.child_offset.tolist() == [0, 0, 2, 7]
    assert packed.n_trees == 3 and packed.max_nodes == 6
    for t, tree in enumerate(trees):
        view, flat = packed.tree(t), flatten(tree)
        for a, b in zip(view, flat, strict=True):
            assert a.tolist() == b.tolist()
    memory = new_memory(packed, np.array([2, 0, 1]), CLEAN)
    assert memory.tolist() == [[-1, 0, -1, 0, 0, 0], [0, 0, 0, 0, 0, 0], [-1, 0, 0, 0, 0, 0]]
    # Under paper a probabilistic composite starts at its first child (A3).
    assert new_memory(packed, np.array([2]), PAPER).tolist() == [[0, 0, -1, 0, 0, 0]]


def test_flatten_refuses_trees_deeper_than_the_compiled_stack():
    text = "stop"
    for _ in range(MAX_COMPILED_DEPTH + 1):
        text = f"seq(on_food, {text})"
    tree = parse(text, max_depth=100)
    with pytest.raises(TreeLimitError):
        flatten(tree)
    ok = parse(text[len("seq(on_food, ") : -1], max_depth=100)
    assert ok.depth == MAX_COMPILED_DEPTH
    robot = CompiledRobot(ok, 3)
    assert robot.step([True] * 8) == (2, 0)
