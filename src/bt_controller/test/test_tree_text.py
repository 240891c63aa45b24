"""The tree model, the parser and the canonical printer."""

from __future__ import annotations

import pytest
from bt_strategies import trees
from hypothesis import given, settings

from bt_controller.errors import TreeLimitError, TreeSyntaxError
from bt_controller.tree import (
    Action,
    Composite,
    Condition,
    check_limits,
    parse,
    prob,
    sel,
    seq,
    to_indented,
    to_text,
)


def test_parse_and_print_example():
    tree = parse("sel(seq(in_nest, stop), forward)")
    assert tree == sel(seq("in_nest", "stop"), "forward")
    assert to_text(tree) == "sel(seq(in_nest, stop), forward)"
    assert tree.size == 5 and tree.depth == 2


def test_single_leaf_is_a_tree():
    assert parse("  on_food\n") == Condition("on_food")
    assert parse("reverse_left") == Action("reverse_left")
    assert parse("stop").depth == 0


def test_whitespace_and_newlines_are_free():
    text = "\n  sel (\n\tseq(in_nest ,stop) ,\r\n  prob( forward,reverse ) )  "
    assert parse(text) == sel(seq("in_nest", "stop"), prob("forward", "reverse"))


def test_arity_suffixes_are_accepted_and_not_printed():
    tree = parse("sel3(seq2(in_nest, stop), forward, prob4(stop, stop, stop, reverse))")
    assert to_text(tree) == "sel(seq(in_nest, stop), forward, prob(stop, stop, stop, reverse))"


def test_trees_are_hashable_equal_and_ordered():
    a, b = parse("seq(on_food, stop)"), parse("seq2(on_food,stop)")
    assert a == b and hash(a) == hash(b) and len({a, b}) == 1
    assert parse("seq(on_food, stop)") != parse("sel(on_food, stop)")
    assert Condition("on_food") != Action("stop")
    assert sorted([parse("stop"), parse("forward"), a]) == [parse("forward"), a, parse("stop")]


@settings(max_examples=400, derandomize=True, deadline=None)
@given(tree=trees)
def test_parse_print_round_trip(tree):
    assert parse(to_text(tree)) == tree
    assert parse(to_indented(tree)) == tree
    assert to_text(parse(to_text(tree))) == to_text(tree)


@pytest.mark.parametrize(
    ("text", "line", "column", "fragment"),
    [
        ("", 1, 1, "expected a node name"),
        ("seq(", 1, 5, "expected a node name for a child of seq"),
        ("seq(stop)", 1, 9, "at least 2 children"),
        ("seq(stop, stop, stop, stop, stop)", 1, 27, "at most 4 children"),
        ("seq3(stop, stop)", 1, 16, "seq3 expects 3 children, found 2"),
        ("seq5(stop, stop)", 1, 1, "2 to 4 children"),
        ("seq stop", 1, 5, "expected '(' after 'seq'"),
        ("stop()", 1, 5, "leaf and takes no children"),
        ("seq(stop, on_food())", 1, 18, "leaf and takes no children"),
        ("stop stop", 1, 6, "expected end of input"),
        ("seq(stop, stop))", 1, 16, "expected end of input"),
        ("seq(stop; stop)", 1, 9, "unexpected character ';'"),
        ("seq(stop,\n  fly)", 2, 3, "unknown node 'fly'"),
        ("seq(stop, , stop)", 1, 11, "expected a node name"),
        ("seq(stop, stop,)", 1, 16, "expected a node name"),
    ],
)
def test_syntax_errors_say_where_and_what(text, line, column, fragment):
    with pytest.raises(TreeSyntaxError) as info:
        parse(text)
    assert (info.value.line, info.value.column) == (line, column)
    assert fragment in str(info.value)
    assert str(info.value).startswith(f"line {line}, column {column}: ")
    assert isinstance(info.value, ValueError)


def test_unknown_names_list_the_known_ones():
    with pytest.raises(TreeSyntaxError) as info:
        parse("sequence(stop, stop)")
    for name in ("seq", "sel", "prob", "on_food", "robot_right", "reverse_right"):
        assert name in str(info.value)


def test_limits_on_size_and_depth():
    deep = "stop"
    for _ in range(18):
        deep = f"seq(on_food, {deep})"
    with pytest.raises(TreeLimitError, match="max_depth=17") as info:
        parse(deep)
    assert info.value.line == 1
    assert parse(deep, max_depth=18).depth == 18
    wide = "seq(" + ", ".join(["sel(stop, stop, stop, stop)"] * 4) + ")"
    assert parse(wide).size == 21
    with pytest.raises(TreeLimitError, match="max_nodes=20"):
        parse(wide, max_nodes=20)
    with pytest.raises(TreeLimitError):
        check_limits(parse(wide), max_nodes=20)
    very_deep = "seq(stop, " * 100_000 + "stop" + ")" * 100_000
    with pytest.raises(TreeLimitError):
        parse(very_deep)


def test_model_refuses_bad_nodes():
    with pytest.raises(TreeSyntaxError):
        Composite("seq", (Action("stop"),))
    with pytest.raises(TreeSyntaxError):
        Composite("loop", (Action("stop"), Action("stop")))
    with pytest.raises(TreeSyntaxError):
        Condition("forward")
    with pytest.raises(TypeError):
        parse(b"stop")  # type: ignore[arg-type]  # the point: bytes are refused at run time
