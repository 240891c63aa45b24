"""Draw a tree to SVG or PNG with matplotlib (no Graphviz needed): a tidy top-down layout.

Leaves sit at consecutive x positions in pre-order; a composite is centred over its children; depth goes
down. Colours and labels follow ``formats.to_dot``: sequence blue, selector orange, probabilistic green (with
its draw key, ``prob % @7``), conditions white ellipses ending in '?', actions grey boxes; with a library's
``name_of``, each copy of a primitive is one purple box with the primitive's name. The layout is
iterative, so an SVG takes a tree of any depth; a PNG is refused (TreeLimitError) beyond the
``MAX_PNG_PIXELS`` matplotlib can write in each direction.

``vertical=True`` lays the tree out as an outline instead, for a page's width: a row per node in pre-order,
indented by depth, each box as wide as its label, a child joined to its parent by an elbow. Its width grows
with the depth and the longest label, not with the number of leaves.
"""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path
from typing import TYPE_CHECKING

from bt_controller.errors import TreeLimitError
from bt_controller.language.formats import COMPOSITE_FILL, composite_label
from bt_controller.language.tree import Composite, Condition, Node, leaf_name
from swarm_ros.safe_paths import replace_file

if TYPE_CHECKING:
    from matplotlib.figure import Figure

RENDER_FORMATS = ("svg", "png")
DPI = 120
INCHES_PER_LEAF = 1.35
INCHES_PER_LEVEL = 0.9
PRIMITIVE_FILL = "#e8dcf0"
"""A library primitive's box (drawn by name, its tree not expanded)."""
MAX_PNG_PIXELS = 2**16 - 1
"""Largest PNG width or height matplotlib writes."""
ROW_INCHES = 0.3
"""The vertical layout's row height."""
INDENT_INCHES = 0.28
"""The vertical layout's indent per level."""
CHARACTER_INCHES = 0.075
"""The width of a label's character at the drawings' 8 points (DejaVu Sans, with a margin)."""


def layout(
    tree: Node, name_of: Callable[[Composite], str | None] | None = None
) -> list[tuple[Node, float, int, int | None]]:
    """``(node, x, depth, parent index)`` for every node in pre-order (iterative, for any depth); a
    composite that ``name_of`` names is placed as a leaf, without its subtree."""
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
            if isinstance(node, Composite) and (name_of is None or name_of(node) is None):
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


def _style(node: Node, name: str | None) -> tuple[str, str, str]:
    """A node's label, fill and box style (``name``: the primitive it copies, drawn as one box)."""
    if name is not None:
        return name, PRIMITIVE_FILL, "round,pad=0.02,rounding_size=0.08"
    if isinstance(node, Composite):
        return composite_label(node), COMPOSITE_FILL[node.kind], "round,pad=0.02"
    if isinstance(node, Condition):
        return node.name + "?", "#ffffff", "round,pad=0.02,rounding_size=0.18"
    return leaf_name(node), "#eeeeee", "square,pad=0.02"


def render(
    tree: Node,
    path: str | Path,
    fmt: str | None = None,
    name_of: Callable[[Composite], str | None] | None = None,
    vertical: bool = False,
) -> Path:
    """Draw ``tree`` into ``path`` as SVG or PNG (``fmt`` defaults to the file suffix); returns the path.
    ``name_of`` (e.g. a library's ``name_of``) names composites drawn as one box, a primitive's copy;
    ``vertical``: the outline layout (see the module docstring)."""
    path = Path(path)
    fmt = (fmt or path.suffix.lstrip(".")).lower()
    if fmt not in RENDER_FORMATS:
        raise ValueError(f"can render {' or '.join(RENDER_FORMATS)}, not {fmt!r}")
    placed = layout(tree, name_of)

    def named(node: Node) -> str | None:
        return name_of(node) if name_of is not None and isinstance(node, Composite) else None

    if vertical:
        return _render_outline(placed, named, path, fmt)
    leaves = sum(1 for node, _, _, _ in placed if not isinstance(node, Composite) or named(node))
    depth = max(d for _, _, d, _ in placed) if name_of is not None else tree.depth
    size = (max(2.0, INCHES_PER_LEAF * leaves), max(1.2, INCHES_PER_LEVEL * (depth + 1)))
    if fmt == "png" and max(size) * DPI > MAX_PNG_PIXELS:
        most_leaves = int(MAX_PNG_PIXELS / DPI / INCHES_PER_LEAF)
        most_depth = int(MAX_PNG_PIXELS / DPI / INCHES_PER_LEVEL) - 1
        raise TreeLimitError(
            f"tree has {leaves} leaves and depth {depth}; a PNG drawing takes at most {most_leaves} "
            f"leaves and depth {most_depth} (draw it as svg, or use text, xml or dot)"
        )
    from matplotlib.figure import Figure  # not pyplot: no half-second import, no figure kept until closed
    from matplotlib.patches import FancyBboxPatch

    figure = Figure(figsize=size)
    width, height = leaves, depth + 1
    axes = figure.add_axes((0, 0, 1, 1))
    axes.set_xlim(-0.6, width - 0.4)
    axes.set_ylim(-height + 0.4, 0.6)
    axes.axis("off")
    for _, x, level, parent in placed:
        if parent is not None:
            _, px, parent_level, _ = placed[parent]
            axes.plot(
                [px, x], [-parent_level - 0.18, -level + 0.18], color="#555555", linewidth=0.8, zorder=1
            )
    for node, x, level, _ in placed:
        label, fill, style = _style(node, named(node))  # a primitive's copy, named, is one box
        axes.add_patch(
            FancyBboxPatch(
                (x - 0.45, -level - 0.18),
                0.9,
                0.36,
                boxstyle=style,
                facecolor=fill,
                edgecolor="#333333",
                linewidth=0.8,
                zorder=2,
            )
        )
        axes.text(x, -level, label, ha="center", va="center", fontsize=8, zorder=3)
    return _save(figure, path, fmt)


def _save(figure: Figure, path: Path, fmt: str) -> Path:
    import matplotlib  # late: the tools' face loads this module; matplotlib (about 1 s) only for a picture

    # no date and a fixed salt for the SVG's element ids: the same tree gives the same bytes
    with matplotlib.rc_context({"svg.hashsalt": "bt_controller.tools.render"}):
        metadata = {"Date": None} if fmt == "svg" else None

        def save(temporary: Path) -> None:  # beside ``path``, then renamed; a link at ``path`` is refused
            figure.savefig(temporary, format=fmt, dpi=DPI, metadata=metadata)

        replace_file(path, save)
    return path


def _render_outline(
    placed: list[tuple[Node, float, int, int | None]],
    named: Callable[[Node], str | None],
    path: Path,
    fmt: str,
) -> Path:
    """The vertical layout: row ``k`` holds the ``k``-th node of ``placed`` (pre-order), indented by its
    depth; axes in inches."""
    # late: as in _save, matplotlib loads only when a picture is drawn
    from matplotlib.figure import Figure
    from matplotlib.patches import FancyBboxPatch

    styled = [  # a row's box is lower than the top-down layout's: its conditions' ends less round
        (label, fill, style.replace("rounding_size=0.18", "rounding_size=0.09"))
        for label, fill, style in (_style(node, named(node)) for node, _, _, _ in placed)
    ]
    widths = [CHARACTER_INCHES * len(label) + 0.22 for label, _, _ in styled]
    right = max(INDENT_INCHES * depth + width for (_, _, depth, _), width in zip(placed, widths, strict=True))
    size = (right + 0.2, ROW_INCHES * len(placed) + 0.1)
    if fmt == "png" and max(size) * DPI > MAX_PNG_PIXELS:
        raise TreeLimitError(
            f"tree has {len(placed)} nodes; a vertical PNG drawing takes at most "
            f"{int((MAX_PNG_PIXELS / DPI - 0.1) / ROW_INCHES)} (draw it as svg, or use text, xml or dot)"
        )
    figure = Figure(figsize=size)
    axes = figure.add_axes((0, 0, 1, 1))
    axes.set_xlim(-0.1, size[0] - 0.1)
    axes.set_ylim(-size[1] + 0.05, 0.05)
    axes.axis("off")
    half = 0.1  # half a box's height

    def row(k: int) -> float:
        return -ROW_INCHES * (k + 0.5)

    for k, (_, _, depth, parent) in enumerate(placed):
        if parent is not None:
            elbow = INDENT_INCHES * placed[parent][2] + INDENT_INCHES / 2
            axes.plot(
                [elbow, elbow, INDENT_INCHES * depth],
                [row(parent) - half, row(k), row(k)],
                color="#555555",
                linewidth=0.8,
                zorder=1,
            )
    for k, ((_, _, depth, _), (label, fill, style), width) in enumerate(
        zip(placed, styled, widths, strict=True)
    ):
        x = INDENT_INCHES * depth
        axes.add_patch(
            FancyBboxPatch(
                (x, row(k) - half),
                width,
                2 * half,
                boxstyle=style,
                facecolor=fill,
                edgecolor="#333333",
                linewidth=0.8,
                zorder=2,
            )
        )
        axes.text(x + 0.08, row(k), label, ha="left", va="center", fontsize=8, zorder=3)
    return _save(figure, path, fmt)
