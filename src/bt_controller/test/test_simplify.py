"""Simplification keeps every motor of every tick: thousands of random trees, random blackboard traces,
probabilistic nodes included, under each reading of the model (``READINGS``), plus hand-worked rewrites."""

from __future__ import annotations

import subprocess
import sys

import numpy as np
import pytest

from bt_controller.draws import choose, derive
from bt_controller.random_trees import random_tree_grow
from bt_controller.semantics import new_counts, new_memory, tick, wheels
from bt_controller.simplify import WORLD_FACTS, simplify, simplify_with_rules
from bt_controller.tree import Action, Composite, Condition, Node, parse, to_text
from bt_controller.vocabulary import ACTION_WHEELS, CONDITIONS, RUNNING, STOP, SUCCESS


def motors_reference(tree: Node, boards: np.ndarray, key: int) -> list[tuple[int, int]]:
    """The wheels after each tick under the project's reference interpreter (``semantics``)."""
    memory, counts = new_memory(tree), new_counts()
    out = []
    for t, board in enumerate(boards):
        status, action = tick(tree, memory, [bool(b) for b in board], key, t, counts)
        out.append(wheels(status, action))
    return out


def motors_model_v2(tree: Node, boards: np.ndarray, key: int, profile: str) -> list[tuple[int, int]]:
    """The wheels after each tick under the model's version 2 (``docs``: motors reset at each tick and set by
    every ticked action, on its running and its success tick; a probabilistic node keeps a current child,
    child 0 first under ``paper`` or drawn under ``clean``, redrawn when the child finishes). A test oracle
    until the reference interpreter takes a profile: the simplifier must be sound under both readings."""
    nodes = list(tree.preorder())
    memory = [0] * len(nodes)  # composites: remembered/current child; actions: 1 when running
    for i, n in enumerate(nodes):
        if isinstance(n, Composite) and n.kind == "prob" and profile == "clean":
            memory[i] = int(choose(np.uint64(derive(np.uint64(key), 10**6)), i, len(n.children)))
    out = []
    for t, board in enumerate(boards):
        motors = [STOP]

        def run(index: int, t: int = t, board: np.ndarray = board, motors: list[int] = motors) -> int:
            n = nodes[index]
            if isinstance(n, Condition):
                return SUCCESS if board[n.index] else 1
            if isinstance(n, Action):
                motors[0] = n.index
                memory[index] ^= 1
                return RUNNING if memory[index] else SUCCESS
            kids, k = [], index + 1
            for c in n.children:
                kids.append(k)
                k += c.size
            if n.kind == "prob":
                status = run(kids[memory[index]])
                if status != RUNNING:
                    draw_key = np.uint64(derive(np.uint64(derive(np.uint64(key), t)), 1))
                    memory[index] = int(choose(draw_key, index, len(kids)))
                return status
            go_on = SUCCESS if n.kind == "seq" else 1
            for position in range(memory[index], len(kids)):
                status = run(kids[position])
                if status == RUNNING:
                    memory[index] = position
                    return status
                if status != go_on:
                    memory[index] = 0
                    return status
            memory[index] = 0
            return go_on

        run(0)
        out.append(ACTION_WHEELS[motors[0]])
    return out


READINGS = {
    "reference": lambda tree, boards, key: motors_reference(tree, boards, key),
    "v2-paper": lambda tree, boards, key: motors_model_v2(tree, boards, key, "paper"),
    "v2-clean": lambda tree, boards, key: motors_model_v2(tree, boards, key, "clean"),
}
"""Each reading of the tree semantics the simplifier must keep; the profile is a parameter of the tests."""


def random_boards(rng: np.random.Generator, n: int, reading: str, facts: bool) -> np.ndarray:
    """A random blackboard trace; with ``facts``, every board obeys ``WORLD_FACTS`` (and, under the paper
    profile, robot_left is true whenever robot_right is false: no neighbour reads as left)."""
    p = rng.random(len(CONDITIONS))
    boards = rng.random((n, len(CONDITIONS))) < p
    if facts:
        index = {name: i for i, name in enumerate(CONDITIONS)}
        for a, b in WORLD_FACTS:
            both = boards[:, index[a]] & boards[:, index[b]]
            drop = np.where(rng.random(n) < 0.5, index[a], index[b])
            boards[both, drop[both]] = False
        if reading == "v2-paper":
            boards[:, index["robot_left"]] = ~boards[:, index["robot_right"]]
    return boards


def random_trees(seed: int, n: int) -> list[Node]:
    rng = np.random.default_rng(seed)
    return [random_tree_grow(rng, int(rng.integers(1, 6)), float(rng.uniform(0.15, 0.6))) for _ in range(n)]


@pytest.mark.parametrize("reading", list(READINGS))
@pytest.mark.parametrize("facts", [True, False])
def test_random_trees_keep_every_motor(reading: str, facts: bool) -> None:
    """2000 random trees per reading and blackboard kind, 3 traces of 60 ticks each."""
    motors = READINGS[reading]
    rng = np.random.default_rng(7)
    shrunk = 0
    for tree in random_trees(11 if facts else 12, 2000):
        simple = simplify(tree, WORLD_FACTS if facts else ())
        assert simple.size <= tree.size
        shrunk += simple.size < tree.size
        for _ in range(3):
            boards = random_boards(rng, 60, reading, facts)
            key = int(rng.integers(0, 2**63))
            assert motors(simple, boards, key) == motors(tree, boards, key), (to_text(tree), to_text(simple))
    assert shrunk > 600  # the test exercises the rules, not only trees left alone


def test_probabilistic_nodes_keep_their_index_and_children() -> None:
    for tree in random_trees(5, 2000):
        simple = simplify(tree)
        old = {i: n for i, n in enumerate(tree.preorder()) if isinstance(n, Composite) and n.kind == "prob"}
        for i, n in enumerate(simple.preorder()):
            if isinstance(n, Composite) and n.kind == "prob":
                assert i in old and len(old[i].children) == len(n.children), (to_text(tree), to_text(simple))


def test_simplify_is_idempotent_and_deterministic() -> None:
    for tree in random_trees(6, 500):
        once = simplify(tree)
        assert simplify(once) == once
        assert simplify(tree) == once


@pytest.mark.parametrize(
    ("before", "after", "rule"),
    [
        # the example: forward never fails, so nothing after it in a selector is ever ticked
        ("sel(on_food, seq(forward, sel(forward, stop)), forward, nest_right)",
         "sel(on_food, seq(forward, forward))", "dead children"),
        ("seq(stop, seq(forward, reverse))", "seq(stop, forward, reverse)", "flatten"),
        ("sel(in_nest, sel(on_food, forward))", "sel(in_nest, on_food, forward)", "flatten"),
        # in_nest was just found true in this tick: the second test is always true
        ("seq(in_nest, in_nest, forward)", "seq(in_nest, forward)", "neutral condition"),
        # on_food is false wherever in_nest is true (disjoint regions)
        ("seq(in_nest, sel(on_food, forward))", "seq(in_nest, forward)", "neutral condition"),
        # after forward ran, the next tick resumes at forward without testing in_nest again: kept
        ("seq(in_nest, forward, in_nest, reverse)", "seq(in_nest, forward, in_nest, reverse)", None),
        # the root's last condition decides only between success and failure, which no motor shows
        ("seq(forward, in_nest)", "forward", "blind tail"),
        ("prob(forward, forward, forward)", "forward", "identical choices"),
        ("seq(in_nest, on_food)", "in_nest", "blind condition subtree"),
    ],
)  # fmt: skip
def test_hand_worked_rewrites(before: str, after: str, rule: str | None) -> None:
    result = simplify_with_rules(parse(before))
    assert to_text(result.tree) == after
    assert (rule in result.rules) if rule else result.rules == ()


def test_a_rewrite_that_would_move_a_probabilistic_node_is_not_made() -> None:
    # Flattening would move prob from index 3 to 2, changing its draws: kept as it is.
    text = "seq(stop, seq(forward, prob(reverse, stop)))"
    assert to_text(simplify(parse(text))) == text
    # The same flattening after the probabilistic node is made.
    assert to_text(simplify(parse("seq(prob(reverse, stop), seq(forward, stop))"))) == (
        "seq(prob(reverse, stop), forward, stop)"
    )


def test_cli_prints_one_line_that_pipes() -> None:
    bt = [sys.executable, "-m", "bt_controller.cli"]
    text = "sel(on_food, seq(forward, sel(forward, stop)), forward, nest_right)"
    out = subprocess.run([*bt, "simplify", text], capture_output=True, text=True, check=True).stdout
    assert out == "sel(on_food, seq(forward, forward))\n"
    checked = subprocess.run([*bt, "check", "-"], input=out, capture_output=True, text=True, check=True)
    assert checked.stdout.startswith("ok: 5 nodes")
    bad = subprocess.run([*bt, "simplify", "seq(forward"], capture_output=True, text=True)
    assert bad.returncode == 2 and bad.stderr.count("\n") == 1
