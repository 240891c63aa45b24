"""Per-robot faults: which kinds there are, what each does, and the faults a configuration names.

A fault strikes one robot and changes the world on the simulator's side (what the robot reads, what its
message carries, how its wheels move), never the robot's own software; ``swarm_sim.core.world`` applies
them (``faulty_wheels``, ``faulty_ground``, ``deafen``, ``faulty_bearing``, ``disrupt``) in the batch
kernels, the reference road and the simulator node alike. The kinds:

``ground-stuck``
    the ground sensor reads nothing: the robot perceives no region, wherever it stands (its ``in_nest`` and
    ``on_food`` conditions never hold, its estimates never drop to 0 and it broadcasts the "not here" value
    of every region). It still picks up and delivers food where it really goes: a robot that crosses from
    food to the nest delivers.
``ground-inverted``
    the ground sensor reads every region the other way round: in a region where it is not, out of one where
    it is. What it perceives (conditions, estimates, broadcasts) follows the false reading; the food it picks
    up and delivers follows where it really is, so standing off food and out of the nest makes no food.

A ground fault changes only what the robot reads. Picking up and delivering food follow the ground the robot
really stands on (after the robot-type swap, ``world.swap_ground``), as does its carrying flag, which the
``got_food`` conditions read: a faulty sensor neither makes nor destroys food, and the robot knows truly
whether it carries (the gripper is not the ground sensor). The simulator hands such a robot both its false
reading and where it stands (``bt_controller.robot.perception.Readings.footing``; the ``footing`` field of
``swarm_msgs/GroundSensor``).
``rab-deaf``
    the range-and-bearing receiver hears no message (the robot still broadcasts, and others hear it).
``rab-noisy``
    every bearing the robot measures is off by an error uniform in +-``BEARING_NOISE`` rad, drawn per
    robot, step and sender (``bt_controller.draws``' ``BEARINGS`` stream; ranges and values are exact).
``rab-mirrored``
    every bearing the robot measures has its sign flipped (left is right).
``wheel-dead``
    the left wheel never turns (its gain 0).
``wheel-weak``
    the left wheel runs at ``WEAK_WHEEL_GAIN`` times its drawn gain.
``wheel-reversed``
    the left wheel turns backwards (its gain negated).
``disruptive``
    every message the robot sends carries 0 for every region, whatever it meant to say: the others take it
    for a robot standing in the nest and in every food region, and are led to it.

A configuration names faults in two ways (``Config.fault_rate``, ``fault_kinds``, ``fault_robots``): a rate
(each robot faulty with that probability, its kind drawn among ``fault_kinds``, from a stream keyed by the
evaluation's seed, so a seed has the same faulty robots on every road and in every chain), or given robots
with given kinds. ``swarm_sim.core.trial_data.robot_faults`` turns either into each robot's fault code.
"""

from __future__ import annotations

import json
import math
from pathlib import Path

import yaml

from swarm_sim.errors import ConfigError

FAULT_KINDS: tuple[str, ...] = (
    "ground-stuck",
    "ground-inverted",
    "rab-deaf",
    "rab-noisy",
    "rab-mirrored",
    "wheel-dead",
    "wheel-weak",
    "wheel-reversed",
    "disruptive",
)
"""Every fault kind; kind ``FAULT_KINDS[c - 1]`` has code ``c`` (code 0: no fault)."""

CONFIG_FIELDS: tuple[str, ...] = ("fault_rate", "fault_kinds", "fault_robots")
"""The ``Config`` fields that name faults: written next to results only when some fault is given, and not
declared as node parameters (a node takes faults through its ``conditions`` parameter)."""

NO_FAULT = 0
(
    GROUND_STUCK,
    GROUND_INVERTED,
    RAB_DEAF,
    RAB_NOISY,
    RAB_MIRRORED,
    WHEEL_DEAD,
    WHEEL_WEAK,
    WHEEL_REVERSED,
    DISRUPTIVE,
) = range(1, len(FAULT_KINDS) + 1)

GROUND_FAULTS: tuple[int, ...] = (GROUND_STUCK, GROUND_INVERTED)
"""The codes of the ground-sensor faults: a robot with one reads a false ground, and is told where it really
stands for picking up and delivering food (``bt_controller.robot.perception.Readings.footing``)."""

BEARING_NOISE = math.pi / 3.0
"""Half the width of a ``rab-noisy`` receiver's bearing error (rad): 60 degrees either way."""
WEAK_WHEEL_GAIN = 0.5
"""What a ``wheel-weak`` left wheel runs at, times its drawn gain."""
DISRUPTIVE_VALUE = 0.0
"""What a ``disruptive`` robot's messages carry for every region (mm): "I am there"."""


def fault_code(kind: str) -> int:
    """The code of fault kind ``kind``; ConfigError naming the kinds for an unknown one."""
    if kind not in FAULT_KINDS:
        raise ConfigError(f"unknown fault kind {kind!r}; expected one of {', '.join(FAULT_KINDS)}")
    return FAULT_KINDS.index(kind) + 1


def check_faults(
    rate: float, kinds: tuple[str, ...], robots: tuple[tuple[int, str], ...], n_robots: int
) -> None:
    """ConfigError naming the first bad fault setting: a rate outside [0, 1], an unknown or repeated kind,
    a robot outside the swarm or given twice, or both a rate and given robots."""
    if isinstance(rate, bool) or not isinstance(rate, int | float) or not 0.0 <= rate <= 1.0:
        raise ConfigError(f"fault_rate must be a probability in [0, 1], got {rate!r}")
    if not isinstance(kinds, tuple):
        raise ConfigError(f"fault_kinds must be a tuple of fault kinds, got {kinds!r}")
    for kind in kinds:
        fault_code(kind)
    if len(set(kinds)) != len(kinds):
        raise ConfigError(f"fault_kinds names a kind twice: {', '.join(kinds)}")
    if not isinstance(robots, tuple):
        raise ConfigError(f"fault_robots must be a tuple of (robot, kind) pairs, got {robots!r}")
    seen: set[int] = set()
    for pair in robots:
        if not isinstance(pair, tuple) or len(pair) != 2:
            raise ConfigError(f"fault_robots must hold (robot, kind) pairs, got {pair!r}")
        robot, kind = pair
        if isinstance(robot, bool) or not isinstance(robot, int) or not 0 <= robot < n_robots:
            raise ConfigError(f"a faulty robot must be a robot id in [0, {n_robots - 1}], got {robot!r}")
        if robot in seen:
            raise ConfigError(f"robot {robot} is given two faults")
        seen.add(robot)
        fault_code(kind)
    if robots and rate > 0.0:
        raise ConfigError("give faults at a rate (fault_rate) or robot by robot (fault_robots), not both")


def read_fault_file(path: str) -> tuple[tuple[int, str], ...]:
    """The faults of a JSON or YAML file mapping robot ids to fault kinds (``{"0": "wheel-dead", "3":
    "disruptive"}``), sorted by robot; ConfigError in one line for an unreadable file or a bad entry."""
    try:
        data = yaml.safe_load(Path(path).read_text(encoding="utf-8"))  # YAML reads JSON too
    except (OSError, UnicodeDecodeError, yaml.YAMLError) as error:
        reason = getattr(error, "strerror", None) or type(error).__name__
        raise ConfigError(f"fault file {path}: cannot read it ({reason})") from None
    if not isinstance(data, dict) or not data:
        raise ConfigError(
            f"fault file {path}: expected a mapping of robot ids to fault kinds, e.g. "
            f"{json.dumps({'0': 'wheel-dead'})}"
        )
    out = []
    for robot, kind in data.items():
        try:
            number = int(robot)
        except (TypeError, ValueError):
            raise ConfigError(f"fault file {path}: expected a robot id, got {robot!r}") from None
        if not isinstance(kind, str):
            raise ConfigError(f"fault file {path}: robot {number}: expected a fault kind, got {kind!r}")
        out.append((number, kind))
    return tuple(sorted(out))


def parse_fault_pairs(text: str, n_robots: int) -> tuple[tuple[int, str], ...]:
    """The faults of ``ROBOT:KIND`` pairs separated by spaces (``"0:wheel-dead 4:disruptive"``; empty: none)
    for a swarm of ``n_robots``, sorted by robot (the simulator's ``inject_faults`` service); ConfigError in
    one line naming the first bad pair."""
    out = []
    for pair in text.split():
        robot, colon, kind = pair.partition(":")
        try:
            number = int(robot)
        except ValueError:
            number = -1
        if not colon or number < 0:
            raise ConfigError(f"expected ROBOT:KIND pairs such as 0:wheel-dead, got {pair!r}")
        out.append((number, kind))
    pairs = tuple(sorted(out))
    check_faults(0.0, (), pairs, n_robots)
    return pairs


def fault_kinds_of(codes: list[int] | tuple[int, ...]) -> list[str]:
    """Each robot's fault kind from its code (``""`` for none)."""
    return [FAULT_KINDS[c - 1] if c else "" for c in codes]
