"""Trees as people are shown them: simplified (``bt_controller.language.simplify``), each primitive's copy
kept whole.

The results files, the explorer and the foraging study's report all show trees this way; this module sits
below them so that none imports another for it.
"""

from __future__ import annotations

from functools import cache

from bt_controller.language import Library, Node, parse, simplify_if_small, to_text


@cache
def simplified(tree: str, library: Library | None = None) -> str:
    """The simplified text of a tree text (``bt_controller.language.simplify``); each copy of a primitive of
    ``library`` is kept whole and written by its name."""
    simple = simplified_tree(parse(tree, library=library), library)
    return to_text(simple) if library is None else library.fold(simple)


def simplified_tree(tree: Node, library: Library | None = None) -> Node:
    """``tree`` simplified for people to read: each copy of a primitive of ``library`` kept whole."""
    return simplify_if_small(tree, whole=None if library is None else library.is_copy)
