"""Hand-worked tick sequences for every node type, run on the reference and the compiled interpreter."""

from __future__ import annotations

import numpy as np
import pytest

from bt_controller.draws import choose, derive
from bt_controller.errors import TreeLimitError
from bt_controller.interpreters.compiled import CompiledRobot
from bt_controller.interpreters.semantics import ReferenceRobot, wheels
from bt_controller.language.tree import MAX_TICK_DEPTH, parse
from bt_controller.language.vocabulary import ACTION_INDEX, CONDITION_INDEX, FAILURE, RUNNING, SUCCESS
from bt_controller.model_settings import CLEAN, PAPER

S, F, R = SUCCESS, FAILURE, RUNNING
FWD, REV, STOP = ACTION_INDEX["forward"], ACTION_INDEX["reverse"], ACTION_INDEX["stop"]


def board(*true: str) -> list[bool]:
    values = [False] * len(CONDITION_INDEX)
    for name in true:
        values[CONDITION_INDEX[name]] = True
    return values


@pytest.fixture(params=["reference", "compiled"])
def robot(request):
    cls = ReferenceRobot if request.param == "reference" else CompiledRobot

    def make(text: str, key: int = 7, profile: int = CLEAN):
        return cls(parse(text, max_depth=1000), key, profile)

    return make


def memory(r) -> list[int]:
    return [int(m) for m in r.memory]


def test_condition_leaf(robot):
    r = robot("on_food")
    assert r.step(board("on_food")) == (S, -1)
    assert r.step(board()) == (F, -1)
    assert list(r.counts) == [2, 0, 0, 0, 0, 0, 0, 0]


def test_action_runs_then_succeeds_then_starts_again(robot):
    r = robot("forward")
    assert r.step(board()) == (R, FWD)
    assert memory(r) == [1]
    assert r.step(board()) == (S, -1)
    assert memory(r) == [0]
    assert r.step(board()) == (R, FWD)
    assert list(r.counts) == [0, 0, 2, 0, 0, 0, 0, 0]


def test_sequence_resumes_at_running_child_without_reticking_earlier_ones(robot):
    r = robot("seq(on_food, forward, stop)")
    assert r.step(board("on_food")) == (R, FWD)
    assert memory(r) == [1, 0, 1, 0]
    # on_food is false now, but the sequence resumes at forward: on_food is not ticked again.
    assert r.step(board()) == (R, STOP)
    assert memory(r) == [2, 0, 0, 1]
    assert r.counts[0] == 1
    assert r.step(board()) == (S, -1)  # stop succeeds, all succeeded: memory cleared
    assert memory(r) == [-1, 0, 0, 0]
    assert r.step(board()) == (F, -1)  # afresh: on_food fails
    assert memory(r) == [-1, 0, 0, 0]
    assert list(r.counts) == [2, 1, 1, 0, 0, 0, 0, 0]


def test_sequence_failure_after_running_clears_memory(robot):
    r = robot("seq(forward, in_nest, stop)")
    assert r.step(board()) == (R, FWD)
    assert memory(r) == [0, 1, 0, 0]
    assert r.step(board()) == (F, -1)  # forward succeeds, in_nest fails
    assert memory(r) == [-1, 0, 0, 0]
    assert r.step(board("in_nest")) == (R, FWD)  # starts from the first child again
    assert memory(r) == [0, 1, 0, 0]


def test_selector_resumes_at_running_child_and_succeeds(robot):
    r = robot("sel(on_food, forward, stop)")
    assert r.step(board()) == (R, FWD)
    assert memory(r) == [1, 0, 1, 0]
    # on_food is true now, but the selector resumes at forward, which succeeds: the selector succeeds.
    assert r.step(board("on_food")) == (S, -1)
    assert memory(r) == [-1, 0, 0, 0]
    assert r.counts[0] == 1
    assert r.step(board("on_food")) == (S, -1)
    assert r.counts[0] == 2


def test_selector_all_fail_clears_memory(robot):
    r = robot("sel(on_food, seq(forward, in_nest))")
    assert r.step(board()) == (R, FWD)
    assert memory(r) == [1, 0, 0, 1, 0]
    assert r.step(board()) == (F, -1)  # forward succeeds, in_nest fails, seq fails, sel exhausted
    assert memory(r) == [-1, 0, -1, 0, 0]
    assert r.step(board("on_food")) == (S, -1)
    assert list(r.counts) == [3, 0, 1, 0, 0, 0, 0, 0]


def test_nested_memory_resumes_deep_running_action(robot):
    r = robot("sel(seq(in_nest, stop, reverse), forward)")
    assert r.step(board("in_nest")) == (R, STOP)
    assert memory(r) == [0, 1, 0, 1, 0, 0]
    assert r.step(board()) == (R, REV)
    assert memory(r) == [0, 2, 0, 0, 1, 0]
    assert r.step(board()) == (S, -1)
    assert memory(r) == [-1, -1, 0, 0, 0, 0]
    assert r.step(board()) == (R, FWD)  # in_nest fails, seq fails, selector moves on to forward
    assert memory(r) == [1, -1, 0, 0, 0, 1]


def _key_with_draws(first: int, second: int, n: int, node: int = 0) -> int:
    """A stream key whose probabilistic draws at ticks 0 and 1 (for ``node``) are ``first`` and ``second``."""
    for key in range(1, 10_000):
        k = np.uint64(key)
        if (
            choose(np.uint64(derive(k, 0)), node, n) == first
            and choose(np.uint64(derive(k, 1)), node, n) == second
        ):
            return key
    raise AssertionError("no such key")


def test_prob_child_is_the_counter_based_draw(robot):
    for key in range(20):
        r = robot("prob(on_food, in_nest, food_left)", key)
        status, _ = r.step(board("in_nest"))
        chosen = choose(np.uint64(derive(np.uint64(key), 0)), 0, 3)
        assert status == (S if chosen == 1 else F)
        assert memory(r) == [-1, 0, 0, 0]


def test_prob_remembers_running_child_and_draws_only_when_nothing_remembered(robot):
    key = _key_with_draws(0, 1, 2)
    r = robot("prob(forward, reverse)", key)
    assert r.step(board()) == (R, FWD)  # draw 0 picks forward
    assert memory(r) == [0, 1, 0]
    assert r.step(board()) == (S, -1)  # tick 1's draw would pick reverse, but forward is remembered
    assert memory(r) == [-1, 0, 0]
    r2 = robot("prob(forward, reverse)", key)
    r2.step(board())
    r2.step(board())
    assert r2.counts[1 + REV] == 0


def test_prob_uses_the_local_preorder_index_of_the_node(robot):
    """The prob node is child 2 of the root but node 3 in pre-order, and is first reached at tick 1 (tick 0
    ends on ``stop``). The key is chosen so that tick 1's draw picks reverse with counter 3 and forward with
    counter 2: a tick that drew with the child position (or at tick 0) would pick forward."""
    key = next(
        k
        for k in range(1, 10_000)
        if choose(np.uint64(derive(np.uint64(k), 1)), 3, 2) == 1
        and choose(np.uint64(derive(np.uint64(k), 1)), 2, 2) == 0
        and choose(np.uint64(derive(np.uint64(k), 0)), 3, 2) == 0
    )
    r = robot("seq(on_food, stop, prob(forward, reverse))", key)
    assert r.step(board("on_food")) == (R, STOP)  # tick 0 ends on stop: the prob node is not reached
    assert r.step(board("on_food")) == (R, REV)  # tick 1 reaches it: counter 3, its pre-order index


def test_prob_with_a_draw_key_draws_with_the_key_instead_of_its_index(robot):
    """The same tree and key as above: ``prob@2`` at pre-order index 3 draws with counter 2 (forward), and
    ``prob@3`` exactly as the plain node (reverse); keys shared by two nodes make them draw alike."""
    key = next(
        k
        for k in range(1, 10_000)
        if choose(np.uint64(derive(np.uint64(k), 1)), 3, 2) == 1
        and choose(np.uint64(derive(np.uint64(k), 1)), 2, 2) == 0
        and choose(np.uint64(derive(np.uint64(k), 0)), 3, 2) == 0
    )
    for text, action in (("prob@2", FWD), ("prob@3", REV), ("prob", REV)):
        r = robot(f"seq(on_food, stop, {text}(forward, reverse))", key)
        assert r.step(board("on_food")) == (R, STOP)
        assert r.step(board("on_food")) == (R, action), text
    # Two nodes with one key pick the same child position when both draw in one tick: with on_food true and
    # in_nest false, the second node fails after the first succeeded only if they picked differently.
    outcomes = {}
    for keys in ("9, 9", "9, 10"):
        a, b = keys.split(", ")
        text = f"seq(prob@{a}(on_food, in_nest), prob@{b}(on_food, in_nest), forward)"
        outcomes[keys] = set()
        for k in range(40):
            r = robot(text, k)
            status, _ = r.step(board("on_food"))
            outcomes[keys].add((status, int(r.counts[0])))
    assert outcomes["9, 9"] == {(R, 2), (F, 1)}
    assert (F, 2) in outcomes["9, 10"]


def test_interpreters_refuse_trees_deeper_than_max_tick_depth(robot):
    deep = "stop"
    for _ in range(MAX_TICK_DEPTH + 1):
        deep = f"seq(on_food, {deep})"
    with pytest.raises(TreeLimitError, match=f"takes {MAX_TICK_DEPTH}"):
        robot(deep)
    assert robot(deep[len("seq(on_food, ") : -1]).step(board("on_food")) == (R, STOP)


def test_prob_starts_at_its_first_child_under_paper_then_draws(robot):
    # A3: the authors' probabilistic node starts at child 0 (CNode.cpp:108-113) and draws after each finish.
    for key in range(10):
        r = robot("prob(forward, reverse)", key, PAPER)
        assert memory(r) == [0, 0, 0]
        assert r.step(board()) == (R, FWD)
        assert r.step(board()) == (S, -1)
        assert memory(r) == [-1, 0, 0]
        second = choose(np.uint64(derive(np.uint64(key), 2)), 0, 2)
        assert r.step(board()) == (R, REV if second else FWD)


def test_prob_draws_are_uniform_over_children():
    seen = np.zeros(4, int)
    for key in range(4000):
        r = ReferenceRobot(parse("prob(stop, forward, forward_left, forward_right)"), key, CLEAN)
        _, action = r.step(board())
        seen[action] += 1
    assert seen.min() > 850


def test_wheels_are_the_running_actions_else_stop():
    assert wheels(R, FWD) == (1, 1)
    assert wheels(S, -1) == (0, 0)
    assert wheels(F, -1) == (0, 0)


def test_success_turns_failure_into_success_and_keeps_its_child_running(robot):
    # success(X): ticks X; X's failure becomes success, running and success pass (CNode.cpp:508-513, a73e4af).
    r = robot("success(seq(got_food, forward))")
    assert r.step(board()) == (S, -1)  # got_food fails: the sequence fails, the decorator succeeds
    assert memory(r) == [-1, -1, 0, 0]
    assert r.step(board("got_food")) == (R, FWD)  # X runs: the decorator runs, remembering nothing else
    assert memory(r) == [0, 1, 0, 1]
    # Resumed at forward whatever the blackboard says: got_food is not ticked again.
    assert r.step(board()) == (S, -1)
    assert memory(r) == [-1, -1, 0, 0]
    assert list(r.counts) == [2, 0, 1, 0, 0, 0, 0, 0]


def test_a_parent_resumes_a_running_success_like_any_child(robot):
    # The guard of seq(got_food, success(P)) is not checked again while P runs (foraging.md section 3).
    r = robot("sel(seq(got_food, success(seq(forward, reverse))), stop)")
    assert r.step(board("got_food")) == (R, FWD)
    assert r.step(board()) == (R, REV)  # forward succeeded, reverse started: got_food not re-ticked
    assert r.counts[0] == 1
    assert r.step(board()) == (S, -1)
    assert r.step(board()) == (R, STOP)  # afresh: got_food fails, the selector moves on to stop
    assert r.counts[0] == 2


def test_success_of_a_failing_child_in_a_selector_ends_the_selector(robot):
    r = robot("sel(success(in_nest), forward)")
    for b in (board(), board("in_nest")):
        assert r.step(b) == (S, -1)
    assert list(r.counts) == [2, 0, 0, 0, 0, 0, 0, 0]


def test_got_food_reads_its_own_blackboard_entry(robot):
    r = robot("sel(seq(got_food, reverse), forward)")
    assert r.step(board("on_food", "got_food")) == (R, REV)
    r = robot("sel(seq(got_food, reverse), forward)")
    assert r.step(board("on_food")) == (R, FWD)  # the interpreters read the entry as given
