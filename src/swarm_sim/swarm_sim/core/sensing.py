"""What the simulator hands each robot at a sensing step, and the robot's side that makes sense of it.

``sense_swarm`` produces every robot's ``Readings`` (what the simulator node publishes). ``Readings`` and
``RobotView`` (raw estimates, smoothing window, blackboard) are robot-side software and live in
``bt_controller.perception``; they are re-exported here. The batch kernels inline the same functions
(``swarm_sim.core.world``, section (c)).
"""

from __future__ import annotations

import numpy as np

from bt_controller.perception import Readings
from swarm_sim.core import world
from swarm_sim.model import Params

__all__ = ["sense_swarm"]


def sense_swarm(
    x: np.ndarray,
    y: np.ndarray,
    heading: np.ndarray,
    broadcast_nest: np.ndarray,
    broadcast_food: np.ndarray,
    drop_keys: np.ndarray,
    step: int,
    entry: np.ndarray,
    p: Params,
) -> list[Readings]:
    """Every robot's readings at sensing step ``step`` on the regions of ``entry`` (the simulator's side,
    robot by robot)."""
    n = x.shape[0]
    counts = np.zeros(n, dtype=np.int64)
    senders = np.zeros((n, n), dtype=np.int64)
    ranges, nest, food = np.zeros((n, n)), np.zeros((n, n)), np.zeros((n, n))
    world.sense_step(
        x, y, broadcast_nest, broadcast_food, drop_keys, step, p, counts, senders, ranges, nest, food
    )
    out = []
    for i in range(n):
        count = counts[i]
        bearings = np.array(
            [world.bearing(x[i], y[i], heading[i], x[j], y[j]) for j in senders[i, :count]], dtype=np.float64
        )
        in_nest, on_food = world.ground(x[i], y[i], entry)
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
