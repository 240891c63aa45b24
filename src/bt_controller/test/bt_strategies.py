"""Hypothesis strategies for trees and blackboards, shared by the tests of bt_controller."""

from __future__ import annotations

from hypothesis import strategies as st

from bt_controller.language.tree import MAX_DRAW_KEY, Action, Composite, Condition, Node
from bt_controller.language.vocabulary import ACTIONS, COMPOSITES, CONDITIONS

leaves = st.one_of(st.sampled_from(CONDITIONS).map(Condition), st.sampled_from(ACTIONS).map(Action))


draw_keys = st.one_of(st.none(), st.none(), st.integers(0, 40), st.just(MAX_DRAW_KEY))
"""No key (mostly), a small one (shared by nodes or equal to an index now and then), or the largest."""


def _composite(kind: str, children: tuple[Node, ...], key: int | None) -> Composite:
    return Composite(kind, children, key if kind == "prob" else None)


def _composites(children: st.SearchStrategy[Node]) -> st.SearchStrategy[Node]:
    kids = st.lists(children, min_size=2, max_size=4).map(tuple)
    decorated = children.map(lambda child: Composite("success", (child,)))
    return st.one_of(st.builds(_composite, st.sampled_from(COMPOSITES), kids, draw_keys), decorated)


trees: st.SearchStrategy[Node] = st.recursive(leaves, _composites, max_leaves=40)
blackboards = st.lists(st.booleans(), min_size=len(CONDITIONS), max_size=len(CONDITIONS))
keys = st.integers(0, 2**64 - 1)
