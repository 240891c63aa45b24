"""Draw one step of a trial bag as a viewer's top-down 3D panel would show it: ``ws/run evolution_manager
snapshot BAG [--step N] --out PNG``.

It reads only the bag's standard visualisation messages (``markers``, ``robot_markers``:
``visualization_msgs/MarkerArray`` in frame ``arena``, metres), so the picture shows what RViz2 or Foxglove
show from the same bag; it is no viewer, and not a replacement for one (``docs/visualisation.md``).
"""

from __future__ import annotations

import sys
from collections.abc import Sequence
from pathlib import Path
from typing import Any

from evolution_manager.arguments import OneLineParser
from evolution_manager.recording.bags import BagError, check_crcs, read_bag
from swarm_ros.safe_paths import check_output, describe, replace_file

# visualization_msgs/Marker types drawn here
ARROW, CYLINDER, LINE_STRIP, TRIANGLE_LIST, TEXT_VIEW_FACING = 0, 3, 4, 11, 9


def scene(bag: Path, step: int) -> tuple[list, list, int]:
    """The arena's markers and the robots' markers at sensing step ``step`` (-1: the last), and that step."""
    arena, robots = [], []
    check_crcs(bag)  # a changed byte is refused, never drawn
    for message in read_bag(bag):
        name = message.topic.rsplit("/", 1)[-1]
        if name == "markers":
            arena = list(message.message.markers)
        elif name == "robot_markers":
            robots.append(list(message.message.markers))
    if not arena or not robots:
        raise BagError(f"{bag} has no markers and robot_markers topics: record it with `trial --bag`")
    if not -len(robots) <= step < len(robots):
        raise BagError(f"--step must be in 0..{len(robots) - 1} (or -1 for the last), got {step}")
    return arena, robots[step], step % len(robots)


def draw(arena: list, robots: list, title: str, out: Path) -> None:
    """Draw the markers top-down (x right, y up, metres) to ``out``."""
    # matplotlib (about 1.5 s to import) loads only when figures are drawn
    from matplotlib.patches import Circle, FancyArrow, Polygon

    # (figures loads matplotlib too)
    from evolution_manager.viewing.figures import subplots

    def colour(m: Any) -> tuple[float, float, float, float]:  # a Marker as rosbags reads it (untyped)
        c = m.color
        return (c.r, c.g, c.b, c.a)

    figure, axes = subplots(figsize=(8, 8))
    for m in [*arena, *robots]:
        x, y = m.pose.position.x, m.pose.position.y
        if m.type == TRIANGLE_LIST:
            points = [(p.x, p.y) for p in m.points]
            for k in range(0, len(points) - 2, 3):
                axes.add_patch(Polygon(points[k : k + 3], closed=True, color=colour(m), linewidth=0))
        elif m.type == LINE_STRIP:
            axes.plot([p.x for p in m.points], [p.y for p in m.points], color=colour(m), linewidth=2)
        elif m.type == CYLINDER:
            axes.add_patch(Circle((x, y), m.scale.x / 2, color=colour(m), zorder=3))
        elif m.type == ARROW:
            q = m.pose.orientation
            cos, sin = 1 - 2 * q.z * q.z, 2 * q.w * q.z  # yaw of a rotation about z
            axes.add_patch(
                FancyArrow(x, y, cos * m.scale.x, sin * m.scale.x, width=0.015, color="k", zorder=4)
            )
        elif m.type == TEXT_VIEW_FACING:
            axes.text(x, y + (0.12 if m.ns == "labels" else 0), m.text, ha="center", fontsize=7, zorder=5)
    half = max(abs(p.x) for m in arena if m.type == LINE_STRIP for p in m.points)
    axes.set_xlim(-half - 0.1, half + 0.1)
    axes.set_ylim(-half - 0.1, half + 0.1)
    axes.set_aspect("equal")
    axes.set_xlabel("x (m), frame arena")
    axes.set_ylabel("y (m)")
    axes.set_title(title)
    out.parent.mkdir(parents=True, exist_ok=True)
    fmt = out.suffix.lstrip(".").lower() or "png"  # written beside ``out``, then renamed over it
    replace_file(out, lambda temporary: figure.savefig(temporary, format=fmt, dpi=110, bbox_inches="tight"))


def check_format(out: Path) -> str:
    """The picture format of ``out`` (its suffix; PNG without one); ``ValueError`` naming the formats
    matplotlib writes for another, before the bag is read."""
    # matplotlib (about 1.5 s to import) loads only when figures are drawn
    from matplotlib.backend_bases import FigureCanvasBase

    fmt = out.suffix.lstrip(".").lower() or "png"
    formats = FigureCanvasBase.get_supported_filetypes()
    if fmt not in formats:
        raise ValueError(f"Format {fmt!r} is not supported (supported formats: {', '.join(sorted(formats))})")
    return fmt


def main(argv: Sequence[str] | None = None) -> int:
    """``snapshot``: one step of a trial bag as a top-down picture."""
    parser = OneLineParser(prog="snapshot", description=__doc__.split("\n\n")[0])
    parser.add_argument("bag", type=Path, help="a trial bag (trial --bag)")
    parser.add_argument("--step", type=int, default=-1, help="sensing step to draw (default -1: the last)")
    parser.add_argument("--out", type=Path, required=True, help="the PNG file to write (new, unless --force)")
    parser.add_argument("--force", action="store_true", help="overwrite an --out that exists")
    args = parser.parse_args(sys.argv[1:] if argv is None else argv)
    try:
        check_output(args.out, args.force)  # a link, a folder, a file there: refused before the bag is read
        check_format(args.out)
        arena, robots, step = scene(args.bag, args.step)
        draw(arena, robots, f"{args.bag.name}: step {step}", args.out)
    except BagError as error:
        print(f"snapshot: {error}", file=sys.stderr)
        return 2
    except OSError as error:  # a read-only or full place, a link, an output that exists
        print(f"snapshot: {describe(args.out, error)}", file=sys.stderr)
        return 2
    except ValueError as error:  # a suffix matplotlib cannot write
        print(f"snapshot: --out {args.out}: {error}", file=sys.stderr)
        return 2
    print(f"snapshot: wrote {args.out}", file=sys.stderr)
    return 0
