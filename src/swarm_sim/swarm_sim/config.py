"""Every parameter of the world model, named once, validated once (``shared/design/model.md``).

``Config`` is the frozen, validated object users and nodes see; ``Config.params()`` turns it into ``Params``,
the plain named tuple that compiled kernels receive (numba reads its fields as typed constants).

Units: millimetres, seconds, radians.
"""

from __future__ import annotations

from dataclasses import dataclass, fields
from typing import NamedTuple

from bt_controller.validate import integer, number
from swarm_sim.errors import ConfigError


class Params(NamedTuple):
    """The configuration as compiled kernels see it (all fields float or int)."""

    arena_half: float
    nest_radius: float
    n_robots: int
    robot_radius: float
    start_radius: float
    max_start_attempts: int
    wheel_separation: float
    wheel_speed: float
    gain_low: float
    gain_high: float
    step_dt: float
    steps_per_tick: int
    ticks: int
    settle_steps: int
    message_range: float
    delivery_probability: float
    estimate_cap: float
    density_range: float
    density_divisor: float
    window: int
    collision_iterations: int
    collision_slack: float
    dead_robots: int
    weak_robots: int
    weak_gain: float


_INT_PARAMS = frozenset(
    (
        "n_robots",
        "max_start_attempts",
        "steps_per_tick",
        "ticks",
        "settle_steps",
        "window",
        "collision_iterations",
        "dead_robots",
        "weak_robots",
    )
)


@dataclass(frozen=True)
class Config:
    """The world model's parameters (defaults from ``model.md``).

    Construction validates every value and raises ``ConfigError`` naming the first bad one.
    """

    arena_half: float = 2500.0
    """Half the side of the square arena: walls at +-arena_half (mm)."""
    nest_radius: float = 500.0
    """A robot is in the nest when its centre is within this distance of the arena centre (mm)."""
    gaps: tuple[float, ...] = (500.0, 700.0)
    """Gap between nest and food per arena configuration; trial k uses gaps[k % len(gaps)] (mm)."""
    n_robots: int = 9
    """Footbots in the swarm."""
    robot_radius: float = 85.0
    """Footbot body radius (mm)."""
    start_radius: float = 1000.0
    """Start positions are uniform within this distance of the centre (mm)."""
    max_start_attempts: int = 10_000
    """Rejection-sampling attempts per robot when placing it without overlap."""
    wheel_separation: float = 140.0
    """Distance between the wheels (mm)."""
    wheel_speed: float = 50.0
    """Nominal wheel speed, one unit of an action's wheel setting (mm/s)."""
    gain_low: float = 0.9
    """Lower bound of each wheel's gain, drawn uniformly per robot per trial."""
    gain_high: float = 1.1
    """Upper bound of each wheel's gain."""
    step_dt: float = 0.125
    """Length of one sensing/physics step (s): 8 Hz."""
    steps_per_tick: int = 4
    """Steps between behaviour-tree ticks: 2 Hz."""
    ticks: int = 40
    """Ticks per trial (20 s)."""
    settle_steps: int = 16
    """Sensing steps with the robots standing still before the first tick (2 s)."""
    message_range: float = 1000.0
    """Messages travel only between centres at most this far apart (mm)."""
    delivery_probability: float = 0.95
    """Chance that a message within range arrives (per ordered pair, per step)."""
    estimate_cap: float = 5000.0
    """Largest nest/food distance estimate; also the estimate when nothing was heard (mm)."""
    density_range: float = 170.0
    """A neighbour at this range contributes 1 to the density sum (touching footbots) (mm)."""
    density_divisor: float = 6.0
    """The density sum is divided by this."""
    window: int = 7
    """Raw samples averaged into a smoothed value."""
    collision_iterations: int = 10
    """Passes of pairwise positional correction per step before the fallback (undo the step's move)."""
    collision_slack: float = 1e-6
    """Extra separation added when two robots are pushed apart, so they end strictly apart (mm)."""
    dead_robots: int = 0
    """Damage (``swarm_sim.conditions``): robots 0 .. dead_robots - 1 have both wheel gains 0, so they never
    drive or turn; they still sense, tick their trees and broadcast, and count in the objectives."""
    weak_robots: int = 0
    """Damage: the left wheel of the last weak_robots robots runs at weak_gain times its drawn gain."""
    weak_gain: float = 1.0
    """Factor on the weak robots' left wheel gain, in [0, 1]."""

    def __post_init__(self) -> None:
        _validate(self)

    @property
    def steps(self) -> int:
        """Controlled (moving) steps per trial."""
        return self.ticks * self.steps_per_tick

    def gap(self, trial: int) -> float:
        """The nest-food gap of trial ``trial``'s arena configuration."""
        return self.gaps[trial % len(self.gaps)]

    def params(self) -> Params:
        """The configuration as a ``Params`` named tuple for compiled kernels."""
        return Params._make((int if f in _INT_PARAMS else float)(getattr(self, f)) for f in Params._fields)

    def as_dict(self) -> dict[str, object]:
        """Every parameter by name (gaps as a list), for writing next to results."""
        out: dict[str, object] = {}
        for f in fields(self):
            value = getattr(self, f.name)
            out[f.name] = list(value) if isinstance(value, tuple) else value
        return out


def _number(config: Config, name: str) -> float:
    return number(getattr(config, name), name, error=ConfigError)


def _positive(config: Config, name: str) -> float:
    return number(getattr(config, name), name, positive=True, error=ConfigError)


def _count(config: Config, name: str, minimum: int = 1) -> int:
    return integer(getattr(config, name), name, minimum, error=ConfigError)


def _validate(c: Config) -> None:
    for name in (
        "arena_half",
        "nest_radius",
        "robot_radius",
        "start_radius",
        "wheel_separation",
        "wheel_speed",
        "step_dt",
        "message_range",
        "estimate_cap",
        "density_range",
        "density_divisor",
        "collision_slack",
    ):
        _positive(c, name)
    for name in ("n_robots", "max_start_attempts", "steps_per_tick", "ticks", "window"):
        _count(c, name)
    _count(c, "settle_steps", 1)
    _count(c, "collision_iterations", 0)
    for name in ("dead_robots", "weak_robots"):
        if _count(c, name, 0) > c.n_robots:
            raise ConfigError(f"{name} must be at most n_robots = {c.n_robots}, got {getattr(c, name)}")
    weak_gain = _number(c, "weak_gain")
    if not 0.0 <= weak_gain <= 1.0:
        raise ConfigError(f"weak_gain must be in [0, 1], got {weak_gain}")
    low, high = _positive(c, "gain_low"), _positive(c, "gain_high")
    if low > high:
        raise ConfigError(f"gain_low must not exceed gain_high, got {low} > {high}")
    p = _number(c, "delivery_probability")
    if not 0.0 <= p <= 1.0:
        raise ConfigError(f"delivery_probability must be in [0, 1], got {p}")
    if not isinstance(c.gaps, tuple) or not c.gaps:
        raise ConfigError(f"gaps must be a non-empty tuple of positive numbers, got {c.gaps!r}")
    for k, gap in enumerate(c.gaps):
        number(gap, f"gaps[{k}]", positive=True, error=ConfigError)
    if c.robot_radius >= c.arena_half:
        raise ConfigError(f"robot_radius must be below arena_half, got {c.robot_radius} >= {c.arena_half}")
    if c.start_radius + c.robot_radius > c.arena_half:
        raise ConfigError(
            f"start_radius must keep robots inside the walls: start_radius + robot_radius = "
            f"{c.start_radius + c.robot_radius} > arena_half = {c.arena_half}"
        )
    # Packing n discs of radius r with centres in a disc of radius R is easy while their area is small.
    area_ratio = c.n_robots * c.robot_radius**2 / (c.start_radius + c.robot_radius) ** 2
    if area_ratio > 0.5:
        raise ConfigError(
            f"n_robots = {c.n_robots} robots of radius {c.robot_radius} do not fit easily within "
            f"start_radius = {c.start_radius} (they would cover "
            f"{area_ratio:.0%} of the start disc; at most 50%)"
        )


DEFAULT = Config()
"""The model of ``model.md``."""
