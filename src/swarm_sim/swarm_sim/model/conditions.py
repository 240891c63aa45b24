"""Conditions: named, validated changes to the world (damage, per-robot faults, a harder radio, another swarm
or arena).

A condition is written ``NAME=VALUE`` (``evaluate --condition``, ``adapt --condition``, the simulator node's
``conditions`` parameter) and is nothing but a setting of ``swarm_sim.model.config.Config``, so it holds in
the reference road, the batch kernels, recordings and the node graph alike. Swarm-wide damage acts through
the wheel gains a trial starts with (``world.wheel_gains``); per-robot faults act on the simulator's side of
the robots' readings, messages and wheels (``world.faulty_wheels`` and its neighbours), never inside the
robots' own perception.

``dead-robots=K``
    robots 0 .. K-1 never drive or turn (both wheel gains 0: ``Config.dead_robots``). They **still
    broadcast** (only their motors failed: they sense, tick their trees and count in the objectives and
    descriptors), and other robots can still push them.
``weak-wheel=K:GAIN``
    the left wheel of the last K robots runs at GAIN (in [0, 1]) times its drawn gain (``weak_robots``,
    ``weak_gain``).
``message-loss=P``
    each message is lost with probability P, instead of the model's 1/20 (``delivery_probability = 1 - P``).
``robots=N``
    a swarm of N robots (``n_robots``).
``gap=MM``
    every trial's nest-food gap is MM mm, instead of 500 and 700 in turn (``gaps = (MM,)``): the food moves
    away from the nest (and, in the 2023 arena, its region shrinks with it).
``food-disc=R``
    a smaller food region at the same distance: in the 2023 arena (a nest disc and food beyond a circle),
    the food becomes a disc of radius R mm on the x axis, its near edge where the food's circle was (nest
    radius plus the gap of each configuration, after ``gap``). It is the same arena as a layout
    (``Config.layout``, ``regions.Piece``), so it holds on every road; a task with regions of its own has no
    such circle, and is refused.
``faults=RATE``, ``faults=RATE:KIND,KIND``, ``faults=FILE``
    per-robot faults (``swarm_sim.model.faults``, which says what each kind does; kinds ``ground-stuck``,
    ``ground-inverted``, ``rab-deaf``, ``rab-noisy``, ``rab-mirrored``, ``wheel-dead``, ``wheel-weak``,
    ``wheel-reversed``, ``disruptive``). ``RATE``: each robot is faulty with probability RATE, its kind drawn
    among all kinds, or among the KINDs listed, from a stream keyed by the evaluation's seed (the same seed
    has the same faulty robots on every road: ``fault_rate``, ``fault_kinds``). ``FILE``: a JSON or YAML
    file mapping robot ids to kinds, e.g. ``{"0": "wheel-dead", "4": "disruptive"}``, the same for every
    seed (``fault_robots``). Unlike ``dead-robots`` and ``weak-wheel``, a fault acts robot by robot where the
    world meets the robot (its readings, its messages, its wheels), not only on the wheel gains.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import replace
from pathlib import Path

from swarm_sim.errors import ConditionError, ConfigError
from swarm_sim.model.config import DEFAULT, Config
from swarm_sim.model.faults import FAULT_KINDS, read_fault_file
from swarm_sim.model.regions import concentric_food_disc

CONDITION_NAMES: tuple[str, ...] = (
    "dead-robots",
    "weak-wheel",
    "message-loss",
    "robots",
    "gap",
    "food-disc",
    "faults",
)
"""Every condition name, in the order they are applied (``robots`` is applied first, whatever the order
given, so that ``dead-robots`` and ``weak-wheel`` are checked against the swarm they damage)."""

_ORDER = ("robots", "gap", "food-disc", "message-loss", "dead-robots", "weak-wheel", "faults")


def _integer(name: str, text: str, piece: str | None = None, what: str = "") -> int:
    """``piece`` (default: the whole ``text``; for a part of it, such as weak-wheel's K) as an int; the
    error names the condition as given, ``name=text``, and the piece that is wrong."""
    piece = text if piece is None else piece
    try:
        return int(piece)
    except ValueError:
        raise ConditionError(f"condition {name}={text}: expected {what}an integer, got {piece!r}") from None


def _real(name: str, text: str, piece: str | None = None, what: str = "") -> float:
    """``piece`` (default: the whole ``text``) as a finite float; the error names ``name=text`` and the
    piece (``weak-wheel=3:inf`` was reported as ``weak-wheel=inf``)."""
    piece = text if piece is None else piece
    try:
        value = float(piece)
    except ValueError:
        raise ConditionError(f"condition {name}={text}: expected {what}a number, got {piece!r}") from None
    if not math.isfinite(value):
        raise ConditionError(f"condition {name}={text}: expected {what}a finite number, got {piece!r}")
    return value


def _robots(config: Config, text: str) -> tuple[Config, object]:
    n = _integer("robots", text)
    if n < 1:
        raise ConditionError(f"condition robots={text}: expected at least 1 robot, got {n}")
    return replace(config, n_robots=n), n


def _gap(config: Config, text: str) -> tuple[Config, object]:
    gap = _real("gap", text)
    largest = config.arena_half - config.robot_radius - config.nest_radius
    if not 0.0 < gap <= largest:
        raise ConditionError(
            f"condition gap={text}: expected a gap in (0, {largest:g}] mm (the food must lie inside the "
            f"walls), got {gap:g}"
        )
    return replace(config, gaps=(gap,)), gap


def _food_disc(config: Config, text: str) -> tuple[Config, object]:
    radius = _real("food-disc", text)
    if config.layout:
        raise ConditionError(
            f"condition food-disc={text}: the task has regions of its own; food-disc changes the 2023 arena "
            "(a nest disc and food beyond a circle)"
        )
    largest = (config.arena_half - config.robot_radius - config.nest_radius - max(config.gaps)) / 2
    if not 0.0 < radius <= largest:
        raise ConditionError(
            f"condition food-disc={text}: expected a radius in (0, {largest:g}] mm (the disc must lie inside "
            f"the walls beyond the largest gap), got {radius:g}"
        )
    layout = concentric_food_disc(config.nest_radius, config.gaps, radius)
    # The layout now says where the nest and the food are; nest_radius and gaps keep their defaults, as a
    # layout requires (they describe only the concentric arena).
    return replace(config, layout=layout, nest_radius=DEFAULT.nest_radius, gaps=DEFAULT.gaps), radius


def _message_loss(config: Config, text: str) -> tuple[Config, object]:
    loss = _real("message-loss", text)
    if not 0.0 <= loss <= 1.0:
        raise ConditionError(f"condition message-loss={text}: expected a probability in [0, 1], got {loss:g}")
    return replace(config, delivery_probability=1.0 - loss), loss


def _dead_robots(config: Config, text: str) -> tuple[Config, object]:
    k = _integer("dead-robots", text)
    if not 0 <= k <= config.n_robots:
        raise ConditionError(
            f"condition dead-robots={text}: expected a number of robots in [0, {config.n_robots}], got {k}"
        )
    return replace(config, dead_robots=k), k


def _weak_wheel(config: Config, text: str) -> tuple[Config, object]:
    parts = text.split(":")
    if len(parts) != 2:
        raise ConditionError(f"condition weak-wheel={text}: expected K:GAIN, e.g. weak-wheel=3:0.5")
    k = _integer("weak-wheel", text, parts[0], "K, ")
    gain = _real("weak-wheel", text, parts[1], "GAIN, ")
    if not 0 <= k <= config.n_robots:
        raise ConditionError(
            f"condition weak-wheel={text}: expected K, a number of robots in [0, {config.n_robots}], got {k}"
        )
    if not 0.0 <= gain <= 1.0:
        raise ConditionError(f"condition weak-wheel={text}: expected GAIN in [0, 1], got {gain:g}")
    return replace(config, weak_robots=k, weak_gain=gain), [k, gain]


def _faults(config: Config, text: str) -> tuple[Config, object]:
    head, _, kinds_text = text.partition(":")
    try:
        rate = float(head)
    except ValueError:
        rate = None
    if rate is None:  # not a rate: a file of faults
        if not Path(text).is_file():
            raise ConditionError(
                f"condition faults={text}: expected RATE, RATE:KIND,KIND or a fault file (JSON or YAML), "
                f"and there is no file {text}"
            )
        try:
            robots = read_fault_file(text)
        except ConfigError as error:
            raise ConditionError(f"condition faults={text}: {error}") from None
        return replace(config, fault_robots=robots), text
    if not 0.0 <= rate <= 1.0:
        raise ConditionError(f"condition faults={text}: expected RATE, a probability in [0, 1], got {head!r}")
    kinds = tuple(kind.strip() for kind in kinds_text.split(",")) if kinds_text else ()
    for kind in kinds:
        if kind not in FAULT_KINDS:
            said = f"condition faults={text}: unknown fault kind {kind!r}"
            raise ConditionError(f"{said}; expected one of {', '.join(FAULT_KINDS)}")
    return replace(config, fault_rate=rate, fault_kinds=kinds), [rate, ",".join(kinds)] if kinds else rate


_APPLY: dict[str, Callable[[Config, str], tuple[Config, object]]] = {
    "robots": _robots,
    "gap": _gap,
    "food-disc": _food_disc,
    "message-loss": _message_loss,
    "dead-robots": _dead_robots,
    "weak-wheel": _weak_wheel,
    "faults": _faults,
}


def parse_conditions(texts: Sequence[str]) -> dict[str, str]:
    """``NAME=VALUE`` texts as {name: value text}; ConditionError for a bad form, name or repeat."""
    out: dict[str, str] = {}
    for text in texts:
        if not isinstance(text, str) or "=" not in text:
            raise ConditionError(
                f"condition {text!r}: expected NAME=VALUE with NAME one of {', '.join(CONDITION_NAMES)}"
            )
        name, value = (part.strip() for part in text.split("=", 1))
        if name not in _APPLY:
            raise ConditionError(f"unknown condition {name!r}: expected one of {', '.join(CONDITION_NAMES)}")
        if name in out:
            raise ConditionError(f"condition {name} given twice ({name}={out[name]}, {name}={value})")
        if not value:
            raise ConditionError(f"condition {name}=: expected a value after '='")
        out[name] = value
    return out


def apply_conditions(texts: Sequence[str], config: Config = DEFAULT) -> tuple[Config, dict[str, object]]:
    """``config`` changed by every condition of ``texts`` (``NAME=VALUE``), and the conditions as parsed
    values by name (for results files: ``{"dead-robots": 2, "weak-wheel": [3, 0.5]}``; ``{}`` for none).

    Raises ConditionError naming the first bad condition."""
    given = parse_conditions(texts)
    record: dict[str, object] = {}
    for name in _ORDER:
        if name in given:
            try:
                config, record[name] = _APPLY[name](config, given[name])
            except ConfigError as error:
                raise ConditionError(f"condition {name}={given[name]}: {error}") from None
    return config, {name: record[name] for name in CONDITION_NAMES if name in record}


def condition_texts(record: dict[str, object]) -> list[str]:
    """The ``NAME=VALUE`` texts of a record written by ``apply_conditions`` (for passing them on)."""
    texts = []
    for name in CONDITION_NAMES:
        if name in record:
            value = record[name]
            text = ":".join(str(v) for v in value) if isinstance(value, list) else str(value)
            texts.append(f"{name}={text}")
    return texts
