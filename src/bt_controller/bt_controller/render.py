"""Draw a tree to SVG or PNG with matplotlib (no Graphviz needed): a tidy top-down layout.

Leaves sit at consecutive x positions in pre-order; a composite is centred over its children; depth goes
down. Colours follow ``formats.to_dot``: sequence blue, selector orange, probabilistic green, conditions
white ellipses ending in '?', actions grey boxes.
"""

from __future__ import annotations

from pathlib import Path

from bt_controller.tree import Composite, Condition, Node, leaf_name

RENDER_FORMATS = ("svg", "png")
_FILL = {"seq": "#cfe2f3", "sel": "#fce5cd", "prob": "#d9ead3"}
_LABEL = {"seq": "seq →", "sel": "sel ?", "prob": "prob %"}


def layout(tree: Node) -> list[tuple[Node, float, int, int | None]]:
    """``(node, x, depth, parent index)`` for every node in pre-order."""
    placed: list[tuple[Node, float, int, int | None]] = []
    next_leaf = 0.0

    def place(node: Node, depth: int, parent: int | None) -> float:
        nonlocal next_leaf
        index = len(placed)
        placed.append((node, 0.0, depth, parent))
        if isinstance(node, Composite):
            xs = [place(child, depth + 1, index) for child in node.children]
            x = (xs[0] + xs[-1]) / 2
        else:
            x = next_leaf
            next_leaf += 1.0
        placed[index] = (node, x, depth, parent)
        return x

    place(tree, 0, None)
    return placed


def render(tree: Node, path: str | Path, fmt: str | None = None) -> Path:
    """Draw ``tree`` into ``path`` as SVG or PNG (``fmt`` defaults to the file suffix); returns the path."""
    path = Path(path)
    fmt = (fmt or path.suffix.lstrip(".")).lower()
    if fmt not in RENDER_FORMATS:
        raise ValueError(f"can render {' or '.join(RENDER_FORMATS)}, not {fmt!r}")
    import matplotlib

    matplotlib.use("Agg")
    from matplotlib import pyplot as plt
    from matplotlib.patches import FancyBboxPatch

    placed = layout(tree)
    width = max(x for _, x, _, _ in placed) + 1
    height = max(d for _, _, d, _ in placed) + 1
    figure = plt.figure(figsize=(max(2.0, 1.35 * width), max(1.2, 0.9 * height)))
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
            label, fill, style = _LABEL[node.kind], _FILL[node.kind], "round,pad=0.02"
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
    figure.savefig(path, format=fmt, dpi=120)
    plt.close(figure)
    return path
