"""Primitive libraries: the JSON format, its checks, and the expansion of names into success copies."""

from __future__ import annotations

import json

import pytest

from bt_controller.errors import TreeLimitError, TreeSyntaxError
from bt_controller.interpreters.semantics import ReferenceRobot
from bt_controller.language.library import LibraryError, library_from_json, load_library
from bt_controller.language.simplify import simplify
from bt_controller.language.tree import parse, to_text
from bt_controller.language.vocabulary import CONDITION_INDEX

NEST = "sel(in_nest, seq(nest_left, forward_left), seq(nest_right, forward_right), prob(forward, reverse))"
FOOD = "sel(on_food, seq(food_left, forward_left), forward)"


def library(*pairs: tuple[str, str]):
    return library_from_json(
        {"format": 1, "primitives": [{"name": n, "tree": t} for n, t in pairs]}, "lib.json"
    )


def test_each_use_is_its_own_success_copy():
    lib = library(("gotoNest3", NEST), ("gotoFood6", FOOD))
    tree = lib.parse("sel(seq(got_food, gotoNest3), prob(gotoFood6, gotoNest3))")
    written = f"sel(seq(got_food, success({NEST})), prob(success({FOOD}), success({NEST})))"
    assert tree == parse(written)
    assert lib.fold(tree) == "sel(seq(got_food, gotoNest3), prob(gotoFood6, gotoNest3))"
    assert lib.parse(lib.fold(tree)) == tree
    # The two copies of gotoNest3 are separate nodes in pre-order: their own memory and their own draws.
    probs = [i for i, n in enumerate(tree.preorder()) if getattr(n, "kind", "") == "prob"]
    assert len(probs) == 3


def test_a_named_primitive_ticks_as_its_tree_written_out_under_success():
    lib = library(("gotoNest3", NEST))
    named = lib.parse("sel(seq(got_food, gotoNest3), forward)")
    written = parse(f"sel(seq(got_food, success({NEST})), forward)")
    boards = [[bool((t * 7 + c * 3) % 5 < 2) for c in range(len(CONDITION_INDEX))] for t in range(40)]
    for key in range(5):
        a, b = ReferenceRobot(named, key), ReferenceRobot(written, key)
        assert [a.step(x) for x in boards] == [b.step(x) for x in boards]


def test_unknown_names_name_the_library():
    lib = library(("gotoNest3", NEST))
    expected = r"unknown node 'gotoNest4'.*primitives of library lib.json: gotoNest3"
    with pytest.raises(TreeSyntaxError, match=expected):
        lib.parse("sel(got_food, gotoNest4)")


def test_names_inside_primitives_are_not_expanded():
    with pytest.raises(LibraryError, match=r"library lib.json: primitive 'b': .*unknown node 'a'"):
        library(("a", "forward"), ("b", "seq(a, stop)"))


def one(name: str, tree: str = "stop") -> dict:
    return {"format": 1, "primitives": [{"name": name, "tree": tree}]}


@pytest.mark.parametrize(
    ("document", "fragment"),
    [
        ([], "expected a JSON object"),
        ({"format": 2, "primitives": []}, "'format' must be 1"),
        ({"format": True, "primitives": []}, "'format' must be 1"),
        ({"format": 1}, "'primitives' must be a list"),
        ({"format": 1, "primitives": [], "extra": 1}, "unknown key 'extra'"),
        ({"format": 1, "primitives": [{"name": "a"}]}, "'tree' must be tree text"),
        ({"format": 1, "primitives": [{"name": "a", "tree": "stop", "sourc": {}}]}, "unknown key 'sourc'"),
        ({"format": 1, "primitives": [{"name": "a", "tree": "stop", "source": 3}]}, "'source' must be"),
        (one("forward"), "is a node of the tree language"),
        (one("seq3"), "is a node of the tree language"),
        (one("success"), "is a node of the tree language"),
        (one("a b"), "must be an identifier"),
        ({"format": 1, "primitives": one("a")["primitives"] * 2}, "named twice"),
        (one("a", "seq(stop"), "primitive 'a': line 1"),
    ],
)
def test_bad_libraries_get_one_clear_error(document, fragment):
    with pytest.raises(LibraryError, match=fragment) as info:
        library_from_json(document, "lib.json")
    assert str(info.value).startswith("library lib.json: ")


def test_files_round_trip_and_bad_files(tmp_path):
    path = tmp_path / "prims.json"
    entry = {"name": "gotoFood6", "tree": FOOD, "source": {"commit": "a73e4af"}}
    document = {"format": 1, "primitives": [entry]}
    path.write_text(json.dumps(document))
    lib = load_library(path)
    assert lib.names == ("gotoFood6",) and lib.label == str(path)
    assert lib.as_json() == document
    assert load_library(path).digest == lib.digest != library(("gotoFood6", "stop")).digest
    with pytest.raises(LibraryError, match="no such file"):
        load_library(tmp_path / "missing.json")
    (tmp_path / "bad.json").write_text("{")
    with pytest.raises(LibraryError, match="not JSON"):
        load_library(tmp_path / "bad.json")


@pytest.mark.parametrize(
    ("source", "fragment"),
    [
        ('{"fitness": NaN}', "NaN is not a JSON number"),
        ('{"fitness": Infinity}', "Infinity is not a JSON number"),
        ('{"fitness": -Infinity}', "-Infinity is not a JSON number"),
        ('{"fitness": 1e999}', "1e999 is out of range"),
        ('{"fitness": 1, "fitness": 2}', "the key 'fitness' appears twice"),
    ],
)
def test_a_library_with_nan_or_a_key_twice_is_refused_at_load(tmp_path, source, fragment):
    """NaN in a primitive's source was accepted, then crashed evolve and explorer writing it back."""
    path = tmp_path / "lib.json"
    entry = '{"name": "a", "tree": "stop", "source": ' + source + "}"
    path.write_text('{"format": 1, "primitives": [' + entry + "]}")
    with pytest.raises(LibraryError, match=fragment) as info:
        load_library(path)
    assert str(info.value).startswith(f"library {path}: ") and "\n" not in str(info.value)


def test_limits_bound_the_tree_as_written_a_name_one_node():
    # as the authors' GP counts a primitive (gp/ea.py:949-959) and evolution's static limits see it
    lib = library(("p", FOOD))
    assert lib.parse("seq(p, p)").size == 1 + 2 * 7  # seq and twice success with its 6 nodes
    assert lib.parse("seq(p, p)", max_nodes=3, max_depth=1).size == 15
    with pytest.raises(TreeLimitError, match="max_nodes=2"):
        lib.parse("seq(p, p)", max_nodes=2)
    with pytest.raises(TreeLimitError, match="max_depth=0"):
        lib.parse("seq(p, p)", max_depth=0)
    assert to_text(lib.parse("p", max_nodes=1, max_depth=0)).count("success(") == 1
    # a written tree at the limits whose expansion is larger: parsed, evaluated and simplified as it is
    from bt_controller.language.simplify import MAX_SIMPLIFY_NODES, simplify_if_small

    wide = "sel(seq(p, p, p, p), seq(p, p, p, p), p, p)"  # 11 nodes written, 73 expanded
    for _ in range(3):
        wide = "seq(" + ", ".join([wide] * 4) + ")"
    big = lib.parse(wide)  # 725 nodes written
    assert big.size == 4693
    assert big.size > MAX_SIMPLIFY_NODES and simplify_if_small(big) is big
    assert simplify_if_small(lib.parse("seq(p, p)")).size <= 15


def test_simplifying_keeps_each_primitive_whole_so_that_it_is_still_named():
    """Under ``in_nest`` the simplifier knows the copy's own ``in_nest`` holds and would rewrite inside it,
    losing its name; kept whole, the tree is simplified around it and still folds to its name."""
    away = "sel(seq(in_nest, forward), reverse)"
    lib = library(("goAwayFromNest1", away))
    tree = lib.parse("sel(seq(in_nest, in_nest, goAwayFromNest1), forward)")
    assert lib.fold(simplify(tree)) == "sel(seq(in_nest, forward), forward)"  # rewritten inside
    kept = simplify(tree, whole=lib.is_copy)
    assert lib.fold(kept) == "sel(seq(in_nest, goAwayFromNest1), forward)"
    # a copy that can never run still goes, whole
    dead = lib.parse("sel(forward, goAwayFromNest1)")
    assert lib.fold(simplify(dead, whole=lib.is_copy)) == "forward"
