"""Behaviour trees as DEAP genetic-programming trees.

The primitive set is built by :func:`make_primitive_set` (no global ``creator`` classes): one primitive per
composite and number of children (``seq2`` ... ``prob4``, DEAP needs a fixed arity) and one terminal per
condition and action, all named as in :mod:`bt_controller.language.vocabulary` (the conditions of the run's
task: the paper's eight, or all nine with ``got_food`` for foraging), and one terminal per primitive of a
library (``bt_controller.language.library``: a name that stands for ``success(<its tree>)``); the hierarchical
node set of the 2024 follow-up has no actions and three conditions (``HIERARCHICAL_CONDITIONS``). Primitives
are never compiled: a tree is data, turned into text with :func:`tree_to_text` and read back with
:func:`tree_from_text` through ``bt_controller``'s parser (DEAP's ``PrimitiveTree.from_string`` falls back to
``eval`` on unknown tokens).
"""

from __future__ import annotations

from collections.abc import Sequence

from deap import base, gp

from bt_controller.errors import TreeError
from bt_controller.language import (
    ACTIONS,
    COMPOSITES,
    CONDITIONS_2023,
    MAX_CHILDREN,
    MAX_DEPTH,
    MAX_NODES,
    MIN_CHILDREN,
    Composite,
    Library,
    is_decorator,
    leaf_name,
    parse,
)
from evolution_manager.errors import TreeTextError
from evolution_manager.evolution.parameters import HIERARCHICAL_CONDITIONS, MAX_TREE_NODES, NODE_SETS
from swarm_sim.model import DESCRIPTORS, OBJECTIVES

__all__ = [
    "DESCRIPTORS",
    "HIERARCHICAL_CONDITIONS",
    "MAX_TREE_NODES",
    "NODE_SETS",
    "OBJECTIVES",
    "BehaviourTree",
    "TripleFitness",
    "make_primitive_set",
    "tree_from_text",
    "tree_to_text",
]


class TripleFitness(base.Fitness):
    """Every objective of one evaluation (``OBJECTIVES``), all maximised."""

    weights = (1.0,) * len(OBJECTIVES)


class BehaviourTree(gp.PrimitiveTree):
    """A DEAP tree with a :class:`TripleFitness`; invalid (empty) until it has been evaluated."""

    def __init__(self, content: list) -> None:
        super().__init__(content)
        self.fitness = TripleFitness()
        self.descriptors: tuple[float, ...] | None = None
        """The descriptors of the evaluation that gave the fitness (None until evaluated, or failed)."""

    def clone(self) -> BehaviourTree:
        """A copy of the tree (nodes are shared, they are immutable) with a copy of its fitness and
        descriptors."""
        twin = BehaviourTree(self)
        if self.fitness.valid:
            twin.fitness.values = self.fitness.values
        twin.descriptors = self.descriptors
        return twin


def _never_called(*_children: object) -> None:  # pragma: no cover - trees are interpreted, never compiled
    raise TypeError("behaviour-tree primitives are data; interpret trees with bt_controller")


def make_primitive_set(
    conditions: Sequence[str] = CONDITIONS_2023, library: Library | None = None, nodes: str = "flat"
) -> gp.PrimitiveSet:
    """A fresh primitive set: composites with 2-4 children (``seq2`` ... ``prob4``), ``conditions`` (the
    paper's eight by default), actions unless ``nodes`` is ``hierarchical``, and the primitives of
    ``library`` by name.

    Primitives are added composite by composite, arity by arity, and terminals as conditions, actions, then
    library primitives in the library's order, so the lists DEAP keeps (and the operators choose from) have a
    fixed order (with the paper's conditions and no library, the set of the 2023 experiment). A hierarchical
    set also has ``leaf_classes``, (conditions, primitives): a new tree's leaf is a condition or a primitive
    with probability 1/2 each, then uniform within its class (``operators.choose_leaf``; the authors'
    local.py:132,177 at a73e4af: 1/6 per condition and 1/96 per primitive with 48 primitives).
    """
    if nodes not in NODE_SETS:
        raise ValueError(f"nodes must be one of {', '.join(NODE_SETS)}, got {nodes!r}")
    names = library.names if library is not None else ()
    if nodes == "hierarchical" and not names:
        raise ValueError("the hierarchical node set needs a library with at least one primitive")
    pset = gp.PrimitiveSet("behaviour_tree", 0)
    for composite in COMPOSITES:
        for arity in range(MIN_CHILDREN, MAX_CHILDREN + 1):
            pset.addPrimitive(_never_called, arity, name=f"{composite}{arity}")
    actions = ACTIONS if nodes == "flat" else ()
    for name in (*conditions, *actions, *names):
        pset.addTerminal(name, name=name)
    if nodes == "hierarchical":
        pset.leaf_classes = (
            tuple(pset.mapping[name] for name in conditions),
            tuple(pset.mapping[name] for name in names),
        )
    return pset


def tree_to_text(tree: gp.PrimitiveTree) -> str:
    """The canonical text of a tree: composite names without the arity suffix, ``", "`` between children."""
    parts: list[str] = []
    open_frames: list[list[int]] = []  # per open composite: [number of children, children printed]
    for node in tree:
        if open_frames and open_frames[-1][1]:
            parts.append(", ")
        if node.arity:
            parts.append(node.name[:-1] + "(")
            open_frames.append([node.arity, 0])
            continue
        parts.append(node.name)
        while open_frames:
            open_frames[-1][1] += 1
            if open_frames[-1][1] < open_frames[-1][0]:
                break
            open_frames.pop()
            parts.append(")")
    return "".join(parts)


def tree_from_text(
    text: str,
    pset: gp.PrimitiveSet,
    max_nodes: int = MAX_NODES,
    max_depth: int = MAX_DEPTH,
    library: Library | None = None,
) -> BehaviourTree:
    """Parse a tree text with ``bt_controller``'s parser (limits on size and depth, the library's primitives
    expanded; no ``eval``) into a :class:`BehaviourTree` of ``pset``, each ``success(<a primitive's tree>)``
    back as that primitive's terminal; raise :class:`TreeTextError` saying what is wrong."""
    try:
        root = parse(text, max_nodes=max_nodes, max_depth=max_depth, library=library)
    except (TreeError, TypeError) as error:
        raise TreeTextError(f"not a behaviour tree: {error}") from None
    nodes = []
    skip = 0  # nodes left of a primitive's expansion, taken as its terminal
    for index, node in enumerate(root.preorder()):
        if skip:
            skip -= 1
            continue
        if library is not None and is_decorator(node):
            assert isinstance(node, Composite)
            name = library.fold(node)
            if name in pset.mapping:
                nodes.append(pset.mapping[name])
                skip = node.size - 1
                continue
        if isinstance(node, Composite) and node.draw_key not in (None, index):
            # DEAP's primitives cannot carry a key: the tree would draw differently (docs/interfaces.md).
            raise TreeTextError(
                f"not a behaviour tree of this primitive set: {node.head} at node {index} names a draw key "
                f"other than its index (simplify with keep_positions=True for trees without keys)"
            )
        name = f"{node.kind}{len(node.children)}" if isinstance(node, Composite) else leaf_name(node)
        if name not in pset.mapping:
            raise TreeTextError(f"not a behaviour tree of this primitive set: unknown node {name!r}")
        nodes.append(pset.mapping[name])
    return BehaviourTree(nodes)
