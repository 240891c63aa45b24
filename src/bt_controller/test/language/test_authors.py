"""The authors' tree syntax read into ours: every token of theirs, the 2026 numbered food conditions, and
what is left alone."""

import pytest

from bt_controller.language.authors import LEAVES, from_authors, is_authors_syntax
from bt_controller.language.tree import parse
from bt_controller.language.vocabulary import ACTIONS, CONDITIONS


def test_every_leaf_of_theirs_is_one_of_ours():
    assert set(LEAVES.values()) <= set(CONDITIONS) | set(ACTIONS)
    assert {f"food_left{kind}" for kind in (1, 2, 3)} <= set(LEAVES.values())


@pytest.mark.parametrize(
    ("theirs", "ours"),
    [
        ("selm2(seqm2(ifFoodToLeft, fl), f)", "sel2(seq2(food_left, forward_left), forward)"),
        ("probm3(ifGotFood2, ifOnFood3, ifFoodToRight1)", "prob3(got_food2, on_food3, food_right1)"),
        ("successd(gotoNest1)", "success(gotoNest1)"),  # a primitive's name is kept
    ],
)
def test_their_trees_read_as_ours(theirs, ours):
    assert is_authors_syntax(theirs)
    assert from_authors(theirs) == ours
    parse(from_authors(theirs).replace("gotoNest1", "stop"))


def test_our_syntax_is_not_theirs():
    assert not is_authors_syntax("sel(seq(got_food2, forward), stop)")
