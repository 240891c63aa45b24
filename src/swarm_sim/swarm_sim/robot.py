"""One robot's view of the world from its own readings: what a controller node keeps between steps.

``Readings`` is what the simulator hands one robot at one sensing step (what the simulator node publishes);
``RobotView`` turns successive readings into raw estimates, the smoothing window and the blackboard, with the
compiled functions of ``swarm_sim.world`` that the batch kernels use too.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from swarm_sim import world
from swarm_sim.config import Params


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


def sense_swarm(
    x: np.ndarray,
    y: np.ndarray,
    heading: np.ndarray,
    broadcast_nest: np.ndarray,
    broadcast_food: np.ndarray,
    drop_keys: np.ndarray,
    step: int,
    gap: float,
    p: Params,
) -> list[Readings]:
    """Every robot's readings at sensing step ``step`` (the simulator's side, robot by robot)."""
    n = x.shape[0]
    counts = np.zeros(n, dtype=np.int64)
    senders = np.zeros((n, n), dtype=np.int64)
    ranges, nest, food = np.zeros((n, n)), np.zeros((n, n)), np.zeros((n, n))
    world.sense_step(x, y, broadcast_nest, broadcast_food, drop_keys, step, p, counts, senders, ranges, nest, food)
    out = []
    for i in range(n):
        count = counts[i]
        bearings = np.array(
            [world.bearing(x[i], y[i], heading[i], x[j], y[j]) for j in senders[i, :count]], dtype=np.float64
        )
        in_nest, on_food = world.ground(x[i], y[i], gap, p)
        out.append(
            Readings(
                bool(in_nest),
                bool(on_food),
                senders[i, :count].copy(),
                ranges[i, :count].copy(),
                bearings,
                nest[i, :count].copy(),
                food[i, :count].copy(),
            )
        )
    return out


class RobotView:
    """One robot's estimates, smoothing window and blackboard, updated from its own readings."""

    def __init__(self, p: Params) -> None:
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
        nest, food, density, nest_source, food_source, nearest = world.estimate(
            readings.in_nest,
            readings.on_food,
            len(readings.senders),
            readings.ranges,
            readings.nest,
            readings.food,
            self.p,
        )
        self.nest, self.food, self.density = nest, food, density
        self.samples = world.push_sample(self.window, self.samples, nest, food, density)
        self.latest = readings
        self.sources = (nest_source, food_source, nearest)

    def broadcast(self) -> tuple[float, float]:
        """The (nest, food) estimates this robot broadcasts: its latest raw estimates."""
        return self.nest, self.food

    def smoothed(self) -> tuple[float, float, float]:
        """The smoothed (nest, food, density): the mean of the last ``window`` raw samples."""
        return world.smoothed(self.window, self.samples)

    def blackboard(self) -> np.ndarray:
        """The 8 conditions (``vocabulary.CONDITIONS`` order) from the latest readings."""
        if self.latest is None:
            raise RuntimeError("blackboard before any readings")
        r = self.latest
        nest_b, food_b, near_b = (r.bearings[k] if k >= 0 else math.nan for k in self.sources)
        out = np.zeros(8, dtype=np.bool_)
        world.blackboard(r.in_nest, r.on_food, nest_b, food_b, near_b, out)
        return out
