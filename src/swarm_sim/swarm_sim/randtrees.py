"""Random tree text for tests and benchmarks (not the evolution's initialisation, which lives elsewhere).

``random_tree(rng, size)`` grows a tree by replacing a uniformly chosen leaf with a composite of 2 to 4
fresh leaves until no further composite fits in ``size`` nodes; leaves are conditions or actions with equal
probability, then uniform within their kind.
"""

from __future__ import annotations

import numpy as np

from bt_controller.vocabulary import ACTIONS, COMPOSITES, CONDITIONS, MAX_CHILDREN, MIN_CHILDREN


def _leaf(rng: np.random.Generator) -> str:
    names = CONDITIONS if rng.random() < 0.5 else ACTIONS
    return names[int(rng.integers(len(names)))]


def random_tree(rng: np.random.Generator, size: int) -> str:
    """Tree text of ``size`` or ``size - 1`` nodes (1 when ``size`` < 3), grown at random from ``rng``."""
    # A node is [name, children]; leaves have no children.
    root: list = [_leaf(rng), []]
    leaves = [root]
    n_nodes = 1
    while True:
        room = size - n_nodes
        if room < MIN_CHILDREN:
            break
        k = int(rng.integers(MIN_CHILDREN, min(MAX_CHILDREN, room) + 1))
        target = leaves.pop(int(rng.integers(len(leaves))))
        target[0] = COMPOSITES[int(rng.integers(len(COMPOSITES)))]
        target[1] = [[_leaf(rng), []] for _ in range(k)]
        leaves.extend(target[1])
        n_nodes += k
    return _text(root)


def _text(root: list) -> str:
    # Iterative printing (trees may be deep): a stack of (node, next child position).
    out: list[str] = []
    stack: list[tuple[list, int]] = [(root, 0)]
    while stack:
        node, position = stack.pop()
        name, children = node
        if not children:
            out.append(name)
            continue
        if position == 0:
            out.append(name + "(")
        elif position < len(children):
            out.append(", ")
        if position == len(children):
            out.append(")")
            continue
        stack.append((node, position + 1))
        stack.append((children[position], 0))
    return "".join(out)


def random_trees(seed: int, count: int, min_size: int = 10, max_size: int = 60) -> list[str]:
    """``count`` random trees of ``min_size`` to ``max_size`` nodes, reproducible from ``seed``."""
    rng = np.random.default_rng(seed)
    return [random_tree(rng, int(rng.integers(min_size + 1, max_size + 1))) for _ in range(count)]
