"""What the simulator hands each robot at a sensing step, and the robot's side that makes sense of it.

``sense_swarm`` produces every robot's ``Readings`` (what the simulator node publishes). ``Readings`` and
``RobotView`` (raw estimates, smoothing window, blackboard) are robot-side software and live in
``bt_controller.robot.perception``; they are re-exported here. The batch kernels inline the same functions
(``swarm_sim.core.world``, section (c)).
"""

from __future__ import annotations

import numpy as np

from bt_controller.robot import Readings
from swarm_sim.core import world
from swarm_sim.model import Params
from swarm_sim.model.faults import GROUND_FAULTS

__all__ = ["sense_swarm"]


def sense_swarm(
    x: np.ndarray,
    y: np.ndarray,
    heading: np.ndarray,
    broadcast: np.ndarray,
    drop_keys: np.ndarray,
    step: int,
    entry: np.ndarray,
    p: Params,
    faults: np.ndarray | None = None,
    bearing_keys: np.ndarray | None = None,
) -> list[Readings]:
    """Every robot's readings at sensing step ``step`` on the regions of ``entry`` (the simulator's side,
    robot by robot); ``broadcast`` (n x regions) is what each robot broadcast at the step before.
    ``faults``: each robot's fault code (``ChainSetup.faults``; None: none), with the robots' ``BEARINGS``
    stream keys (``ChainSetup.bearing_keys``) for noisy bearings; ``broadcast`` is left as it is. With two
    robot types (``p.robot_types``) each odd robot's ground, the messages it receives and those it sends
    have the nest and food kind 1 swapped (``world.swap_ground``, ``swap_received``, ``swap_sent``). A robot
    whose ground sensor is faulty reads the faulty ground (``world.faulty_ground``) and is also told where it
    really stands (``Readings.footing``: the ground after the swap), where it picks up and delivers food. So
    is a robot whose group cannot carry every food kind (``Config.carries``): its footing is the ground after
    the swap with the kinds it cannot carry cleared (``world.clear_uncarried``), so that it senses them but
    never picks them up."""
    n = x.shape[0]
    regions = broadcast.shape[1]
    if faults is None:
        faults = np.zeros(n, dtype=np.int64)
    if bearing_keys is None:
        bearing_keys = np.zeros(n, dtype=np.uint64)
    sent = broadcast.copy()
    world.swap_sent(sent, p)
    world.disrupt(faults, sent)
    counts = np.zeros(n, dtype=np.int64)
    senders = np.zeros((n, n), dtype=np.int64)
    ranges, values = np.zeros((n, n)), np.zeros((n, n, regions))
    world.sense_step(x, y, sent, drop_keys, step, p, counts, senders, ranges, values)
    world.swap_received(counts, values, p)
    world.deafen(faults, counts)
    out = []
    for i in range(n):
        count = counts[i]
        fault, key = int(faults[i]), np.uint64(bearing_keys[i])
        bearings = np.zeros(count)
        for m, j in enumerate(senders[i, :count]):
            seen = world.bearing(x[i], y[i], heading[i], x[j], y[j])
            bearings[m] = world.faulty_bearing(fault, seen, key, step, j, n)
        inside = np.zeros(regions, dtype=np.bool_)
        world.ground(x[i], y[i], entry, inside)
        world.swap_ground(i, p, inside)
        footing = None
        if fault in GROUND_FAULTS or any(not world.can_carry(i, f, p) for f in range(regions - 1)):
            footing = inside.copy()
            world.clear_uncarried(i, p, footing)  # the kinds it cannot carry (none: left as it is)
        world.faulty_ground(fault, inside)
        out.append(
            Readings(
                inside,
                senders[i, :count].copy(),
                ranges[i, :count].copy(),
                bearings,
                values[i, :count].copy(),
                footing,
            )
        )
    return out
