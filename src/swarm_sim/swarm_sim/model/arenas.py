"""The arena layouts 1-9 of the authors' 2026 code (commit 1cd2358) as plain data: regions made of pieces.

The authors' code at 1cd2358 defines them; the facts here
were read from their ``arena.py`` (the seeded generator of layouts 6-9), their loop functions (BLF,
``bt_loop_functions.cpp``: builds and reorders the arenas) and their controller (FB, ``footbot_bt.cpp``:
measures a robot's distance to each region). Units are millimetres
with the arena's centre at the origin; their files and code use metres, converted here once, at the edge.

An arena entry is one trial's regions (``swarm_sim.model.regions``): pieces, each of one kind (``nest``, and
``food``, ``food2``, ``food3`` for their food kinds 1-3). A kind made of several pieces is their union, and
the distance from it is from its nearest piece (``regions.distance``, in float64 throughout). Theirs
(``calculateDistancesExpN``, FB:150-370) squares the centre offsets of layouts 5-9 in float32
(``hypotenuseSquared``, FB:372-377), rounds layout 9's food distances to float32 (FB:360-361) and, in
layouts 8 and 9, starts the nearest-piece search at 5 m (FB:281, 291, 357), so their distances saturate at
5000 mm; their gap and radii settings are float32 too (``std::stof``, BLF:308-313, 393: a gap of 0.7 m is
0.699999988 m there). ``arena_entries`` gives a layout's entries in
trial order (trial k uses entry k, as their loop functions do); ``scatter_points`` reproduces their
generator bit for bit; ``pieces_from_points`` turns one arena's listed points (a task file's data) into its
pieces.

Every bad setting raises ``ConfigError`` with one line naming the setting, the value and what was expected.
"""

from __future__ import annotations

import math
import random
from collections.abc import Sequence

import numpy as np

from swarm_sim.errors import ConfigError
from swarm_sim.model.regions import ArenaEntry, Piece

FOOD_KINDS = ("food", "food2", "food3")
"""Their food kinds 1-3 as region kinds: ``food`` is kind 1 (their unnumbered conditions read it)."""

LAYOUTS = tuple(range(1, 10))
"""The arena layouts of their code."""

GENERATED_LAYOUTS = (6, 7, 8, 9)
"""The layouts whose points come from the seeded generator (their ``arena<N>.txt`` files)."""

HARNESS_POINTS = {6: 4, 7: 2, 8: 6, 9: 6}
"""Points per generated arena as the reference harness made their files (``rebuild_2026.sh``)."""

LAYOUT5_PERMUTATIONS = ((1, 2, 3), (1, 3, 2), (2, 1, 3), (2, 3, 1), (3, 1, 2))
"""Layout 5: which corner (1: (+g, -g), 2: (-g, -g), 3: (+g, +g)) holds food kinds 1, 2, 3 in trial k. Their
loop functions list a sixth, (3, 2, 1), which their five trials never reach (BLF:147-165)."""

NEST_SEARCH_LIMIT_M = 5.0
"""Layout 9: their search for the point nearest the nest starts at this edge-to-edge distance (m, BLF:224)."""


# -- the generator of layouts 6-9 (their arena.py) -------------------------------------------------------


def _generator_settings(points: int) -> tuple[float, float, float]:
    """(spawn_range, min_radius_sq, minimum_gap) in m, m^2, m for ``points`` points (arena.py:16-27)."""
    if points < 4:
        return 2.5, 1.5, 0.2
    if points < 6:
        return 3.0, 1.5, 0.2
    return 4.0, 1.0, 0.1


def _scatter_points_m(index: int, points: int) -> list[tuple[float, float, float]]:
    """Arena ``index`` of their generator in metres, the same draws in the same order; fewer than ``points``
    points when one could not be placed (their script then stops writing arenas)."""
    spawn_range, min_sq, min_gap = _generator_settings(points)
    rng = random.Random(index)

    def draw() -> tuple[float, float]:
        x = rng.random() * spawn_range - spawn_range / 2
        y = rng.random() * spawn_range - spawn_range / 2
        return x, y

    def too_close(x: float, y: float, placed: list[tuple[float, float]]) -> bool:
        # Their order of operations: (x_k - x) squared plus (y_k - y) squared, compared strictly.
        return any((px - x) * (px - x) + (py - y) * (py - y) < min_sq for px, py in placed)

    placed: list[tuple[float, float]] = []
    for _ in range(points):
        # Up to 20 checks; a failed check draws a new candidate, even after the last one (never checked).
        x, y = draw()
        valid = False
        for _check in range(20):
            valid = not too_close(x, y, placed)
            if valid:
                break
            x, y = draw()
        if valid:
            placed.append((x, y))

    def centre_distance(i: int, j: int) -> float:
        (xi, yi), (xj, yj) = placed[i], placed[j]
        return math.sqrt((xj - xi) * (xj - xi) + (yj - yi) * (yj - yi))

    n = len(placed)
    # First pass: half the distance to another point, taken only when it undercuts the radius so far by more
    # than minimum_gap; at most 1 m.
    radii = [1.0] * n
    for i in range(n):
        radius = 5.0
        for j in range(n):
            if i != j:
                half = centre_distance(i, j) / 2
                if half + min_gap < radius:
                    radius = half
        radii[i] = min(radius, 1.0)
    # Second pass, in place (a point sees the new radii of the points before it): leave minimum_gap to every
    # other disc; at most 1 m.
    for i in range(n):
        radius = 5.0
        for j in range(n):
            if i != j:
                remainder = (centre_distance(i, j) - radii[j]) - min_gap
                if remainder < radius:
                    radius = remainder
        radii[i] = min(radius, 1.0)
    return [(x, y, r) for (x, y), r in zip(placed, radii, strict=True)]


def scatter_points(index: int, points: int) -> list[tuple[float, float, float]]:
    """Arena ``index`` (0-based) of the authors' generator of random arenas: (x, y, r) in mm per point.

    Seeded with ``random.Random(index)`` and drawn as their ``arena.py`` draws, so the points and radii equal
    their file's (which holds every float at full precision) times 1000. Fewer than ``points`` points means
    the generator could not place one; ``arena_entries`` refuses that.
    """
    _check_count("points", points, 1)
    _check_count("arena index", index, 0)
    return [_in_mm(p) for p in _scatter_points_m(index, points)]


def _in_mm(point_m: tuple[float, float, float]) -> tuple[float, float, float]:
    x, y, r = point_m
    return x * 1000.0, y * 1000.0, r * 1000.0


# -- layouts ---------------------------------------------------------------------------------------------


def _check_count(name: str, value: object, least: int) -> None:
    if isinstance(value, bool) or not isinstance(value, int) or value < least:
        raise ConfigError(f"{name} must be an integer of at least {least}, got {value!r}")


def _check_length(name: str, value: object) -> float:
    if (
        isinstance(value, bool)
        or not isinstance(value, int | float)
        or not math.isfinite(value)
        or value <= 0
    ):
        raise ConfigError(f"{name} must be a positive number of mm, got {value!r}")
    return float(value)


def _check_layout(layout: object, bias: object) -> None:
    if isinstance(layout, bool) or not isinstance(layout, int) or layout not in LAYOUTS:
        raise ConfigError(f"arena layout must be one of 1-9, got {layout!r}")
    if layout == 9:
        if bias is None:
            raise ConfigError("arena layout 9 needs a bias (the preferred food kind, 0-based 0-2), got none")
        if isinstance(bias, bool) or bias not in (0, 1, 2):
            raise ConfigError(
                f"arena bias must be 0, 1 or 2 (the preferred food kind, 0-based), got {bias!r}"
            )
    elif bias is not None:
        raise ConfigError(f"arena bias applies only to layout 9, got bias {bias!r} for layout {layout}")


def arena_entries(
    layout: int,
    *,
    nest_radius: float = 500.0,
    food_radius: float = 500.0,
    gap: float = 500.0,
    bias: int | None = None,
    points: int | None = None,
    arenas: int = 10,
) -> tuple[ArenaEntry, ...]:
    """The entries of arena ``layout`` (1-9) in trial order, trial k using entry k.

    Layouts 1-4 have one entry (every trial); layout 5 has five, the corner permutations of its trials, which
    depend on ``gap``; layouts 6-9 have one per generated arena (``arenas`` of them, generated with
    ``points`` points each, by default as the reference harness did: ``HARNESS_POINTS``), which do not
    depend on ``gap`` or the radii. Layout 9 needs ``bias`` (the preferred food kind, 0-based 0-2).
    """
    _check_layout(layout, bias)
    nest_radius = _check_length("nest_radius", nest_radius)
    food_radius = _check_length("food_radius", food_radius)
    gap = _check_length("gap", gap)
    if layout not in GENERATED_LAYOUTS:
        if points is not None:
            raise ConfigError(
                f"points apply only to the generated layouts 6-9, got points {points!r} for layout {layout}"
            )
        return _fixed_entries(layout, nest_radius, food_radius, gap)
    _check_count("arenas", arenas, 1)
    if points is None:
        points = HARNESS_POINTS[layout]
    _check_points(layout, points)
    entries = []
    for index in range(arenas):
        listed = _scatter_points_m(index, points)
        if len(listed) < points:
            raise ConfigError(
                f"points {points} for layout {layout}: the generator places only {len(listed)} in arena "
                f"{index}; expected a count it can place in every arena"
            )
        entries.append(_pieces(layout, [_in_mm(p) for p in listed], listed, bias))
    return tuple(entries)


def _check_points(layout: int, points: object) -> None:
    """Layouts 6, 7 and 9 use a fixed number of points; layout 8 at least one nest and one food point."""
    fixed = {6: 4, 7: 2, 9: 6}
    if layout in fixed and points != fixed[layout]:
        raise ConfigError(f"points for layout {layout} must be {fixed[layout]}, got {points!r}")
    _check_count(f"points for layout {layout}", points, 2)


def _fixed_entries(layout: int, nest_radius: float, food_radius: float, gap: float) -> tuple[ArenaEntry, ...]:
    if layout == 1:
        # Their food edge is 0.5 m + gap from the centre whatever the nest radius (FB:155).
        return (
            (Piece("nest", "disc", 0.0, 0.0, nest_radius), Piece("food", "beyond", 0.0, 0.0, 500.0 + gap)),
        )
    if layout == 2:
        # Their seed file's offset for layout 2: (nest + food + gap) / 2, so the edges are gap apart.
        offset = (nest_radius + food_radius + gap) / 2
        return (
            (
                Piece("nest", "disc", 0.0, offset, nest_radius),
                Piece("food", "disc", 0.0, -offset, food_radius),
            ),
        )
    if layout == 3:
        # Their offset for layout 3 is sqrt((nest + food + gap)^2 / 2); the food centres lie that plus both
        # radii from the origin (FB:172-181), so the edge-to-edge gap is (nest + food + gap) / sqrt(2).
        total = nest_radius + food_radius + gap
        d = math.sqrt(total * total / 2) + food_radius + nest_radius
        centres = ((0.0, d), (0.0, -d), (-d, 0.0), (d, 0.0))
        return (
            (
                Piece("nest", "disc", 0.0, 0.0, nest_radius),
                *(Piece("food", "disc", *c, food_radius) for c in centres),
            ),
        )
    if layout == 4:
        return ((Piece("nest", "above", 0.0, 0.0, gap / 2), Piece("food", "below", 0.0, 0.0, gap / 2)),)
    # layout 5
    if nest_radius != food_radius:
        raise ConfigError(
            f"layout 5 needs equal radii, got nest_radius {nest_radius:g} and food_radius {food_radius:g}"
        )
    g = gap / 2 + food_radius
    corners = {1: (g, -g), 2: (-g, -g), 3: (g, g)}
    nest = Piece("nest", "disc", -g, g, nest_radius)
    return tuple(
        (nest, *(Piece(FOOD_KINDS[k], "disc", *corners[c], food_radius) for k, c in enumerate(permutation)))
        for permutation in LAYOUT5_PERMUTATIONS
    )


# -- points to pieces (layouts 6-9) ------------------------------------------------------------------------


def pieces_from_points(
    layout: int, points_mm: Sequence[tuple[float, float, float]], bias: int | None = None
) -> ArenaEntry:
    """The pieces of one arena of layout 6-9 from its listed points (x, y, r) in mm, in the order of their
    arena file (layout 9's nearest point is moved into slot 1 here, as their loop functions do on reading)."""
    _check_layout(layout, bias)
    if layout not in GENERATED_LAYOUTS:
        raise ConfigError(f"points make an arena only for layouts 6-9, got layout {layout}")
    listed = []
    for k, point in enumerate(points_mm):
        if len(point) != 3:
            raise ConfigError(f"arena point {k} must be (x, y, r) in mm, got {point!r}")
        x, y, r = (float(v) for v in point)
        if not (math.isfinite(x) and math.isfinite(y) and math.isfinite(r)) or r <= 0:
            raise ConfigError(f"arena point {k} must be finite with a positive radius (mm), got {point!r}")
        listed.append((x, y, r))
    _check_points(layout, len(listed))
    return _pieces(layout, listed, [(x / 1000.0, y / 1000.0, r / 1000.0) for x, y, r in listed], bias)


def _pieces(
    layout: int,
    listed_mm: list[tuple[float, float, float]],
    listed_m: list[tuple[float, float, float]],
    bias: int | None,
) -> ArenaEntry:
    """One arena's pieces from its points in mm; ``listed_m`` (the same in metres, their units) only decides
    layout 9's swap, so that generated arenas swap exactly as their loop functions do."""

    def piece(kind: str, point: tuple[float, float, float]) -> Piece:
        x, y, r = point
        return Piece(kind, "disc", x, y, r)

    if layout == 6:
        return tuple(piece(kind, p) for kind, p in zip(("nest", *FOOD_KINDS), listed_mm, strict=True))
    if layout == 7:
        # Their "target" (point 0) and "other" (point 1); robot type 1 of the generic projects swaps them.
        return (piece("nest", listed_mm[0]), piece("food", listed_mm[1]))
    if layout == 8:
        return tuple(piece("nest" if k % 2 == 0 else "food", p) for k, p in enumerate(listed_mm))
    # layout 9: the nearest point into slot 1; slots 1-3 the preferred kind, slots 4 and 5 the next two kinds
    # round from it (bias 0: kinds 2, 3; bias 1: 3, 1; bias 2: 1, 2; FB:327-353).
    assert bias is not None
    nearest = _nearest_to_nest(listed_m)
    slots = list(listed_mm)
    slots[1], slots[nearest] = slots[nearest], slots[1]
    preferred = FOOD_KINDS[bias]
    kinds = ("nest", preferred, preferred, preferred, FOOD_KINDS[(bias + 1) % 3], FOOD_KINDS[(bias + 2) % 3])
    return tuple(piece(kind, p) for kind, p in zip(kinds, slots, strict=True))


def _nearest_to_nest(listed_m: list[tuple[float, float, float]]) -> int:
    """Layout 9: the index of the point whose disc edge is nearest the nest's (point 0), in metres, as their
    loop functions find it before swapping it into slot 1 (BLF:215-245).

    As theirs: the squared centre distance in float32 (BLF:1045-1050), its root and the radii in float64,
    the first of equal distances kept, only distances below 5 m considered. Where none is, theirs would swap
    the nest itself into slot 1; that is refused.
    """
    x0, y0, r0 = listed_m[0]
    nearest, smallest = 0, NEST_SEARCH_LIMIT_M
    for j in range(1, len(listed_m)):
        xj, yj, rj = listed_m[j]
        dx = np.float32(xj) - np.float32(x0)
        dy = np.float32(yj) - np.float32(y0)
        edge_to_edge = math.sqrt(float(dx * dx + dy * dy)) - (r0 + rj)
        if edge_to_edge < smallest:
            nearest, smallest = j, edge_to_edge
    if nearest == 0:
        raise ConfigError(
            f"layout 9 arena: no point within {NEST_SEARCH_LIMIT_M * 1000:g} mm edge to edge of the nest; "
            "expected one to move into the preferred slot"
        )
    return nearest
