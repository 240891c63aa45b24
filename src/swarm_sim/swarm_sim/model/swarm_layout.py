"""A swarm layout: which behaviour tree each robot runs. The one home of heterogeneous swarms.

A homogeneous swarm runs one tree on every robot; a heterogeneous one gives robot ``i`` (in id order) tree
``trees[i]``. Both roads (``swarm_sim.roads.reference_road``, ``swarm_sim.evaluation.batch.BatchEvaluator``)
and the node graph (one controller node per robot, each loading its own tree) take a layout. A network's text
(``nn(...)``, ``bt_controller.interpreters.network``) may stand wherever a tree's does, so a swarm may mix
trees and networks.

The file format (JSON) is one object, either

    {"trees": ["tree text", ... one per robot, robot 0 first]}   or   {"tree": "tree text"}

the second meaning every robot runs that tree. Anything else is refused with a ``LayoutError`` naming the
problem and the expected shape.
"""

from __future__ import annotations

import json
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

from bt_controller.errors import TreeError
from bt_controller.interpreters import Network, parse_controller
from bt_controller.language import MAX_DEPTH, MAX_NODES, Library, Node
from bt_controller.validate import strict_json

EXPECTED_SHAPE = '{"trees": ["tree text", ...] (one per robot)} or {"tree": "tree text"} (every robot)'
"""The file format, as error messages spell it."""


class LayoutError(ValueError):
    """A swarm layout that cannot be used: its message names the problem and the expected shape."""


@dataclass(frozen=True)
class SwarmLayout:
    """Tree text per robot, robot 0 first. Build one with ``uniform``, ``of_trees``, ``layout_from_json`` or
    ``load_layout`` (which check it); the constructor checks only the shape."""

    trees: tuple[str, ...]

    def __post_init__(self) -> None:
        if not self.trees or not all(isinstance(t, str) for t in self.trees):
            raise LayoutError(f"a swarm layout is a non-empty sequence of tree texts, got {self.trees!r}")

    @classmethod
    def uniform(cls, tree: str, n_robots: int) -> SwarmLayout:
        """Every one of ``n_robots`` robots runs ``tree``."""
        return cls((tree,) * n_robots)

    @property
    def n_robots(self) -> int:
        """Number of robots."""
        return len(self.trees)

    @property
    def homogeneous(self) -> bool:
        """Whether every robot runs the same tree text."""
        return len(set(self.trees)) == 1

    @property
    def distinct(self) -> tuple[str, ...]:
        """The different tree texts, in order of first use."""
        return tuple(dict.fromkeys(self.trees))

    @property
    def robot_tree(self) -> tuple[int, ...]:
        """Each robot's index into ``distinct``."""
        index = {text: k for k, text in enumerate(self.distinct)}
        return tuple(index[text] for text in self.trees)

    def parsed(
        self, library: Library | None = None, max_nodes: int = MAX_NODES, max_depth: int = MAX_DEPTH
    ) -> list[Node | Network]:
        """Each robot's parsed tree (or network); ``LayoutError`` naming the first robot whose tree does not
        parse."""
        cache: dict[str, Node | Network] = {}
        out = []
        for i, text in enumerate(self.trees):
            if text not in cache:
                try:
                    cache[text] = parse_controller(
                        text, max_nodes=max_nodes, max_depth=max_depth, library=library
                    )
                except TreeError as error:
                    raise LayoutError(
                        f"swarm layout: the tree of robot {i} does not parse: {error}"
                    ) from None
            out.append(cache[text])
        return out

    @property
    def label(self) -> str:
        """The layout as one string where results keep a tree (``/trial_result``, recordings): a homogeneous
        swarm's tree text unchanged, else the JSON list of the robots' trees (``layout_of_label`` reads
        either back)."""
        return self.trees[0] if self.homogeneous else json.dumps(list(self.trees))

    def as_json(self) -> dict[str, list[str]]:
        """The layout in the file format (always the ``trees`` form)."""
        return {"trees": list(self.trees)}


def of_trees(trees: Sequence[str], n_robots: int, library: Library | None = None) -> SwarmLayout:
    """A checked layout of one tree text per robot: ``n_robots`` texts that parse (with ``library``)."""
    if isinstance(trees, str) or not isinstance(trees, Sequence):
        raise LayoutError(
            f"swarm layout: expected a list of {n_robots} tree texts, got {type(trees).__name__}"
        )
    if len(trees) != n_robots:
        raise LayoutError(
            f"swarm layout: expected {n_robots} trees (one per robot), got {len(trees)}; "
            f"expected {EXPECTED_SHAPE}"
        )
    for i, text in enumerate(trees):
        if not isinstance(text, str):
            raise LayoutError(
                f"swarm layout: the tree of robot {i} is not tree text but {type(text).__name__}; "
                f"expected {EXPECTED_SHAPE}"
            )
    layout = SwarmLayout(tuple(trees))
    layout.parsed(library)
    return layout


def layout_from_json(document: object, n_robots: int, library: Library | None = None) -> SwarmLayout:
    """The checked layout of a parsed JSON document in the file format, for ``n_robots`` robots."""
    if not isinstance(document, dict) or len(document) != 1 or not ({"trees", "tree"} & set(document)):
        got = sorted(document) if isinstance(document, dict) else type(document).__name__
        raise LayoutError(f"swarm layout: expected {EXPECTED_SHAPE}, got {got}")
    if "tree" in document:
        tree = document["tree"]
        if not isinstance(tree, str):
            raise LayoutError(
                f'swarm layout: "tree" must be tree text, got {type(tree).__name__}; '
                f"expected {EXPECTED_SHAPE}"
            )
        return of_trees([tree] * n_robots, n_robots, library)
    trees = document["trees"]
    if not isinstance(trees, list):
        raise LayoutError(
            f'swarm layout: "trees" must be a list of {n_robots} tree texts, got {type(trees).__name__}; '
            f"expected {EXPECTED_SHAPE}"
        )
    return of_trees(trees, n_robots, library)


def layout_of_label(label: str, n_robots: int, library: Library | None = None) -> SwarmLayout:
    """The checked layout of a ``SwarmLayout.label``: a JSON list of tree texts (one per robot), or one tree
    text for every robot (tree text never starts with ``[``)."""
    if label.lstrip().startswith("["):
        try:
            trees = json.loads(label)
        except json.JSONDecodeError as error:
            raise LayoutError(f"swarm layout: a list of trees that is not JSON ({error})") from None
        return of_trees(trees, n_robots, library)
    return of_trees([label] * n_robots, n_robots, library)


def load_layout(path: str | Path, n_robots: int, library: Library | None = None) -> SwarmLayout:
    """The checked layout in file ``path``; ``LayoutError`` (naming the file) if it cannot be read or used."""
    try:
        document = strict_json(Path(path).read_text())
    except (OSError, UnicodeDecodeError) as error:
        raise LayoutError(f"swarm layout {path}: cannot read it: {error}") from None
    except json.JSONDecodeError as error:
        raise LayoutError(f"swarm layout {path}: not JSON ({error}); expected {EXPECTED_SHAPE}") from None
    except ValueError as error:  # NaN, a key twice (JSON keeps the last without a word)
        raise LayoutError(f"swarm layout {path}: {error}; expected {EXPECTED_SHAPE}") from None
    try:
        return layout_from_json(document, n_robots, library)
    except LayoutError as error:  # its message names the file
        raise LayoutError(str(error).replace("swarm layout:", f"swarm layout {path}:", 1)) from None
