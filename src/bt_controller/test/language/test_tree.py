"""The tree model, the parser and the canonical printer."""

from __future__ import annotations

import pytest
from bt_strategies import trees
from hypothesis import given, settings

from bt_controller.errors import TreeLimitError, TreeSyntaxError
from bt_controller.language.tree import (
    MAX_DRAW_KEY,
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


def test_draw_keys_parse_print_and_compare():
    tree = parse("sel(prob3@7(forward, stop, on_food), prob @ 0 (stop, stop), prob@007(stop, stop))")
    assert to_text(tree) == "sel(prob@7(forward, stop, on_food), prob@0(stop, stop), prob@7(stop, stop))"
    assert tree.children[0].draw_key == 7 and tree.children[0].head == "prob@7"
    assert prob("stop", "stop", draw_key=3) == parse("prob@3(stop, stop)")
    assert parse("prob@3(stop, stop)") != parse("prob(stop, stop)")
    assert parse("prob@3(stop, stop)") != parse("prob@4(stop, stop)")
    assert parse(to_indented(tree)) == tree
    assert "prob@7(" in to_indented(tree)
    assert parse(f"prob@{MAX_DRAW_KEY}(stop, stop)").draw_key == MAX_DRAW_KEY


@pytest.mark.parametrize(
    ("text", "column", "fragment"),
    [
        ("seq@3(stop, stop)", 4, "seq takes no draw key; only prob does"),
        ("sel2@3(stop, stop)", 5, "sel2 takes no draw key"),
        (
            "prob@(stop, stop)",
            6,
            "expected a draw key (an integer in [0, 2147483647]) after 'prob@', found '('",
        ),
        ("prob@-1(stop, stop)", 6, "found unexpected character '-'"),
        ("prob@x(stop, stop)", 6, "found 'x'"),
        ("prob@2147483648(stop, stop)", 6, "draw key 2147483648 of prob is out of range"),
        ("prob@" + "9" * 5000 + "(stop, stop)", 6, "draw key 999999999999... of prob is out of range"),
        ("prob@7 stop", 8, "expected '(' after 'prob@7', found 'stop'"),
        ("prob(stop@1, stop)", 10, "stop is a leaf and takes no draw key"),
        ("forward@1", 8, "forward is a leaf and takes no draw key"),
        ("seq(stop, 7)", 11, "expected a node name for a child of seq, found '7'"),
    ],
)
def test_bad_draw_keys_say_where_and_what(text, column, fragment):
    with pytest.raises(TreeSyntaxError) as info:
        parse(text)
    assert (info.value.line, info.value.column) == (1, column)
    assert fragment in str(info.value)


def test_model_refuses_bad_draw_keys():
    for key in (-1, MAX_DRAW_KEY + 1, True, 1.0, "3"):
        with pytest.raises(TreeSyntaxError, match="a draw key must be an integer"):
            Composite("prob", (Action("stop"), Action("stop")), key)  # type: ignore[arg-type]  # refused at run time
    with pytest.raises(TreeSyntaxError, match="only prob"):
        Composite("seq", (Action("stop"), Action("stop")), 3)


def test_trees_of_any_depth_print_compare_and_hash():
    # Issue 25, item 6: every operation on a tree is iterative (the parser already was).
    text = "forward"
    for i in range(10_000):
        text = f"seq(in_nest, {text})" if i % 2 else f"prob@{i}(on_food, {text})"
    tree = parse(text, max_depth=100_000, max_nodes=100_000)
    again = parse(text, max_depth=100_000, max_nodes=100_000)
    assert tree.depth == 10_000 and tree is not again
    assert tree == again and hash(tree) == hash(again)
    assert not tree != again  # noqa: SIM202  # the point: __ne__ of a deep tree
    assert tree != parse(text.replace("prob@9998", "prob@1"), max_depth=100_000, max_nodes=100_000)
    assert to_text(tree) == text
    assert parse(to_indented(tree), max_depth=100_000, max_nodes=100_000) == tree
    assert sorted([tree, again, parse("stop")])[-1] == parse("stop")


def test_success_decorator_parses_prints_and_takes_one_child():
    tree = parse("sel(seq(got_food, success(seq(nest_left, forward))), success( forward ))")
    assert to_text(tree) == "sel(seq(got_food, success(seq(nest_left, forward))), success(forward))"
    assert tree.size == 9 and tree.depth == 4
    assert parse(to_indented(tree)) == tree
    for text, column, fragment in [
        ("success(forward, stop)", 16, "success takes exactly one child"),
        ("success()", 9, "expected a node name for a child of success"),
        ("success@3(forward)", 8, "success takes no draw key"),
        ("success", 8, "expected '(' after 'success'"),
        ("success1(forward)", 1, "unknown node 'success1'"),
    ]:
        with pytest.raises(TreeSyntaxError, match=fragment.replace("(", r"\(")) as info:
            parse(text)
        assert info.value.column == column, text
    with pytest.raises(TreeSyntaxError, match="exactly one child"):
        Composite("success", (Action("stop"), Action("stop")))


def test_unknown_names_say_a_primitive_needs_a_library():
    with pytest.raises(TreeSyntaxError, match=r"'gotoNest3'.*needs a library: --library FILE"):
        parse("sel(seq(got_food, gotoNest3), forward)")
