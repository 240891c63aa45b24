"""Where the nest and the food are: a trial's regions as pieces of the ground, and how trials go through them.

A **piece** is one shape on the ground of one region kind: a disc (the points closer than its radius to its
centre), the points beyond a circle (the 2023 food region: everything at least its radius from its centre), or
a half-plane (``above``: y >= radius; ``below``: y <= -radius). A region kind with several pieces is their
union, and a robot's distance from it is its distance from the nearest piece (0 inside). An **arena entry** is
the pieces of one trial. A **layout** gives the entries trials go through: one row per arena configuration
(trials come in blocks of ``chain_trials`` and the blocks cycle through the rows, as the 2023 gaps do), and in
each row the entries the trials of a block take in turn (the 2026 arenas 5-9: trial k of a run uses entry k).

The 2023 arena is the layout ``concentric(nest_radius, gaps)``: a nest disc at the centre and, per
configuration, food beyond the circle of radius nest_radius + gap. Compiled code reads a layout as the array
``layout_table`` makes. Units: millimetres; the arena's centre is the origin.
"""

from __future__ import annotations

import json
import math
from collections.abc import Iterable, Sequence
from typing import NamedTuple

import numpy as np

from bt_controller.language import REGIONS
from swarm_sim.errors import ConfigError

REGION_KINDS: tuple[str, ...] = REGIONS
"""The kinds of region, in the order compiled code numbers them (a piece's kind column): the nest and the
food kinds 1-3 (``food``, ``food2``, ``food3``; ``bt_controller.language.vocabulary.REGIONS``)."""

PIECE_SHAPES: tuple[str, ...] = ("disc", "beyond", "above", "below")
"""The shapes of a piece, in the order compiled code numbers them (a piece's shape column)."""

PIECE_FIELDS = 5
"""Columns of a piece in ``layout_table``: kind, shape, centre x, centre y, radius (-1 as kind: no piece)."""


class Piece(NamedTuple):
    """One shape of one region kind on the ground (the module's docstring)."""

    kind: str
    """A kind of ``REGION_KINDS``."""
    shape: str
    """A shape of ``PIECE_SHAPES``."""
    x: float
    """The centre's x (mm; 0 for a half-plane)."""
    y: float
    """The centre's y (mm; 0 for a half-plane)."""
    radius: float
    """The circle's radius, or a half-plane's distance from the x axis (mm)."""

    def distance(self, px: float, py: float) -> float:
        """The distance of point (px, py) from this piece: 0 inside (the compiled ``world.region_distance``
        reads the same formulas)."""
        if self.shape in ("disc", "beyond"):
            dx, dy = px - self.x, py - self.y
            r = math.sqrt(dx * dx + dy * dy)
            return max(0.0, r - self.radius) if self.shape == "disc" else max(0.0, self.radius - r)
        return max(0.0, self.radius - py) if self.shape == "above" else max(0.0, py + self.radius)


def label_point(piece: Piece) -> tuple[float, float]:
    """Where a drawing labels ``piece`` (mm): a disc's centre, below a circle's rim, or inside a half-plane
    near its edge."""
    if piece.shape == "disc":
        return piece.x, piece.y
    if piece.shape == "beyond":
        return piece.x, piece.y - piece.radius - 150.0
    return 0.0, piece.radius + 150.0 if piece.shape == "above" else -piece.radius - 150.0


ArenaEntry = tuple[Piece, ...]
"""The regions of one trial."""

Layout = tuple[tuple[ArenaEntry, ...], ...]
"""Per arena configuration, the entries its block's trials take in turn."""


def concentric(nest_radius: float, gaps: Sequence[float]) -> Layout:
    """The 2023 arena: a nest disc of ``nest_radius`` at the centre and food beyond nest_radius + gap, one
    configuration per gap."""
    return tuple(
        (
            (
                Piece("nest", "disc", 0.0, 0.0, nest_radius),
                Piece("food", "beyond", 0.0, 0.0, nest_radius + gap),
            ),
        )
        for gap in gaps
    )


def concentric_food_disc(nest_radius: float, gaps: Sequence[float], radius: float) -> Layout:
    """The 2023 arena with a smaller food region (the ``food-disc`` condition): per gap, a food disc of
    ``radius`` on the x axis whose near edge is where ``concentric``'s food circle is."""
    return tuple(
        (
            (
                Piece("nest", "disc", 0.0, 0.0, nest_radius),
                Piece("food", "disc", nest_radius + gap + radius, 0.0, radius),
            ),
        )
        for gap in gaps
    )


def entry_of_trial(layout: Layout, trial: int, chain_trials: int) -> ArenaEntry:
    """The entry of trial ``trial`` of an evaluation: trials come in blocks of ``chain_trials``, the blocks
    cycle through the layout's configurations, and trial k of a block takes its configuration's entry k
    (cycling)."""
    row = layout[(trial // chain_trials) % len(layout)]
    return row[(trial % chain_trials) % len(row)]


def distance(entry: ArenaEntry, kind: str, x: float, y: float) -> float:
    """The distance of (x, y) from region ``kind`` of ``entry`` (its nearest piece), inf if it has none."""
    return min((piece.distance(x, y) for piece in entry if piece.kind == kind), default=math.inf)


def nest_point(entry: ArenaEntry) -> tuple[float, float]:
    """The nest's reference point: the centre of its first disc, or the point of its first half-plane on the y
    axis. The inverse food objective measures food distances in units of this point's food distance."""
    for piece in entry:
        if piece.kind == "nest" and piece.shape == "disc":
            return piece.x, piece.y
        if piece.kind == "nest" and piece.shape in ("above", "below"):
            return 0.0, piece.radius if piece.shape == "above" else -piece.radius
    raise ConfigError("an arena entry needs a nest disc or half-plane for the nest's reference point")


def food_scale(entry: ArenaEntry) -> float:
    """The food distance of the nest's reference point: the unit of the inverse food objective (the 2023
    arena's nest_radius + gap)."""
    return distance(entry, "food", *nest_point(entry))


def kinds_needed(kinds: Iterable[str]) -> tuple[str, ...]:
    """The region kinds a world of regions of ``kinds`` must have: the nest and every food kind up to the
    highest among them (at least kind 1); unknown kinds are left to the checks that name them."""
    known = [REGION_KINDS.index(kind) for kind in kinds if kind in REGION_KINDS]
    return REGION_KINDS[: 1 + max([1, *known])]


def food_kinds(layout: Layout) -> int:
    """How many kinds of food ``layout`` has: its highest food kind (1 for the papers' arena, no layout)."""
    return len(kinds_needed(p.kind for row in layout for e in row for p in e)) - 1


def check_layout(layout: Layout, arena_half: float, key: str = "layout") -> None:
    """Raise ``ConfigError`` naming the first piece of ``layout`` that cannot be run: an unknown kind or
    shape, a radius that is not a positive finite number, a centre outside the arena, an entry without a
    nest or without one of the layout's food kinds, or a nest that overlaps food."""
    if not layout or any(not row for row in layout):
        raise ConfigError(f"{key} must hold at least one arena entry per configuration, got {layout!r}")
    kinds = kinds_needed(p.kind for row in layout for e in row for p in e)
    for c, row in enumerate(layout):
        for k, entry in enumerate(row):
            where = f"{key}: arena entry {c * len(row) + k}"
            for m, piece in enumerate(entry):
                at = f"{where}, piece {m}:"
                if piece.kind not in REGION_KINDS:
                    raise ConfigError(
                        f"{at} kind must be one of {', '.join(REGION_KINDS)}, got {piece.kind!r}"
                    )
                if piece.shape not in PIECE_SHAPES:
                    raise ConfigError(
                        f"{at} shape must be one of {', '.join(PIECE_SHAPES)}, got {piece.shape!r}"
                    )
                for name in ("x", "y", "radius"):
                    value = getattr(piece, name)
                    if (
                        isinstance(value, bool)
                        or not isinstance(value, int | float)
                        or not math.isfinite(value)
                    ):
                        raise ConfigError(f"{at} {name} must be a finite number, got {value!r}")
                if piece.radius <= 0 and piece.shape in ("disc", "beyond"):
                    raise ConfigError(f"{at} radius must be positive for a {piece.shape}, got {piece.radius}")
                if max(abs(piece.x), abs(piece.y)) >= arena_half or abs(piece.radius) >= arena_half:
                    raise ConfigError(
                        f"{at} the region lies outside the arena (centre ({piece.x:g}, {piece.y:g}), radius "
                        f"{piece.radius:g}, arena half size {arena_half:g}): expected within +-{arena_half:g}"
                    )
            for kind in kinds:
                if not any(piece.kind == kind for piece in entry):
                    raise ConfigError(
                        f"{where} has no {kind} piece; every arena entry needs the nest and each food kind "
                        f"of the layout ({', '.join(kinds)})"
                    )
            nest_x, nest_y = nest_point(entry)
            if distance(entry, "food", nest_x, nest_y) <= 0.0:
                raise ConfigError(
                    f"{where}: the nest's reference point ({nest_x:g}, {nest_y:g}) lies on food"
                )


def layout_table(layout: Layout) -> tuple[np.ndarray, np.ndarray]:
    """``layout`` as compiled code reads it: pieces (configurations x entries x pieces x ``PIECE_FIELDS``;
    rows cycle, so a configuration with fewer entries repeats them, and unused piece rows have kind -1) and
    each entry's ``food_scale`` (configurations x entries)."""
    entries = max(len(row) for row in layout)
    pieces = max(len(entry) for row in layout for entry in row)
    table = np.full((len(layout), entries, pieces, PIECE_FIELDS), -1.0)
    scale = np.zeros((len(layout), entries))
    for c, row in enumerate(layout):
        for k in range(entries):
            entry = row[k % len(row)]
            for m, piece in enumerate(entry):
                table[c, k, m] = (
                    REGION_KINDS.index(piece.kind),
                    PIECE_SHAPES.index(piece.shape),
                    piece.x,
                    piece.y,
                    piece.radius,
                )
            scale[c, k] = food_scale(entry)
    return table, scale


def layout_as_json(layout: Layout) -> list[list[list[dict[str, object]]]]:
    """``layout`` as JSON-ready lists of piece objects."""
    return [[[piece._asdict() for piece in entry] for entry in row] for row in layout]


def _is_number(value: object) -> bool:
    return isinstance(value, int | float) and not isinstance(value, bool)


def layout_to_text(layout: Layout) -> str:
    """``layout`` as one line of JSON (a ROS parameter's text); "" for the papers' arena (no layout)."""
    return json.dumps(layout_as_json(layout), separators=(",", ":")) if layout else ""


def layout_from_text(text: str, key: str = "layout") -> Layout:
    """The layout ``layout_to_text`` wrote ("" gives none); ``ConfigError`` naming what is malformed."""
    if not text.strip():
        return ()
    try:
        data = json.loads(text)
    except json.JSONDecodeError as error:
        raise ConfigError(
            f"{key} must be JSON (regions.layout_as_json), got {text[:60]!r}: {error.msg}"
        ) from None
    return layout_from_json(data, key)


def layout_from_json(data: object, key: str = "layout") -> Layout:
    """The layout ``layout_as_json`` wrote; ``ConfigError`` naming the first malformed part."""
    if not isinstance(data, list):
        raise ConfigError(f"{key} must be a list of configurations, got {data!r}")
    rows = []
    for c, row in enumerate(data):
        if not isinstance(row, list):
            raise ConfigError(f"{key}[{c}] must be a list of arena entries, got {row!r}")
        entries = []
        for k, entry in enumerate(row):
            if not isinstance(entry, list):
                raise ConfigError(f"{key}[{c}][{k}] must be a list of pieces, got {entry!r}")
            pieces = []
            for m, piece in enumerate(entry):
                if not isinstance(piece, dict) or set(piece) != set(Piece._fields):
                    raise ConfigError(
                        f"{key}[{c}][{k}][{m}] must be an object with keys {', '.join(Piece._fields)}, "
                        f"got {piece!r}"
                    )
                kind, shape, x, y, radius = (piece[name] for name in Piece._fields)
                numbers = [float(v) for v in (x, y, radius) if _is_number(v)]
                if not (isinstance(kind, str) and isinstance(shape, str) and len(numbers) == 3):
                    raise ConfigError(
                        f"{key}[{c}][{k}][{m}] must have a text kind and shape and numbers, got {piece!r}"
                    )
                pieces.append(Piece(kind, shape, *numbers))
            entries.append(tuple(pieces))
        rows.append(tuple(entries))
    return tuple(rows)
