"""The authors' tree syntax (DEAP's ``str(individual)`` in KirstyMontague/big-mad-robot-repo), read into ours.

Their trees name composites by arity (``seqm2``, ``selm3``, ``probm4``), the decorator ``successd``,
conditions ``ifOnFood ifInNest ifGotFood ifFoodToLeft ifFoodToRight ifNestToLeft ifNestToRight ifRobotToLeft
ifRobotToRight`` (in their 2026 code also ``ifOnFood1``-``3`` and so on, per food kind) and actions ``stop f
fl fr r rl rr`` (``params.py`` ``addNodes``; ``CNode.cpp``). Reference
trees of the validation (``docs/validation/``) and their sub-behaviours files come in it. ``from_authors``
maps each token to ours and leaves anything else (a primitive's name, punctuation) as it is, so that the
result parses with our parser (``seq2`` names keep their arity check); ``is_authors_syntax`` tells the two
syntaxes apart by the tokens only theirs has. Only names are mapped: the meanings are ours
(``docs/model.md``).
"""

from __future__ import annotations

import re

COMPOSITES: dict[str, str] = {"seqm": "seq", "selm": "sel", "probm": "prob"}
"""Their composite stems (followed by the arity) and ours."""
DECORATORS: dict[str, str] = {"successd": "success"}
LEAVES: dict[str, str] = {
    "ifOnFood": "on_food",
    "ifInNest": "in_nest",
    "ifGotFood": "got_food",
    "ifFoodToLeft": "food_left",
    "ifFoodToRight": "food_right",
    "ifNestToLeft": "nest_left",
    "ifNestToRight": "nest_right",
    "ifRobotToLeft": "robot_left",
    "ifRobotToRight": "robot_right",
    "stop": "stop",
    "f": "forward",
    "fl": "forward_left",
    "fr": "forward_right",
    "r": "reverse",
    "rl": "reverse_left",
    "rr": "reverse_right",
}
LEAVES.update(
    {
        f"{theirs}{kind}": f"{ours}{kind}"
        for theirs, ours in (
            ("ifOnFood", "on_food"),
            ("ifGotFood", "got_food"),
            ("ifFoodToLeft", "food_left"),
            ("ifFoodToRight", "food_right"),
        )
        for kind in (1, 2, 3)
    }
)  # their 2026 code's conditions of food kinds 1-3 (CNode.cpp:115-136 at 1cd2358)
"""Their conditions and actions, and ours."""

_TOKEN = re.compile(r"[A-Za-z_][A-Za-z0-9_]*")
_COMPOSITE = re.compile(r"^(seqm|selm|probm)([0-9]+)$")
_THEIRS_ONLY = {name for name in LEAVES if name != "stop"} | set(DECORATORS)


def _token(name: str) -> str:
    composite = _COMPOSITE.match(name)
    if composite is not None:
        return COMPOSITES[composite.group(1)] + composite.group(2)
    return DECORATORS.get(name) or LEAVES.get(name) or name


def from_authors(text: str) -> str:
    """``text`` with every token of the authors' syntax replaced by ours (``seqm3`` -> ``seq3``, ``ifOnFood``
    -> ``on_food``, ``fl`` -> ``forward_left``, ``successd`` -> ``success``); other tokens are kept."""
    return _TOKEN.sub(lambda m: _token(m.group(0)), text)


def is_authors_syntax(text: str) -> bool:
    """Whether ``text`` uses a token only the authors' syntax has (``seqm2``, ``ifInNest``, ``f`` ...)."""
    return any(_COMPOSITE.match(t) or t in _THEIRS_ONLY for t in _TOKEN.findall(text))
