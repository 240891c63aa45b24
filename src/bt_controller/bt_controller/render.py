"""Draw a tree to SVG or PNG with matplotlib (no Graphviz needed): a tidy top-down layout.

Leaves sit at consecutive x positions in pre-order; a composite is centred over its children; depth goes
down. Colours and labels follow ``formats.to_dot``: sequence blue, selector orange, probabilistic green (with
its draw key, ``prob % @7``), conditions white ellipses ending in '?', actions grey boxes. The layout is
iterative, so an SVG takes a tree of any depth; a PNG is refused (TreeLimitError) beyond the
``MAX_PNG_PIXELS`` matplotlib can write in each direction.
"""

from __future__ import annotations

from pathlib import Path

from bt_controller.errors import TreeLimitError
from bt_controller.formats import COMPOSITE_FILL, composite_label
from bt_controller.tree import Composite, Condition, Node, leaf_name

RENDER_FORMATS = ("svg", "png")
DPI = 120
INCHES_PER_LEAF = 1.35
INCHES_PER_LEVEL = 0.9
MAX_PNG_PIXELS = 2**16 - 1
"""Largest PNG width or height matplotlib writes."""


def layout(tree: Node) -> list[tuple[Node, float, int, int | None]]:
    """``(node, x, depth, parent index)`` for every node in pre-order (iterative, for any depth)."""
    placed: list[tuple[Node, float, int, int | None]] = []
    xs: list[list[float]] = []  # per open composite, the x of its children placed so far
    next_leaf = 0.0
    stack: list[tuple[Node, int, int | None] | int] = [(tree, 0, None)]  # to place, or a composite to centre
    while stack:
        item = stack.pop()
        if isinstance(item, int):  # every child of the composite at ``item`` is placed: centre it
            index = item
            node, _, depth, parent = placed[index]
            children = xs.pop()
            x = (children[0] + children[-1]) / 2
        else:
            node, depth, parent = item
            index = len(placed)
            placed.append((node, 0.0, depth, parent))
            if isinstance(node, Composite):
                xs.append([])
                stack.append(index)
                stack.extend((child, depth + 1, index) for child in reversed(node.children))
                continue
            x = next_leaf
            next_leaf += 1.0
        placed[index] = (node, x, depth, parent)
        if xs:
            xs[-1].append(x)
    return placed


def render(tree: Node, path: str | Path, fmt: str | None = None) -> Path:
    """Draw ``tree`` into ``path`` as SVG or PNG (``fmt`` defaults to the file suffix); returns the path."""
    path = Path(path)
    fmt = (fmt or path.suffix.lstrip(".")).lower()
    if fmt not in RENDER_FORMATS:
        raise ValueError(f"can render {' or '.join(RENDER_FORMATS)}, not {fmt!r}")
    leaves = sum(1 for node in tree.preorder() if not isinstance(node, Composite))
    size = (max(2.0, INCHES_PER_LEAF * leaves), max(1.2, INCHES_PER_LEVEL * (tree.depth + 1)))
    if fmt == "png" and max(size) * DPI > MAX_PNG_PIXELS:
        most_leaves = int(MAX_PNG_PIXELS / DPI / INCHES_PER_LEAF)
        most_depth = int(MAX_PNG_PIXELS / DPI / INCHES_PER_LEVEL) - 1
        raise TreeLimitError(
            f"tree has {leaves} leaves and depth {tree.depth}; a PNG drawing takes at most {most_leaves} "
            f"leaves and depth {most_depth} (draw it as svg, or use text, xml or dot)"
        )
    import matplotlib

    matplotlib.use("Agg")
    from matplotlib import pyplot as plt
    from matplotlib.patches import FancyBboxPatch

    placed = layout(tree)
    figure = plt.figure(figsize=size)
    width, height = leaves, tree.depth + 1
    axes = figure.add_axes((0, 0, 1, 1))
    axes.set_xlim(-0.6, width - 0.4)
    axes.set_ylim(-height + 0.4, 0.6)
    axes.axis("off")
    for _, x, depth, parent in placed:
        if parent is not None:
            _, px, pdepth, _ = placed[parent]
            axes.plot([px, x], [-pdepth - 0.18, -depth + 0.18], color="#555555", linewidth=0.8, zorder=1)
    for node, x, depth, _ in placed:
        if isinstance(node, Composite):
            label, fill, style = composite_label(node), COMPOSITE_FILL[node.kind], "round,pad=0.02"
        elif isinstance(node, Condition):
            label, fill, style = node.name + "?", "#ffffff", "round,pad=0.02,rounding_size=0.18"
        else:
            label, fill, style = leaf_name(node), "#eeeeee", "square,pad=0.02"
        axes.add_patch(
            FancyBboxPatch(
                (x - 0.45, -depth - 0.18),
                0.9,
                0.36,
                boxstyle=style,
                facecolor=fill,
                edgecolor="#333333",
                linewidth=0.8,
                zorder=2,
            )
        )
        axes.text(x, -depth, label, ha="center", va="center", fontsize=8, zorder=3)
    figure.savefig(path, format=fmt, dpi=DPI)
    plt.close(figure)
    return path
