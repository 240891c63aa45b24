"""A footbot's perception: what its onboard software makes of its own readings, step by step.

From one sensing step's readings (the ground sensor and the range-and-bearing messages it received) a robot
computes its raw nest and food distance estimates (hop gradients through its neighbours' broadcasts) and its
neighbourhood density, keeps the last ``window`` samples for the smoothed values, and fills the blackboard its
behaviour tree reads (``shared/design/model.md``, "Messages and estimates" and "Blackboard").

This is robot-side software, so it lives with the controller; the simulator's batch kernels call the same
``njit`` functions inline, and the controller node and the reference road call them from Python, so both roads
compute every number with the same operations in the same order. Arguments ``p`` are any named tuple with the
fields of ``PerceptionParams`` (``PerceptionSettings``; ``swarm_sim.config.Params`` has them all).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import NamedTuple, Protocol

import numba
import numpy as np


class PerceptionParams(NamedTuple):
    """The parameters of a robot's perception, with the model's defaults."""

    window: int = 7
    """Raw samples averaged into a smoothed value (paper: seven)."""
    estimate_cap: float = 5000.0
    """Largest nest/food distance estimate; also the estimate when nothing was heard (mm)."""
    density_range: float = 170.0
    """A neighbour at this range adds 1 to the density sum: two touching footbots (mm)."""
    density_divisor: float = 6.0
    """The density sum is divided by this."""


class PerceptionSettings(Protocol):
    """What perception reads of its parameters: ``PerceptionParams`` or any named tuple with its fields."""

    @property
    def window(self) -> int: ...
    @property
    def estimate_cap(self) -> float: ...
    @property
    def density_range(self) -> float: ...
    @property
    def density_divisor(self) -> float: ...


@numba.njit(cache=True)
def estimate(
    in_nest: bool,
    on_food: bool,
    count: int,
    ranges: np.ndarray,
    nest_values: np.ndarray,
    food_values: np.ndarray,
    p: PerceptionSettings,
) -> tuple:
    """A robot's raw estimates from one step's readings.

    Returns ``(nest, food, density, nest_source, food_source, nearest)``: the sources are positions in the
    readings (-1 for none) of the message that gave the minimum nest / food estimate (first on ties; none
    inside the region or when the estimate is capped) and of the nearest sender (first on ties).
    """
    nest = 0.0
    nest_source = -1
    if not in_nest:
        nest = p.estimate_cap
        for k in range(count):
            candidate = nest_values[k] + ranges[k]
            if candidate < nest:
                nest = candidate
                nest_source = k
    food = 0.0
    food_source = -1
    if not on_food:
        food = p.estimate_cap
        for k in range(count):
            candidate = food_values[k] + ranges[k]
            if candidate < food:
                food = candidate
                food_source = k
    total = 0.0
    nearest = -1
    for k in range(count):
        q = p.density_range / ranges[k]
        total += q * q
        if nearest < 0 or ranges[k] < ranges[nearest]:
            nearest = k
    return nest, food, total / p.density_divisor, nest_source, food_source, nearest


@numba.njit(cache=True)
def push_sample(window: np.ndarray, count: int, nest: float, food: float, density: float) -> int:
    """Store one raw sample (nest, food, density) in a ring ``window`` (w x 3) holding ``count`` samples so
    far; returns the new count."""
    slot = count % window.shape[0]
    window[slot, 0] = nest
    window[slot, 1] = food
    window[slot, 2] = density
    return count + 1


@numba.njit(cache=True)
def smoothed(window: np.ndarray, count: int) -> tuple:
    """The mean (nest, food, density) of the last ``min(count, w)`` samples, summed oldest first."""
    w = window.shape[0]
    m = min(count, w)
    nest = 0.0
    food = 0.0
    density = 0.0
    for k in range(count - m, count):
        slot = k % w
        nest += window[slot, 0]
        food += window[slot, 1]
        density += window[slot, 2]
    return nest / m, food / m, density / m


@numba.njit(cache=True)
def is_left(b: float) -> bool:
    """A bearing in [0, pi) is on the left (NaN, meaning no bearing, is on neither side)."""
    return 0.0 <= b < math.pi


@numba.njit(cache=True)
def is_right(b: float) -> bool:
    """A bearing in (-pi, 0) is on the right."""
    return -math.pi < b < 0.0


@numba.njit(cache=True)
def blackboard(
    in_nest: bool,
    on_food: bool,
    nest_bearing: float,
    food_bearing: float,
    nearest_bearing: float,
    out: np.ndarray,
) -> None:
    """Fill ``out`` (8 entries, ``vocabulary.CONDITIONS`` order) from the latest step.

    The bearings are those of the sources ``estimate`` returned (NaN for none): a side is true only when
    the source exists and lies on it.
    """
    out[0] = on_food
    out[1] = in_nest
    out[2] = is_left(food_bearing)
    out[3] = is_right(food_bearing)
    out[4] = is_left(nest_bearing)
    out[5] = is_right(nest_bearing)
    out[6] = is_left(nearest_bearing)
    out[7] = is_right(nearest_bearing)


@dataclass(frozen=True)
class Readings:
    """One robot's readings of one sensing step: the ground sensor and the messages it received.

    The message arrays are ordered by sender id: ``senders`` (int), ``ranges`` (mm), ``bearings`` (rad, from
    the receiver's heading), and the senders' broadcast ``nest`` and ``food`` estimates (mm).
    """

    in_nest: bool
    on_food: bool
    senders: np.ndarray
    ranges: np.ndarray
    bearings: np.ndarray
    nest: np.ndarray
    food: np.ndarray


class RobotView:
    """One robot's estimates, smoothing window and blackboard, updated from its own readings."""

    def __init__(self, p: PerceptionSettings) -> None:
        self.p = p
        self.window = np.zeros((p.window, 3))
        self.samples = 0
        self.nest = math.nan
        self.food = math.nan
        self.density = math.nan
        self.latest: Readings | None = None
        self.sources = (-1, -1, -1)

    def update(self, readings: Readings) -> None:
        """Take one step's readings: raw estimates, the window and the sources of the blackboard."""
        nest, food, density, nest_source, food_source, nearest = estimate(
            readings.in_nest,
            readings.on_food,
            len(readings.senders),
            readings.ranges,
            readings.nest,
            readings.food,
            self.p,
        )
        self.nest, self.food, self.density = nest, food, density
        self.samples = push_sample(self.window, self.samples, nest, food, density)
        self.latest = readings
        self.sources = (nest_source, food_source, nearest)

    def broadcast(self) -> tuple[float, float]:
        """The (nest, food) estimates this robot broadcasts: its latest raw estimates."""
        return self.nest, self.food

    def smoothed(self) -> tuple[float, float, float]:
        """The smoothed (nest, food, density): the mean of the last ``window`` raw samples."""
        return smoothed(self.window, self.samples)

    def blackboard(self) -> np.ndarray:
        """The 8 conditions (``vocabulary.CONDITIONS`` order) from the latest readings."""
        if self.latest is None:
            raise RuntimeError("blackboard before any readings")
        r = self.latest
        nest_b, food_b, near_b = (r.bearings[k] if k >= 0 else math.nan for k in self.sources)
        out = np.zeros(8, dtype=np.bool_)
        blackboard(r.in_nest, r.on_food, nest_b, food_b, near_b, out)
        return out


def warm_up() -> None:
    """Compile (or load from numba's cache) every function of a robot's perception, so that the first step
    of a trial is not slowed down by compilation."""
    view = RobotView(PerceptionParams())
    one = np.ones(1)
    view.update(Readings(False, False, np.zeros(1, dtype=np.int64), one * 300.0, one * 0.5, one, one))
    view.smoothed()
    view.blackboard()
