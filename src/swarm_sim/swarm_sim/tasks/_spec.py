"""The task spec: everything that defines a trial's world and its scoring, as one immutable value.

A task says the arena, its regions, the trials' length and chains, the robots, their communication and motors,
the objectives it is about and the node set its trees are made of. The model's constants (the control step,
perception, contact physics: ``docs/model.md``) and a run's profile are not part of it. ``TaskSpec.config``
gives the world model's ``Config`` for a profile: the one way from a task to what the simulator runs.
Units: millimetres, ticks (2 Hz).
"""

from __future__ import annotations

import difflib
import math
import re
from dataclasses import dataclass, field, replace

from bt_controller.language import ACTIONS, CONDITION_TABLE, CONDITIONS_2024
from swarm_sim.errors import ConfigError
from swarm_sim.model import (
    DEFAULT,
    OBJECTIVES,
    PIECE_SHAPES,
    REGION_KINDS,
    Config,
    Piece,
    carries_to_text,
    layout_to_text,
)
from swarm_sim.model.regions import Layout, check_layout, kinds_needed


class TaskError(ConfigError):
    """A task that cannot be run; the message is one line naming the key, the value and what was expected."""


@dataclass(frozen=True)
class Arena:
    """The arena: a square inside walls."""

    half_size: float = DEFAULT.arena_half
    """Half the side of the free square inside the walls (mm)."""
    trial_entries: int = 1
    """How many arena entries the trials of a block take in turn (1: every trial of a block has the same
    regions, as in the papers; 5: trial k of a block has entry k, as the authors' 2026 arenas 5-9 have)."""


@dataclass(frozen=True)
class Region:
    """A region of the arena that the ground sensor reads: one piece of ground of one kind; a kind with
    several regions is their union (``swarm_sim.model.regions``).

    ``radius`` and ``centre`` hold one value per arena entry (a single value: the same in all). Entries come
    ``Arena.trial_entries`` to a configuration; trials come in blocks of ``Trials.chain_trials``, the blocks
    cycle through the configurations (as the 2023 gaps do: food 1000 mm, then 1200 mm from the centre), and
    trial k of a block takes its configuration's entry k.
    """

    kind: str
    """A kind of ``swarm_sim.model.REGION_KINDS``."""
    shape: str
    """A shape of ``swarm_sim.model.PIECE_SHAPES``: ``disc``, the points closer than ``radius`` to ``centre``;
    ``beyond``, the points at least ``radius`` from ``centre`` (the 2023 food region); ``above``, the points
    with y >= ``radius``; ``below``, the points with y <= -``radius`` (half-planes: centre [0, 0])."""
    radius: tuple[float, ...]
    """The circle's radius (a half-plane's distance from the x axis) in each arena entry (mm)."""
    centre: tuple[tuple[float, float], ...] = ((0.0, 0.0),)
    """The circle's centre in each arena entry (mm; the arena's centre is the origin). A task file may give
    one pair, ``[x, y]``, for the same centre in every entry."""


@dataclass(frozen=True)
class Trials:
    """The trials of one evaluation."""

    ticks: int = DEFAULT.ticks
    """A trial's length in behaviour-tree ticks (2 Hz: 40 ticks are 20 s)."""
    chain_trials: int = DEFAULT.chain_trials
    """Trials per chain (under ``paper`` one simulation with teleports between its trials), and so per block
    of trials sharing an arena configuration."""


@dataclass(frozen=True)
class Robots:
    """The swarm's robots (footbots) and where they start."""

    count: int = DEFAULT.n_robots
    """Robots in the swarm."""
    radius: float = DEFAULT.robot_radius
    """Body radius (mm)."""
    start_half_size: float = DEFAULT.start_half
    """Start positions are uniform in the square [-start_half_size, start_half_size]^2 (mm)."""
    start_attempts: int = DEFAULT.max_start_attempts
    """Tries per robot to find a free start position."""
    formation: str = DEFAULT.formation
    """Where robots start each trial: ``random`` (uniform in the start square), ``lattice``, ``nest``,
    ``localised`` or ``two_robots`` (``swarm_sim.model.config.FORMATIONS``; ``docs/tasks.md``)."""
    types: int = DEFAULT.robot_types
    """1: every robot perceives the regions as they are. 2: the authors' two robot types (their ``generic``
    projects): the odd robots perceive the nest and food kind 1 the other way round, one tree serving both
    (``Config.robot_types``; ``docs/model.md``, "Robot types")."""
    carries: tuple[tuple[str, ...], ...] = DEFAULT.carries
    """Which food kinds each group of robots can pick up: one entry per group, each a list of food kind names
    (``food``, ``food2``, ``food3``; an empty one: robots that carry nothing); robot i is in group
    ``i mod len(carries)``. A robot on a kind it cannot carry senses it but does not pick it up.
    Empty: every robot picks up every kind (``Config.carries``)."""


@dataclass(frozen=True)
class Communication:
    """Range-and-bearing messages."""

    range: float = DEFAULT.message_range
    """Messages travel only between centres at most this far apart (mm)."""
    delivery_probability: float = DEFAULT.delivery_probability
    """Chance that a message within range and not occluded arrives (per ordered pair, per step)."""
    occlusion: bool = DEFAULT.occlusion
    """Whether a third robot's body between two robots blocks their messages."""


@dataclass(frozen=True)
class Motors:
    """The differential drive."""

    wheel_speed: float = DEFAULT.wheel_speed
    """Nominal wheel speed, one unit of an action's wheel setting (mm/s)."""
    wheel_separation: float = DEFAULT.wheel_separation
    """Distance between the wheels (mm)."""
    gain_low: float = DEFAULT.gain_low
    """Each wheel's gain is gain_low + gain_step * U{0 .. gain_levels - 1}, drawn once per chain."""
    gain_step: float = DEFAULT.gain_step
    """Step between the possible wheel gains."""
    gain_levels: int = DEFAULT.gain_levels
    """Number of possible wheel gains."""


@dataclass(frozen=True)
class Scoring:
    """How the ``foraging_biased`` objective weighs the food kinds (the authors' 2026 bias and penalty)."""

    preferred_food: int = DEFAULT.preferred_food
    """The preferred food kind, 1-3 (0: none, and ``foraging_biased`` is ``foraging``)."""
    other_food_weight: float = DEFAULT.other_food_weight
    """What a delivery of another kind counts (the authors' penalty: 0.5 in their arena-9 runs)."""


@dataclass(frozen=True)
class Nodes:
    """The node set trees of the task are made of (composites are always available)."""

    conditions: tuple[str, ...] = CONDITIONS_2024
    """Condition nodes, by name (``bt_controller.language.vocabulary.CONDITION_TABLE``); by default the 2024
    nine."""
    actions: tuple[str, ...] = ACTIONS
    """Action nodes, by name (``bt_controller.language.vocabulary.ACTIONS``)."""


def _default_regions() -> tuple[Region, ...]:
    nest = DEFAULT.nest_radius
    return (
        Region("nest", "disc", (nest,)),
        Region("food", "beyond", tuple(nest + gap for gap in DEFAULT.gaps)),
    )


@dataclass(frozen=True)
class TaskSpec:
    """A task: one trial's world and its scoring (see the module's docstring; ``docs/tasks.md``)."""

    name: str
    """The task's name (a registered name, or one of the user's own)."""
    description: str = ""
    """One or two sentences for people."""
    authors_code: int = DEFAULT.authors_code
    """Which of the authors' code versions the ``paper`` profile reproduces on this task: 2024 (the papers')
    or 2026 (their commit 1cd2358: estimates start afresh at every trial; ``docs/model.md``)."""
    arena: Arena = field(default_factory=Arena)
    regions: tuple[Region, ...] = field(default_factory=_default_regions)
    trials: Trials = field(default_factory=Trials)
    robots: Robots = field(default_factory=Robots)
    communication: Communication = field(default_factory=Communication)
    motors: Motors = field(default_factory=Motors)
    objectives: tuple[str, ...] = ()
    """The objectives the task is about: every run of it shows them (grids, summary, figures) and GP_fnd
    evolves them by default. Every trial scores every objective of the table all the same."""
    scoring: Scoring = field(default_factory=Scoring)
    nodes: Nodes = field(default_factory=Nodes)

    def __post_init__(self) -> None:
        check(self)

    def region(self, kind: str) -> Region | None:
        """The task's region of ``kind``, or None."""
        return next((r for r in self.regions if r.kind == kind), None)

    @property
    def arena_entries(self) -> int:
        """How many arena entries the task's regions go through."""
        return max(max(len(r.radius), len(r.centre)) for r in self.regions)

    @property
    def arena_configurations(self) -> int:
        """How many arena configurations the task's regions go through."""
        return self.arena_entries // self.arena.trial_entries

    @property
    def layout(self) -> Layout:
        """The regions of every arena entry as the world model's layout (``swarm_sim.model.regions``)."""
        per, count = self.arena.trial_entries, self.arena_entries

        def piece(region: Region, entry: int) -> Piece:
            x, y = _cycle(region.centre, count)[entry]
            return Piece(region.kind, region.shape, x, y, _cycle(region.radius, count)[entry])

        return tuple(
            tuple(tuple(piece(r, c * per + k) for r in self.regions) for k in range(per))
            for c in range(self.arena_configurations)
        )

    @property
    def concentric(self) -> bool:
        """Whether the regions are the papers' arena: one nest disc of one radius at the centre and one food
        region beyond a circle at the centre, by block of trials (``Config.nest_radius`` and ``gaps``)."""
        nest, food = self.region("nest"), self.region("food")
        return (
            len(self.regions) == 2
            and self.arena.trial_entries == 1
            and nest is not None
            and food is not None
            and (nest.shape, food.shape) == ("disc", "beyond")
            and len(nest.radius) == 1
            and set(nest.centre) | set(food.centre) == {(0.0, 0.0)}
        )

    @property
    def trial_seconds(self) -> float:
        """A trial's length in simulated seconds (its ticks at the model's control rate)."""
        world = self.config()
        return world.ticks * world.steps_per_tick * world.step_dt

    def config(self, profile: str | None = None) -> Config:
        """The world model's configuration for this task under ``profile`` (None: the model's default). The
        papers' arena is given as ``nest_radius`` and ``gaps`` (as the model's own default), any other as a
        ``layout``."""
        nest, food = self.region("nest"), self.region("food")
        assert nest is not None and food is not None  # check() requires both
        if self.concentric:
            nest_radius = nest.radius[0]
            gaps = tuple(radius - nest_radius for radius in _cycle(food.radius, self.arena_configurations))
            layout: Layout = ()
        else:
            nest_radius, gaps, layout = DEFAULT.nest_radius, DEFAULT.gaps, self.layout
        return replace(
            DEFAULT,
            profile=DEFAULT.profile if profile is None else profile,
            arena_half=self.arena.half_size,
            nest_radius=nest_radius,
            gaps=gaps,
            layout=layout,
            n_robots=self.robots.count,
            robot_radius=self.robots.radius,
            start_half=self.robots.start_half_size,
            max_start_attempts=self.robots.start_attempts,
            formation=self.robots.formation,
            robot_types=self.robots.types,
            carries=self.robots.carries,
            ticks=self.trials.ticks,
            chain_trials=self.trials.chain_trials,
            message_range=self.communication.range,
            delivery_probability=self.communication.delivery_probability,
            occlusion=self.communication.occlusion,
            wheel_speed=self.motors.wheel_speed,
            wheel_separation=self.motors.wheel_separation,
            gain_low=self.motors.gain_low,
            gain_step=self.motors.gain_step,
            gain_levels=self.motors.gain_levels,
            preferred_food=self.scoring.preferred_food,
            other_food_weight=self.scoring.other_food_weight,
            authors_code=self.authors_code,
        )


def _unknown(key: str, what: str, name: object, choices: tuple[str, ...]) -> str:
    close = difflib.get_close_matches(str(name), choices, n=1)
    hint = f" (did you mean {close[0]}?)" if close else ""
    return f"{key}: unknown {what} {name!r}{hint}; expected among {', '.join(choices)}"


def _cycle(values: tuple, n: int) -> tuple:
    return values if len(values) == n else values * n


def check(task: TaskSpec) -> None:
    """Raise ``TaskError`` naming the first thing of ``task`` that cannot be run (values of the right types
    are the file loader's concern; this checks what they mean together)."""
    half = task.arena.half_size
    kinds = [r.kind for r in task.regions]
    if isinstance(task.arena.trial_entries, bool) or task.arena.trial_entries < 1:
        raise TaskError(f"arena.trial_entries must be a positive integer, got {task.arena.trial_entries!r}")
    for k, region in enumerate(task.regions):
        key = f"regions[{k}]"
        if region.kind not in REGION_KINDS:
            raise TaskError(f"{key}.kind must be one of {', '.join(REGION_KINDS)}, got {region.kind!r}")
        if region.shape not in PIECE_SHAPES:
            raise TaskError(f"{key}.shape must be one of {', '.join(PIECE_SHAPES)}, got {region.shape!r}")
        if not region.radius:
            raise TaskError(f"{key}.radius must be one positive number per arena entry, got none")
        if not region.centre:
            raise TaskError(f"{key}.centre must be one [x, y] per arena entry, got none")
        for radius in region.radius:
            if not (math.isfinite(radius) and radius > 0):
                raise TaskError(f"{key}.radius must be positive numbers, got {radius!r}")
            if radius >= half:
                raise TaskError(
                    f"{key}.radius {radius} puts the region's edge outside the arena "
                    f"(arena.half_size {half}): expected below {half}"
                )
        for x, y in region.centre:
            if max(abs(x), abs(y)) >= half:
                raise TaskError(
                    f"{key}.centre [{x:g}, {y:g}] lies outside the arena (arena.half_size {half}): "
                    f"expected both within +-{half:g}"
                )
            if region.shape in ("above", "below") and (x, y) != (0.0, 0.0):
                raise TaskError(
                    f"{key}.centre must be [0, 0] for a half-plane ({region.shape}), got [{x:g}, {y:g}]"
                )
    needed = kinds_needed(kinds)  # the nest and every food kind up to the highest
    for kind in needed:
        if kind not in kinds:
            raise TaskError(
                f"regions: the task has no {kind} region; expected at least one (a nest, and food of every "
                f"kind up to its highest, {needed[-1]})"
            )
    scoring = task.scoring
    if isinstance(scoring.preferred_food, bool) or scoring.preferred_food not in range(len(needed)):
        raise TaskError(
            "scoring.preferred_food must be 0 (none) or a food kind of the task, 1 to "
            f"{len(needed) - 1}, got {scoring.preferred_food!r}"
        )
    if not math.isfinite(scoring.other_food_weight):
        raise TaskError(
            f"scoring.other_food_weight must be a finite number, got {scoring.other_food_weight!r}"
        )
    counts = {n for r in task.regions for n in (len(r.radius), len(r.centre))} - {1}
    if len(counts) > 1:
        raise TaskError(
            "regions: every region with more than one radius or centre must have one per arena entry, the "
            f"same number for all; got {', '.join(str(n) for n in sorted(counts))}"
        )
    if task.arena_entries % task.arena.trial_entries:
        raise TaskError(
            f"regions: {task.arena_entries} arena entries do not make whole configurations of "
            f"arena.trial_entries = {task.arena.trial_entries}: expected a multiple of it"
        )
    try:
        check_layout(task.layout, half, "regions")
    except ConfigError as error:
        raise TaskError(str(error)) from None
    for name in task.objectives:
        if name not in OBJECTIVES:
            raise TaskError(_unknown("objectives", "objective", name, OBJECTIVES))
    if len(set(task.objectives)) != len(task.objectives):
        raise TaskError(f"objectives must be distinct, got {', '.join(task.objectives)}")
    table = {row.name: row for row in CONDITION_TABLE}
    offered = set(kinds) | {"robots"}
    for name in task.nodes.conditions:
        if name not in table:
            raise TaskError(_unknown("nodes.conditions", "condition", name, tuple(table)))
        missing = [kind for kind in table[name].reads if kind not in offered]
        if missing:
            raise TaskError(
                f"nodes.conditions: {name} reads the {missing[0]} region, which the task does not have"
            )
    for name in task.nodes.actions:
        if name not in ACTIONS:
            raise TaskError(_unknown("nodes.actions", "action", name, ACTIONS))
    if not task.nodes.actions:
        raise TaskError("nodes.actions must name at least one action, got none")
    for what, names in (("conditions", task.nodes.conditions), ("actions", task.nodes.actions)):
        if len(set(names)) != len(names):
            raise TaskError(f"nodes.{what} must be distinct, got {', '.join(names)}")
    robots = task.robots
    if robots.start_half_size + robots.radius > half:
        raise TaskError(
            f"robots.start_half_size {robots.start_half_size} lets robots of radius {robots.radius} start "
            f"outside the arena (arena.half_size {half}): expected at most {half - robots.radius}"
        )
    try:
        task.config()
    except TaskError:
        raise
    except ConfigError as error:
        message = re.sub(r"\b[a-z_]+\b", lambda m: _TASK_KEY.get(m.group(0), m.group(0)), str(error))
        raise TaskError(message) from None


_TASK_KEY: dict[str, str] = {
    "arena_half": "arena.half_size",
    "nest_radius": "the nest's radius",
    "n_robots": "robots.count",
    "robot_radius": "robots.radius",
    "start_half": "robots.start_half_size",
    "max_start_attempts": "robots.start_attempts",
    "formation": "robots.formation",
    "robot_types": "robots.types",
    "carries": "robots.carries",
    "ticks": "trials.ticks",
    "chain_trials": "trials.chain_trials",
    "message_range": "communication.range",
    "delivery_probability": "communication.delivery_probability",
    "occlusion": "communication.occlusion",
    "wheel_speed": "motors.wheel_speed",
    "wheel_separation": "motors.wheel_separation",
    "gain_low": "motors.gain_low",
    "gain_step": "motors.gain_step",
    "gain_levels": "motors.gain_levels",
    "preferred_food": "scoring.preferred_food",
    "other_food_weight": "scoring.other_food_weight",
    "authors_code": "authors_code",
}
"""The task key of each ``Config`` field a task sets, for the messages of ``Config``'s own checks."""

TASK_CONFIG_FIELDS: tuple[str, ...] = (*_TASK_KEY, "gaps", "layout")
"""The ``Config`` fields a task sets (the rest are the model's constants, its profile and damage)."""


def world_parameters(config: Config) -> dict[str, object]:
    """The simulator node's parameters that give it the world of ``config`` as far as a task sets it: those
    that differ from the model's default world (so a parameter file can still set the others); a layout as
    its JSON text (the node's ``layout`` parameter), the robot groups' food kinds likewise (``carries``)."""
    texts = {"layout": layout_to_text(config.layout), "carries": carries_to_text(config.carries)}
    return {
        name: texts.get(name, getattr(config, name))
        for name in TASK_CONFIG_FIELDS
        if getattr(config, name) != getattr(DEFAULT, name)
    }
