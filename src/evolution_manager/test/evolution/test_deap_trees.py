"""The primitive set factory and the tree text round trip."""

from __future__ import annotations

import random

import deap.creator
import pytest

from bt_controller.language import ACTIONS, CONDITIONS, CONDITIONS_2023, library_from_json, parse, to_text
from evolution_manager.errors import TreeTextError
from evolution_manager.evolution.deap_trees import (
    BehaviourTree,
    make_primitive_set,
    tree_from_text,
    tree_to_text,
)
from evolution_manager.evolution.operators import full_tree


def test_primitive_set_has_the_vocabulary_and_leaves_no_global_state(pset):
    before = set(vars(deap.creator))
    names = sorted(p.name for p in pset.primitives[pset.ret])
    assert names == sorted(f"{c}{n}" for c in ("seq", "sel", "prob") for n in (2, 3, 4))
    # the paper's node set: got_food is the foraging task's (and the authors' 2023 set had it too:
    # params.py:128 at 6c65001; the paper's table 3 lists eight conditions)
    assert [t.name for t in pset.terminals[pset.ret]] == list(CONDITIONS_2023 + ACTIONS)
    make_primitive_set()
    assert set(vars(deap.creator)) == before


def test_foraging_node_set_and_library_primitives_as_terminals():
    library = library_from_json(
        {"format": 1, "primitives": [{"name": "gotoNest3", "tree": "sel(in_nest, prob(forward, stop))"}]}, "l"
    )
    pset = make_primitive_set(CONDITIONS, library)
    assert [t.name for t in pset.terminals[pset.ret]] == [*CONDITIONS, *ACTIONS, "gotoNest3"]
    tree = tree_from_text("sel(seq(got_food, gotoNest3), success(sel(in_nest, prob(forward, stop))))", pset,
                          library=library)  # fmt: skip
    assert [n.name for n in tree] == ["sel2", "seq2", "got_food", "gotoNest3", "gotoNest3"]
    assert tree_to_text(tree) == "sel(seq(got_food, gotoNest3), gotoNest3)"
    with pytest.raises(TreeTextError, match="unknown node 'success1'"):
        tree_from_text("success(forward)", pset, library=library)


def test_text_round_trip_matches_the_bt_engine(pset):
    rng = random.Random(5)
    for _ in range(200):
        tree = full_tree(pset, rng, 1, 4)
        text = tree_to_text(tree)
        assert text == to_text(parse(text))
        again = tree_from_text(text, pset)
        assert [n.name for n in again] == [n.name for n in tree]
        assert isinstance(again, BehaviourTree) and not again.fitness.valid


def test_suffixed_names_are_read_and_canonical_text_is_written(pset):
    tree = tree_from_text("sel2(seq2(in_nest, stop), forward)", pset)
    assert tree_to_text(tree) == "sel(seq(in_nest, stop), forward)"
    assert tree.height == 2 and len(tree) == 5


def test_draw_keys_other_than_the_index_are_refused(pset):
    # A key equal to the node's pre-order index is its default: the same draws as plain prob.
    assert (
        tree_to_text(tree_from_text("sel(stop, prob@2(stop, forward))", pset))
        == "sel(stop, prob(stop, forward))"
    )
    with pytest.raises(TreeTextError, match="prob@1 at node 2 names a draw key"):
        tree_from_text("sel(stop, prob@1(stop, forward))", pset)


BAD = ["", "sel(stop)", "seq(stop, stop", "seq3(stop, stop)", "fly", "sel(a, b)", 7]


@pytest.mark.parametrize("bad", BAD)
def test_bad_text_is_refused_with_a_reason(pset, bad):
    with pytest.raises(TreeTextError, match="not a behaviour tree"):
        tree_from_text(bad, pset)


def test_the_size_limit_of_trees_is_the_evaluators():
    from bt_controller.language import MAX_DEPTH, MAX_NODES
    from evolution_manager.evolution.parameters import GPParameters, QDParameters

    assert GPParameters().max_nodes == QDParameters().max_nodes == MAX_NODES
    assert GPParameters().max_height <= MAX_DEPTH
