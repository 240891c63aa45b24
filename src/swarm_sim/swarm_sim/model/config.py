"""Every parameter of the world model, named once, validated once (``docs/model.md``).

``Config`` is the frozen, validated object users and nodes see; ``Config.params()`` turns it into ``Params``,
the plain named tuple that compiled kernels receive (numba reads its fields as typed constants).

Units: millimetres, seconds, radians.
"""

from __future__ import annotations

import functools
import json
import math
from dataclasses import dataclass, fields, replace
from typing import Any, NamedTuple

import numpy as np

from bt_controller.model_settings import (
    PROFILES,
    PerceptionParams,
    Timeline,
    arena_of_trial,
    check_authors_code,
    profile_number,
)
from bt_controller.validate import integer, number
from swarm_sim.errors import ConfigError
from swarm_sim.model.faults import CONFIG_FIELDS as FAULT_FIELDS
from swarm_sim.model.faults import check_faults
from swarm_sim.model.regions import (
    REGION_KINDS,
    ArenaEntry,
    Layout,
    check_layout,
    concentric,
    entry_of_trial,
    food_kinds,
    layout_as_json,
    layout_from_json,
    layout_table,
)

_PERCEPTION = PerceptionParams()
_TIMELINE = Timeline()

FORMATIONS: tuple[str, ...] = ("random", "lattice", "nest", "localised", "two_robots")
"""The start formations (the authors' 2026 ``formation`` setting), in the order compiled code numbers them
(``Params.formation``): see ``world.place_robots``."""
FORMATION_RANDOM, FORMATION_LATTICE, FORMATION_NEST, FORMATION_LOCALISED, FORMATION_TWO_ROBOTS = range(5)
FORMATION_MARGIN = 150.0
"""The ``nest`` and ``localised`` start areas stay this far inside the walls (mm): their +-2.3 m in a
2.45 m arena."""
DEFAULT_NEST_RADIUS = 500.0
DEFAULT_GAPS = (500.0, 700.0)
ROBOT_TYPES: tuple[int, ...] = (1, 2)
"""The values of ``Config.robot_types``: 1, every robot perceives the regions as they are; 2, the authors'
two robot types (``docs/model.md``, "Robot types")."""
CARRY_KIND_BITS = 3
"""Bits per robot group in ``Params.carry_masks``: bit f of group g's bits says whether the group picks up
food kind f + 1 (``world.can_carry``)."""
MAX_CARRY_GROUPS = 63 // CARRY_KIND_BITS
"""The most robot groups ``Config.carries`` may have: their masks fill one int64 (``Params.carry_masks``)."""


class Params(NamedTuple):
    """The configuration as compiled kernels see it (all fields float or int; ``profile`` a number)."""

    profile: int
    arena_half: float
    n_robots: int
    robot_radius: float
    start_half: float
    max_start_attempts: int
    wheel_separation: float
    wheel_speed: float
    gain_low: float
    gain_step: float
    gain_levels: int
    step_dt: float
    steps_per_tick: int
    ticks: int
    initial_step: int
    chain_trials: int
    message_range: float
    delivery_probability: float
    occlusion: bool
    estimate_cap: float
    density_range: float
    density_divisor: float
    window: int
    friction: float
    wall_friction: float
    physics_substeps: int
    solver_iterations: int
    max_drive_accel: float
    max_turn_accel: float
    dead_robots: int
    weak_robots: int
    weak_gain: float
    formation: int
    regions: int
    preferred_food: int
    other_food_weight: float
    authors_code: int
    robot_types: int
    carry_groups: int
    """``len(Config.carries)``: 0, every robot picks up every kind."""
    carry_masks: int
    """Each group's food kinds, ``CARRY_KIND_BITS`` bits a group (``carry_masks``)."""


_INT_MINIMUM = {
    "n_robots": 1,
    "max_start_attempts": 1,
    "gain_levels": 1,
    "steps_per_tick": 1,
    "ticks": 1,
    "initial_step": 1,
    "chain_trials": 1,
    "window": 1,
    "physics_substeps": 1,
    "solver_iterations": 1,
    "dead_robots": 0,
    "weak_robots": 0,
    "preferred_food": 0,
    "authors_code": 0,
    "robot_types": 1,
}
"""The integer parameters and the least value each may take (the one list of them)."""


@dataclass(frozen=True)
class Config:
    """The world model's parameters (defaults from ``docs/model.md``, which gives each one's source).

    Construction validates every value and raises ``ConfigError`` naming the first bad one.
    """

    profile: str = PROFILES[_TIMELINE.profile]
    """``paper`` (the authors' experiment, artefacts A1-A4 included) or ``clean`` (A1-A4 removed)."""
    arena_half: float = 2450.0
    """Half the side of the free square inside the walls (walls 100 mm thick centred at +-2500 mm) (mm)."""
    nest_radius: float = DEFAULT_NEST_RADIUS
    """The 2023 arena: a robot is in the nest when its centre is closer than this to the arena centre (mm)."""
    gaps: tuple[float, ...] = DEFAULT_GAPS
    """The 2023 arena: the gap between nest and food per arena configuration (mm); see ``gap``."""
    layout: Layout = ()
    """The regions of every trial (``swarm_sim.model.regions``); empty: the 2023 arena of ``nest_radius`` and
    ``gaps`` (``regions.concentric``). A task with regions of its own sets it, and then ``nest_radius`` and
    ``gaps`` must keep their defaults (they describe only the 2023 arena)."""
    n_robots: int = 9
    """Footbots in the swarm: the one place the robot count is defined."""
    robot_radius: float = 85.036758
    """Footbot body radius (mm): ARGoS's ``BODY_RADIUS`` (``footbot_entity.cpp``) and its dynamics2d disc."""
    start_half: float = 1000.0
    """Start positions are uniform in the square [-start_half, start_half]^2 (mm)."""
    max_start_attempts: int = 10
    """Tries per robot to find a free start position; after that it stays where it is."""
    wheel_separation: float = 140.0
    """Distance between the wheels (mm)."""
    wheel_speed: float = 50.0
    """Nominal wheel speed, one unit of an action's wheel setting (mm/s)."""
    gain_low: float = 0.9
    """Each wheel's gain is gain_low + gain_step * U{0 .. gain_levels - 1}, drawn once per chain."""
    gain_step: float = 0.01
    """Step between the possible wheel gains."""
    gain_levels: int = 20
    """Number of possible wheel gains."""
    step_dt: float = 0.125
    """Length of one control step (s): 8 Hz."""
    steps_per_tick: int = _TIMELINE.steps_per_tick
    """Control steps per behaviour-tree tick: 2 Hz."""
    ticks: int = _TIMELINE.ticks
    """Ticks per trial (20 s)."""
    initial_step: int = _TIMELINE.initial_step
    """A trial's step whose smoothed values are the objectives' initial values."""
    chain_trials: int = _TIMELINE.chain_trials
    """Trials per chain (``paper``: one simulation with teleports); also the block of trials sharing a gap."""
    message_range: float = 1000.0
    """Messages travel only between centres at most this far apart (mm)."""
    delivery_probability: float = 0.95
    """Chance that a message within range and not occluded arrives (per ordered pair, per step)."""
    occlusion: bool = True
    """Whether a third robot's body between two robots blocks their messages."""
    estimate_cap: float = _PERCEPTION.estimate_cap
    """Largest nest/food distance estimate; also the estimate when nothing was heard (mm)."""
    density_range: float = _PERCEPTION.density_range
    """A neighbour at range r adds 1 / (pi (r / density_range)^2) to the density sum (mm)."""
    density_divisor: float = _PERCEPTION.density_divisor
    """The density sum is divided by this."""
    window: int = _PERCEPTION.window
    """Raw samples averaged into a smoothed value."""
    friction: float = 0.49
    """Coulomb friction coefficient at a robot-robot contact (ARGoS: 0.7 per footbot body, multiplied)."""
    wall_friction: float = 0.07
    """Coulomb friction coefficient between a robot and a wall (ARGoS: 0.7 for the footbot, 0.1 for a box)."""
    physics_substeps: int = 10
    """Physics substeps per control step (ARGoS dynamics2d's default ``iterations``)."""
    solver_iterations: int = 10
    """Passes over the contacts and drives per substep while robots touch (Chipmunk's ``iterations``)."""
    max_drive_accel: float = 9375.0
    """Largest acceleration a robot's drive exerts to reach its target velocity: ARGoS's 15 N on a 1.6 kg
    footbot (mm/s^2)."""
    max_turn_accel: float = 6482.3
    """Largest angular acceleration of a robot's drive: ARGoS's 150 N m over the footbot's moment of inertia,
    1.6 kg x (2 x 85.036758 mm)^2 / 2 (rad/s^2)."""
    dead_robots: int = 0
    """Damage (``swarm_sim.model.conditions``): robots 0 .. dead_robots - 1 have both wheel gains 0, so they
    never drive or turn; they still sense, tick their trees and broadcast, and count in the objectives."""
    weak_robots: int = 0
    """Damage: the left wheel of the last weak_robots robots runs at weak_gain times its drawn gain."""
    weak_gain: float = 1.0
    """Factor on the weak robots' left wheel gain, in [0, 1]."""
    formation: str = "random"
    """Where robots start each trial (``world.place_robots``): ``random`` (uniform in the start square, the
    papers'), ``lattice`` (a grid 1 m apart; a square number of robots), ``nest`` (around the nest's disc),
    ``localised`` (even robots around the first food disc, odd ones around the nest's) or ``two_robots``
    (two robots facing each other; chains of one trial)."""
    preferred_food: int = 0
    """The food kind (1-3) the ``foraging_biased`` objective prefers (the authors' 2026 ``arenaBias``, 0-based
    there); 0: none, and ``foraging_biased`` is ``foraging``."""
    other_food_weight: float = 1.0
    """What a delivery of another kind than ``preferred_food`` counts in ``foraging_biased`` (the authors'
    ``penalty``: 1.0 by default, 0.5 in their arena-9 runs)."""
    authors_code: int = _TIMELINE.authors_code
    """Which of the authors' code versions ``paper`` reproduces (``AUTHORS_CODES``): 2024, the papers' code,
    or 2026, their commit 1cd2358, whose robots start their estimates afresh at every trial of a chain and
    see no robot on either side when nobody is heard (``docs/model.md``, "Two profiles"). Under ``clean``
    both give the same model."""
    robot_types: int = 1
    """1: every robot perceives the regions as they are. 2: the authors' two robot types of their
    ``generic`` projects (commit 1cd2358): a robot's type is its id mod 2, and an odd robot perceives the nest
    and food kind 1 the other way round, on its ground sensor, in the estimates it receives and in those it
    broadcasts, and in its true food distance (the probe); one tree serves both types (``docs/model.md``,
    "Robot types")."""
    carries: tuple[tuple[str, ...], ...] = ()
    """Which food kinds each group of robots can pick up: one entry per group, each the names of the food
    kinds (``food``, ``food2``, ``food3``) its robots pick up (an empty entry: robots that carry nothing).
    Robot i belongs to group ``i mod len(carries)``, as robot i runs tree ``i mod K`` of a team of K. A
    robot standing on a kind it cannot carry still senses it (ground sensor, estimates, conditions) but does
    not pick it up (``world.can_carry``; ``docs/model.md``, "Robot types"). Empty: every robot picks up
    every kind."""
    fault_rate: float = 0.0
    """Per-robot faults (``swarm_sim.model.faults``): each robot is faulty with this probability, drawn per
    evaluation seed (``trial_data.robot_faults``); 0: none."""
    fault_kinds: tuple[str, ...] = ()
    """The kinds a faulty robot's fault is drawn among under ``fault_rate`` (``faults.FAULT_KINDS``); empty:
    all of them."""
    fault_robots: tuple[tuple[int, str], ...] = ()
    """Faults given robot by robot, (robot id, kind) pairs, the same for every seed (not with
    ``fault_rate``)."""

    def __post_init__(self) -> None:
        _validate(self)

    @property
    def profile_number(self) -> int:
        """The profile as the number compiled code reads (``timeline.PAPER`` or ``timeline.CLEAN``)."""
        return profile_number(self.profile)

    @property
    def timeline(self) -> Timeline:
        """The timeline's parameters."""
        return Timeline(
            self.profile_number,
            self.steps_per_tick,
            self.ticks,
            self.initial_step,
            self.chain_trials,
            self.authors_code,
        )

    @property
    def perception(self) -> PerceptionParams:
        """The robots' perception parameters."""
        return PerceptionParams(
            self.window,
            self.estimate_cap,
            self.density_range,
            self.density_divisor,
            self.profile_number,
            self.regions,
            self.authors_code,
        )

    @property
    def food_kinds(self) -> int:
        """How many kinds of food the arena has (1 for the papers' arena; ``regions.food_kinds``)."""
        return food_kinds(self.layout)

    @property
    def regions(self) -> int:
        """The regions robots perceive: the nest and the food kinds."""
        return 1 + self.food_kinds

    @property
    def trial_steps(self) -> int:
        """Control steps per trial (160 under ``paper``, 176 under ``clean``)."""
        return self.ticks * self.steps_per_tick + (self.initial_step if self.profile == "clean" else 0)

    @property
    def chain_length(self) -> int:
        """Trials per simulated chain: ``chain_trials`` under ``paper``, 1 under ``clean``."""
        return self.chain_trials if self.profile == "paper" else 1

    def gap(self, trial: int) -> float:
        """The nest-food gap of trial ``trial`` in the 2023 arena: trials come in blocks of ``chain_trials``
        (one chain under ``paper``), and the blocks alternate the gaps. NaN under a layout of the task's own,
        which has no one gap."""
        if self.layout:
            return math.nan
        return self.gaps[arena_of_trial(self.timeline, trial, len(self.gaps))]

    @property
    def arena_layout(self) -> Layout:
        """The layout in force: ``layout``, or the 2023 arena of ``nest_radius`` and ``gaps``."""
        return self.layout or concentric(self.nest_radius, self.gaps)

    def arena_of_trial(self, trial: int) -> int:
        """The arena configuration (a row of ``arena_layout``) of trial ``trial``."""
        return arena_of_trial(self.timeline, trial, len(self.arena_layout))

    @functools.cached_property
    def arena_table(self) -> tuple[np.ndarray, np.ndarray]:
        """``arena_layout`` as compiled code reads it (``regions.layout_table``: pieces and food scales)."""
        return layout_table(self.arena_layout)

    def arena_arrays(self, trial: int) -> tuple[np.ndarray, float]:
        """The regions of trial ``trial`` as compiled code reads them: its entry's row of ``arena_table``
        (pieces x ``regions.PIECE_FIELDS``) and its food scale."""
        table, scale = self.arena_table
        c = self.arena_of_trial(trial)
        k = (trial % self.chain_trials) % table.shape[1]
        return table[c, k], float(scale[c, k])

    def arena_entry(self, trial: int) -> ArenaEntry:
        """The regions of trial ``trial`` of an evaluation (``regions.entry_of_trial``)."""
        return entry_of_trial(self.arena_layout, trial, self.chain_trials)

    def params(self) -> Params:
        """The configuration as a ``Params`` named tuple for compiled kernels."""

        def field(name: str) -> int | float | bool:
            if name == "profile":
                return self.profile_number
            if name == "formation":
                return FORMATIONS.index(self.formation)
            if name == "occlusion":
                return bool(self.occlusion)
            if name == "regions":
                return self.regions
            if name == "carry_groups":
                return len(self.carries)
            if name == "carry_masks":
                return carry_masks(self.carries)
            return (int if name in _INT_MINIMUM else float)(getattr(self, name))

        return Params._make(field(f) for f in Params._fields)

    def as_dict(self) -> dict[str, object]:
        """Every parameter by name (gaps as a list, a layout as ``regions.layout_as_json``; no ``layout`` key
        for the papers' arena), for writing next to results."""
        out: dict[str, object] = {}
        for f in fields(self):
            value = getattr(self, f.name)
            if f.name == "layout":
                if not value:
                    continue  # the papers' arena: nest_radius and gaps say it, as before layouts
                value = layout_as_json(value)
            if f.name in FAULT_FIELDS and value == f.default:
                continue  # no faults: written as before faults
            if f.name == "robot_types" and value == f.default:
                continue  # one type: written as before robot types
            if f.name == "carries":
                if not value:
                    continue  # every robot carries every kind: written as before carries
                value = [list(group) for group in value]
            if f.name == "fault_robots":
                value = [list(pair) for pair in value]
            out[f.name] = list(value) if isinstance(value, tuple) else value
        return out


def _number(config: Config, name: str) -> float:
    return number(getattr(config, name), name, error=ConfigError)


def _positive(config: Config, name: str) -> float:
    return number(getattr(config, name), name, positive=True, error=ConfigError)


def _count(config: Config, name: str, minimum: int = 1) -> int:
    return integer(getattr(config, name), name, minimum, error=ConfigError)


def _validate(c: Config) -> None:
    if c.profile not in PROFILES:
        raise ConfigError(f"profile must be one of {', '.join(PROFILES)}, got {c.profile!r}")
    try:
        check_authors_code(c.authors_code)
    except ValueError as error:
        raise ConfigError(str(error)) from None
    if isinstance(c.robot_types, bool) or c.robot_types not in ROBOT_TYPES:
        raise ConfigError(
            f"robot_types must be 1 (one type) or 2 (the authors' two types, odd robots with the nest and "
            f"food kind 1 swapped), got {c.robot_types!r}"
        )
    for name in (
        "arena_half",
        "nest_radius",
        "robot_radius",
        "start_half",
        "wheel_separation",
        "wheel_speed",
        "step_dt",
        "message_range",
        "estimate_cap",
        "density_range",
        "density_divisor",
        "max_drive_accel",
        "max_turn_accel",
        "gain_low",
    ):
        _positive(c, name)
    for name, least in _INT_MINIMUM.items():
        _count(c, name, least)
    if _number(c, "gain_step") < 0:
        raise ConfigError(f"gain_step must not be negative, got {c.gain_step!r}")
    friction = _number(c, "friction")
    if not 0.0 <= friction <= 1.0:
        raise ConfigError(f"friction must be in [0, 1], got {friction}")
    wall_friction = _number(c, "wall_friction")
    if not 0.0 <= wall_friction <= 1.0:
        raise ConfigError(f"wall_friction must be in [0, 1], got {wall_friction}")
    if not isinstance(c.occlusion, bool):
        raise ConfigError(f"occlusion must be true or false, got {c.occlusion!r}")
    for name in ("dead_robots", "weak_robots"):
        if getattr(c, name) > c.n_robots:
            raise ConfigError(f"{name} must be at most n_robots = {c.n_robots}, got {getattr(c, name)}")
    weak_gain = _number(c, "weak_gain")
    if not 0.0 <= weak_gain <= 1.0:
        raise ConfigError(f"weak_gain must be in [0, 1], got {weak_gain}")
    p = _number(c, "delivery_probability")
    if not 0.0 <= p <= 1.0:
        raise ConfigError(f"delivery_probability must be in [0, 1], got {p}")
    if not isinstance(c.gaps, tuple) or not c.gaps:
        raise ConfigError(f"gaps must be a non-empty tuple of positive numbers, got {c.gaps!r}")
    for k, gap in enumerate(c.gaps):
        number(gap, f"gaps[{k}]", positive=True, error=ConfigError)
    if not isinstance(c.layout, tuple):
        raise ConfigError(f"layout must be a tuple of arena configurations, got {c.layout!r}")
    if c.layout:
        if (c.nest_radius, c.gaps) != (DEFAULT_NEST_RADIUS, DEFAULT_GAPS):
            raise ConfigError(
                "nest_radius and gaps describe the 2023 arena only: with a layout, leave them at their "
                f"defaults ({DEFAULT_NEST_RADIUS:g}, {list(DEFAULT_GAPS)}), "
                f"got {c.nest_radius:g}, {list(c.gaps)}"
            )
        check_layout(c.layout, c.arena_half)
    if c.robot_radius >= c.arena_half:
        raise ConfigError(f"robot_radius must be below arena_half, got {c.robot_radius} >= {c.arena_half}")
    if c.start_half + c.robot_radius > c.arena_half:
        raise ConfigError(
            f"start_half must keep robots inside the walls: start_half + robot_radius = "
            f"{c.start_half + c.robot_radius} > arena_half = {c.arena_half}"
        )
    if c.initial_step >= c.ticks * c.steps_per_tick or c.initial_step % c.steps_per_tick:
        raise ConfigError(
            f"initial_step must be a multiple of steps_per_tick ({c.steps_per_tick}) inside a trial's "
            f"{c.ticks * c.steps_per_tick} steps (the smoothed values are refreshed then), "
            f"got {c.initial_step}"
        )
    _validate_formation(c)
    check_carries(c.carries, c.food_kinds, c.n_robots)
    if c.preferred_food > food_kinds(c.layout):
        raise ConfigError(
            f"preferred_food must be 0 (none) or a food kind of the arena, 1 to {food_kinds(c.layout)}, "
            f"got {c.preferred_food}"
        )
    _number(c, "other_food_weight")
    check_faults(c.fault_rate, c.fault_kinds, c.fault_robots, c.n_robots)
    # Placing n discs of radius r in a square of side 2 S by rejection is easy while their area is small.
    area_ratio = c.n_robots * math.pi * c.robot_radius**2 / (2.0 * c.start_half) ** 2
    if area_ratio > 0.5:
        raise ConfigError(
            f"n_robots = {c.n_robots} robots of radius {c.robot_radius} do not fit easily within "
            f"start_half = {c.start_half} (they would cover {area_ratio:.0%} of the start square; "
            "at most 50%)"
        )


def check_carries(carries: object, kinds: int, n_robots: int, key: str = "carries") -> None:
    """``ConfigError`` in one line unless ``carries`` is a tuple of groups (at most ``n_robots`` and
    ``MAX_CARRY_GROUPS``), each a tuple of distinct names of the arena's ``kinds`` food kinds; ``key`` names
    the setting in the message."""
    names = REGION_KINDS[1:]
    if not isinstance(carries, tuple):
        raise ConfigError(
            f"{key} must be a list of robot groups, each a list of food kinds ({', '.join(names)}), "
            f"got {carries!r}"
        )
    if len(carries) > min(n_robots, MAX_CARRY_GROUPS):
        raise ConfigError(
            f"{key} has {len(carries)} robot groups, more than the {n_robots} robots"
            if len(carries) > n_robots
            else f"{key} has {len(carries)} robot groups; at most {MAX_CARRY_GROUPS}"
        )
    for g, group in enumerate(carries):
        if not isinstance(group, tuple):
            raise ConfigError(f"{key}[{g}] must be a list of food kinds ({', '.join(names)}), got {group!r}")
        for kind in group:
            if kind not in names:
                raise ConfigError(
                    f"{key}[{g}]: {kind!r} is not a food kind; expected among {', '.join(names)}"
                )
            if names.index(kind) >= kinds:
                raise ConfigError(
                    f"{key}[{g}]: the arena has no {kind} (its food kinds: {', '.join(names[:kinds])})"
                )
        if len(set(group)) != len(group):
            raise ConfigError(f"{key}[{g}] names a food kind twice, got {list(group)}")


def carry_masks(carries: tuple[tuple[str, ...], ...]) -> int:
    """``Params.carry_masks`` of ``Config.carries``: group g's food kinds in bits ``CARRY_KIND_BITS * g`` up,
    bit f for food kind f + 1."""
    names = REGION_KINDS[1:]
    mask = 0
    for g, group in enumerate(carries):
        for kind in group:
            mask |= 1 << (CARRY_KIND_BITS * g + names.index(kind))
    return mask


def carries_to_text(carries: tuple[tuple[str, ...], ...]) -> str:
    """``Config.carries`` as one line of JSON (a ROS parameter's text, as ``layout``'s); "" for none."""
    return json.dumps([list(group) for group in carries], separators=(",", ":")) if carries else ""


def carries_from_text(text: str, key: str = "carries") -> tuple[tuple[str, ...], ...]:
    """The groups ``carries_to_text`` wrote ("" gives none); ``ConfigError`` in one line for text that is not
    a JSON list of lists of names (the names are ``Config``'s to check)."""
    if not text.strip():
        return ()
    try:
        data = json.loads(text)
    except json.JSONDecodeError as error:
        raise ConfigError(
            f"{key} must be JSON, a list of lists of food kinds, got {text!r} ({error.msg})"
        ) from None
    if not isinstance(data, list) or not all(isinstance(group, list) for group in data):
        raise ConfigError(f"{key} must be a JSON list of lists of food kinds, got {text!r}")
    return tuple(tuple(group) for group in data)


def _validate_formation(c: Config) -> None:
    if c.formation not in FORMATIONS:
        raise ConfigError(f"formation must be one of {', '.join(FORMATIONS)}, got {c.formation!r}")
    if c.formation == "lattice":
        side = math.isqrt(c.n_robots)
        if side * side != c.n_robots:
            raise ConfigError(
                f"formation lattice needs a square number of robots, got n_robots = {c.n_robots}"
            )
        reach = 1000.0 * (side - 1 - (side // 2 - (0.5 if side % 2 == 0 else 0.0))) + c.robot_radius
        if reach > c.arena_half:
            raise ConfigError(
                f"formation lattice puts {c.n_robots} robots 1 m apart out to {reach:g} mm from the centre, "
                f"beyond arena_half = {c.arena_half:g}"
            )
    if c.formation == "two_robots" and (c.n_robots != 2 or c.chain_trials != 1):
        raise ConfigError(
            "formation two_robots needs n_robots = 2 and chain_trials = 1 (the authors' code is undefined "
            f"beyond a chain's first trial), got n_robots = {c.n_robots}, chain_trials = {c.chain_trials}"
        )
    needs = {"nest": ("nest",), "localised": ("nest", "food")}.get(c.formation, ())
    for k, entry in enumerate(entry for row in c.arena_layout for entry in row):
        for kind in needs:
            if not any(piece.kind == kind and piece.shape == "disc" for piece in entry):
                raise ConfigError(
                    f"formation {c.formation} starts robots around a {kind} disc, but arena entry {k} has "
                    f"no {kind} disc (the authors refuse it too: localised in arenas 1 and 4, nest in 4)"
                )


DEFAULT = Config()
"""The model of docs/model.md, under its default profile."""


def default_config(profile: str) -> Config:
    """The model's default configuration (the 2023 primitives' world) under ``profile`` (``paper`` or
    ``clean``, docs/model.md); a task's world is ``swarm_sim.tasks.TaskSpec.config``."""
    return replace(DEFAULT, profile=profile)


def config_from_dict(data: object) -> Config:
    """The configuration ``Config.as_dict`` wrote (a JSON object: gaps as a list); ``ConfigError`` naming an
    unknown parameter or a bad value."""
    if not isinstance(data, dict):
        raise ConfigError(f"a configuration must be an object of parameters, got {data!r}")
    known = [f.name for f in fields(Config)]
    for name in data:
        if name not in known:
            raise ConfigError(f"unknown model parameter {name!r}; expected among {', '.join(known)}")
    values: dict[str, Any] = dict(data)
    if isinstance(values.get("gaps"), list):
        values["gaps"] = tuple(values["gaps"])
    if isinstance(values.get("fault_kinds"), list):
        values["fault_kinds"] = tuple(values["fault_kinds"])
    if isinstance(values.get("fault_robots"), list):
        values["fault_robots"] = tuple(tuple(p) if isinstance(p, list) else p for p in values["fault_robots"])
    if isinstance(values.get("carries"), list):
        values["carries"] = tuple(tuple(g) if isinstance(g, list) else g for g in values["carries"])
    if "layout" in values:
        values["layout"] = layout_from_json(values["layout"])
    return Config(**values)
