"""Simplification keeps every motor of every tick: thousands of random trees, random blackboard traces,
probabilistic nodes included, under each reading of the model (``READINGS``), plus hand-worked rewrites."""

from __future__ import annotations

import subprocess
import sys
from collections import Counter

import numpy as np
import pytest

from bt_controller.draws import choose, derive
from bt_controller.interpreters.semantics import new_counts, new_memory, tick, wheels
from bt_controller.language.formats import from_xml, to_ascii, to_dot, to_xml
from bt_controller.language.random_trees import random_tree_grow
from bt_controller.language.simplify import (
    _N,
    WORLD_FACTS,
    WORLD_IMPLICATIONS,
    _analyse_rewrites,
    _candidates,
    _Facts,
    _from_node,
    _replace,
    _walk,
    simplify,
    simplify_with_rules,
)
from bt_controller.language.tree import (
    Action,
    Composite,
    Condition,
    Node,
    draw_key_at,
    parse,
    to_indented,
    to_text,
)
from bt_controller.language.vocabulary import ACTION_WHEELS, CONDITIONS, RUNNING, STOP, SUCCESS


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
            memory[i] = int(
                choose(np.uint64(derive(np.uint64(key), 10**6)), draw_key_at(n, i), len(n.children))
            )
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
            if n.kind == "success":
                status = run(kids[0])
                return SUCCESS if status == 1 else status
            if n.kind == "prob":
                status = run(kids[memory[index]])
                if status != RUNNING:
                    draw_key = np.uint64(derive(np.uint64(derive(np.uint64(key), t)), 1))
                    memory[index] = int(choose(draw_key, draw_key_at(n, index), len(kids)))
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
    """A random blackboard trace; with ``facts``, every board obeys ``WORLD_FACTS`` and
    ``WORLD_IMPLICATIONS`` (and, under the paper profile, robot_left is true whenever robot_right is false: no
    neighbour reads as left)."""
    p = rng.random(len(CONDITIONS))
    boards = rng.random((n, len(CONDITIONS))) < p
    if facts:
        index = {name: i for i, name in enumerate(CONDITIONS)}
        for a, b in WORLD_FACTS:
            both = boards[:, index[a]] & boards[:, index[b]]
            drop = np.where(rng.random(n) < 0.5, index[a], index[b])
            boards[both, drop[both]] = False
        # on_food makes got_food true; on food a robot is not in the nest (dropped above), so no fact breaks.
        for a, b in WORLD_IMPLICATIONS:
            boards[:, index[b]] |= boards[:, index[a]]
        if reading == "v2-paper":
            boards[:, index["robot_left"]] = ~boards[:, index["robot_right"]]
    return boards


def random_trees(seed: int, n: int, keyed: float = 0.0) -> list[Node]:
    """``n`` random trees; with ``keyed`` > 0 that share of them names random draw keys (small ones, so that
    some keys repeat within a tree and some equal another node's pre-order index)."""
    rng = np.random.default_rng(seed)
    trees = [
        random_tree_grow(rng, int(rng.integers(1, 6)), float(rng.uniform(0.15, 0.6)), p_success=0.1)
        for _ in range(n)
    ]
    return [with_random_keys(rng, t) if rng.random() < keyed else t for t in trees]


def with_random_keys(rng: np.random.Generator, tree: Node) -> Node:
    """``tree`` with each probabilistic node given a draw key in [0, 20) with probability 1/2."""
    built: list[Node] = []
    for node in reversed(list(tree.preorder())):  # children before parents, on a stack
        if isinstance(node, Composite):
            children = tuple(built.pop() for _ in node.children)
            key = int(rng.integers(0, 20)) if node.kind == "prob" and rng.random() < 0.5 else None
            built.append(Composite(node.kind, children, key))
        else:
            built.append(node)
    return built[0]


@pytest.mark.parametrize("reading", list(READINGS))
@pytest.mark.parametrize("facts", [True, False])
def test_random_trees_keep_every_motor(reading: str, facts: bool) -> None:
    """2000 random trees per reading and blackboard kind (a fifth of them with draw keys of their own), 3
    traces of 60 ticks each; the simplifier moves probabilistic nodes (adding keys) in many of them."""
    motors = READINGS[reading]
    rng = np.random.default_rng(7)
    shrunk = moved = 0
    for tree in random_trees(11 if facts else 12, 2000, keyed=0.2):
        simple = simplify(tree, WORLD_FACTS if facts else ())
        assert simple.size <= tree.size
        shrunk += simple.size < tree.size
        moved += "@" in to_text(simple) and "@" not in to_text(tree)
        for _ in range(3):
            boards = random_boards(rng, 60, reading, facts)
            key = int(rng.integers(0, 2**63))
            assert motors(simple, boards, key) == motors(tree, boards, key), (to_text(tree), to_text(simple))
    assert shrunk > 600  # the test exercises the rules, not only trees left alone
    assert moved > 100  # ... and moves probabilistic nodes


def probs(tree: Node) -> dict[int, tuple[int, int]]:
    """Pre-order index -> (draw key, number of children) of every probabilistic node."""
    return {
        i: (draw_key_at(n, i), len(n.children))
        for i, n in enumerate(tree.preorder())
        if isinstance(n, Composite) and n.kind == "prob"
    }


def test_probabilistic_nodes_keep_their_draw_key_and_children() -> None:
    """Every surviving probabilistic node draws with its original key and keeps its number of children; a key
    is written only where it is not the node's index; with keep_positions no node moves."""
    for tree in random_trees(5, 2000, keyed=0.2):
        text = to_text(tree)
        simple = simplify(tree)
        assert not Counter(probs(simple).values()) - Counter(probs(tree).values()), (text, to_text(simple))
        for i, n in enumerate(simple.preorder()):
            if isinstance(n, Composite) and n.draw_key is not None:
                assert n.draw_key != i, (text, to_text(simple))
        kept = simplify(tree, keep_positions=True)
        assert kept.size >= simple.size
        before = probs(tree)
        for i, draw in probs(kept).items():
            assert before.get(i) == draw, (text, to_text(kept))
        if "@" not in text:
            assert "@" not in to_text(kept)


def _scratch_analysis(root: _N, facts: _Facts) -> list[tuple]:
    """Every node's analysis, in pre-order, from a copy of the tree that was never analysed."""

    def copy(n: _N) -> _N:
        return _N(n.kind, n.name, [copy(c) for c in n.children], n.orig, n.draw)

    fresh = copy(root)
    _analyse_rewrites(fresh, facts, {}, frozenset())
    return _analysis(fresh)


def _analysis(root: _N) -> list[tuple]:
    """Each node's analysed fields in pre-order; shapes as the first pre-order index of their shape (the
    integers themselves differ between analyses), rewrites by rule name."""
    nodes = _walk(root)
    first_of_shape: dict[int, int] = {}
    return [
        (
            n.kind, n.name, n.status, n.pure, n.has_prob, n.fresh, n.blind, n.post_s, n.post_f, n.size,
            first_of_shape.setdefault(n.shape, i), tuple(rule for _, rule, _ in n.rewrites), n.quiet,
        )
        for i, n in enumerate(nodes)
    ]  # fmt: skip


def test_each_analysis_after_a_rewrite_is_the_analysis_from_scratch() -> None:
    """The simplifier analyses again only what a rewrite changed (``_analyse``) and looks for rewrites only
    in subtrees that have some (``_candidates``). Following the rewrites ``simplify`` makes on random trees,
    after each one the kept analysis of every node equals a fresh one, and the rewrites found equal those of
    a walk over every node."""
    facts = _Facts(WORLD_FACTS, WORLD_IMPLICATIONS)
    steps = 0
    for tree in random_trees(13, 400, keyed=0.2):
        root = _from_node(tree)
        shapes: dict[tuple, int] = {}
        while True:
            _analyse_rewrites(root, facts, shapes, frozenset())
            assert _analysis(root) == _scratch_analysis(root, facts), to_text(tree)
            everywhere = [
                (priority, -position, rule, n, replacement)
                for position, n in enumerate(_walk(root))
                for priority, rule, replacement in n.rewrites
            ]
            found = _candidates(root)
            assert sorted(found, key=lambda c: (c[0], c[1])) == sorted(everywhere, key=lambda c: (c[0], c[1]))
            if not found:
                break
            _, _, _, target, replacement = min(found, key=lambda c: (c[0], c[1]))
            root = _replace(root, target, replacement)
            steps += 1
    assert steps > 300  # the trees are rewritten, not only analysed once


def test_simplify_is_idempotent_and_deterministic() -> None:
    for tree in random_trees(6, 500, keyed=0.2):
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
        # got_food is clear in the nest and set on food (the carrying flag after the delivery check)
        ("seq(in_nest, sel(got_food, forward))", "seq(in_nest, forward)", "neutral condition"),
        ("sel(seq(on_food, got_food, reverse), forward)", "sel(seq(on_food, reverse), forward)",
         "neutral condition"),
        ("sel(seq(got_food, sel(on_food, reverse)), forward)",
         "sel(seq(got_food, sel(on_food, reverse)), forward)", None),
        # success over a child that never fails is the child
        ("seq(success(forward), reverse)", "seq(forward, reverse)", "success never needed"),
        ("success(success(sel(got_food, forward)))", "sel(got_food, forward)", "success never needed"),
        # at the root, success and failure look alike
        ("success(seq(got_food, forward))", "seq(got_food, forward)", "blind success"),
        # inside success the child is blind: its last condition only picks success or failure
        ("seq(success(seq(forward, in_nest)), reverse)", "seq(forward, reverse)", "blind tail"),
        # a success that ticks no action always succeeds: neutral in a sequence, the end of a selector
        ("seq(success(in_nest), forward)", "forward", "neutral condition"),
        ("sel(success(seq(got_food, forward)), reverse)", "seq(got_food, forward)", "dead children"),
        # kept: success changes what the parent sequence does after a failure
        ("seq(success(seq(got_food, forward)), reverse)",
         "seq(success(seq(got_food, forward)), reverse)", None),
    ],
)  # fmt: skip
def test_hand_worked_rewrites(before: str, after: str, rule: str | None) -> None:
    result = simplify_with_rules(parse(before))
    assert to_text(result.tree) == after
    assert (rule in result.rules) if rule else result.rules == ()


def test_a_probabilistic_node_that_moves_keeps_its_draws_with_a_key() -> None:
    # Flattening moves prob from index 4 to 3: it keeps drawing with 4, written prob@4.
    text = "seq(stop, seq(forward, prob(reverse, stop)))"
    assert to_text(simplify(parse(text))) == "seq(stop, forward, prob@4(reverse, stop))"
    # keep_positions: the rewrite is not made (the simplifier before draw keys).
    assert to_text(simplify(parse(text), keep_positions=True)) == text
    # A node that stays at its index is written plain; one whose key is its new index too.
    assert to_text(simplify(parse("seq(prob(reverse, stop), seq(forward, stop))"))) == (
        "seq(prob(reverse, stop), forward, stop)"
    )
    assert to_text(simplify(parse("seq(stop, seq(forward, prob@3(reverse, stop)))"))) == (
        "seq(stop, forward, prob(reverse, stop))"
    )
    # The main job's best tree (issue 26): the dead selector before the probabilistic node now goes.
    best = "sel(on_food, seq(sel(forward, forward), forward, prob(forward_left, forward)))"
    assert to_text(simplify(parse(best), keep_positions=True)) == best
    assert (
        to_text(simplify(parse(best))) == "sel(on_food, seq(forward, forward, prob@7(forward_left, forward)))"
    )


def test_simplified_keys_pass_through_every_format() -> None:
    simple = simplify(parse("sel(on_food, seq(sel(forward, forward), forward, prob(forward_left, forward)))"))
    assert from_xml(to_xml(simple)) == simple
    assert parse(to_indented(simple)) == simple
    assert "prob % @7" in to_dot(simple) and "prob@7" in to_ascii(simple)


def test_cli_prints_one_line_that_pipes() -> None:
    bt = [sys.executable, "-m", "bt_controller.tools.cli"]
    text = "sel(on_food, seq(forward, sel(forward, stop)), forward, nest_right)"
    out = subprocess.run([*bt, "simplify", text], capture_output=True, text=True, check=True).stdout
    assert out == "sel(on_food, seq(forward, forward))\n"
    checked = subprocess.run([*bt, "check", "-"], input=out, capture_output=True, text=True, check=True)
    assert checked.stdout.startswith("ok: 5 nodes")
    bad = subprocess.run([*bt, "simplify", "seq(forward"], capture_output=True, text=True)
    assert bad.returncode == 2 and bad.stderr.count("\n") == 1
