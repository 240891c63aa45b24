"""The virtual-sensor bridge's core, free of ROS: each robot's ground and range-and-bearing readings computed
from the robots' poses as the model senses them (``swarm_sim.core.sense_swarm``).

A lab that tracks its robots (motion capture, or another simulator's poses) gives them the footbots' senses
with it: the ground sensor (in the nest, on the food region of the task's arena), and the range-and-bearing
messages each robot hears, with the model's range, its message loss and the neighbours' broadcast
estimates. The loss is drawn from the chain of ``seed`` and ``trial`` as the simulator draws it, so poses
replayed from a recorded trial give the readings the simulator gave. ``sensor_bridge`` is its ROS node.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from bt_controller.model_settings import chain_of_trial
from bt_controller.robot import Readings
from swarm_sim.core import sense_swarm, setup_chain
from swarm_sim.model import Config

MM = 1000.0
"""Millimetres in a metre: poses come in metres (REP 103), the model senses in millimetres."""


def heading_of(qz: float, qw: float) -> float:
    """The heading (radians, anticlockwise from x) of a rotation about z given as a quaternion's z and w."""
    return 2.0 * math.atan2(qz, qw)


class VirtualSensors:
    """The readings of a swarm of ``config.n_robots`` robots in the arena of trial ``trial`` of ``seed`` (its
    regions, ``Config.arena_entry``, and the chain whose message losses are drawn). Give each robot's pose
    (``set_pose``) and what it broadcasts (``set_broadcast``; the estimate cap until it says otherwise, as
    the world starts), then ``sense`` a step."""

    def __init__(self, config: Config, seed: int = 0, trial: int = 0) -> None:
        self.config = config
        self.p = config.params()
        chain, _ = chain_of_trial(config.timeline, trial)
        setup = setup_chain(seed, chain, config)
        self.entry, _ = config.arena_arrays(trial)
        self.drop_keys = setup.drop_keys
        self.setup = setup
        n = self.p.n_robots
        self.poses = np.full((n, 3), np.nan)
        """Each robot's (x mm, y mm, heading rad); NaN until given."""
        self.broadcast = np.full((n, self.p.regions), self.p.estimate_cap)
        """What each robot broadcasts, per region (nest, food, food2, food3) (mm)."""

    def set_pose(self, robot: int, x_mm: float, y_mm: float, heading: float) -> None:
        """Robot ``robot``'s pose in the arena's frame, millimetres and radians."""
        self.poses[robot] = (x_mm, y_mm, heading)

    def set_pose_in_metres(self, robot: int, x: float, y: float, qz: float, qw: float) -> None:
        """Robot ``robot``'s pose as a ROS pose gives it: metres, and a rotation about z as a quaternion."""
        self.set_pose(robot, x * MM, y * MM, heading_of(qz, qw))

    def set_broadcast(self, robot: int, nest: float, food: float, *other_food: float) -> None:
        """What robot ``robot`` broadcasts to the others from now on: its nest and food estimates, and those
        of the other food kinds the world has (mm)."""
        values = (nest, food, *other_food)
        if len(values) != self.p.regions:
            raise ValueError(
                f"expected {self.p.regions} broadcast values (nest and each food kind), got {len(values)}"
            )
        self.broadcast[robot] = values

    def missing(self) -> list[int]:
        """The robots whose pose was never given."""
        return [int(i) for i in np.flatnonzero(np.isnan(self.poses).any(axis=1))]

    def sense(self, step: int) -> list[Readings]:
        """Every robot's readings at sensing step ``step`` (which, with the seed, draws the losses);
        ``ValueError`` while a robot's pose is missing."""
        missing = self.missing()
        if missing:
            raise ValueError(f"no pose yet of robot {', '.join(map(str, missing))}")
        x, y, heading = (np.ascontiguousarray(self.poses[:, k]) for k in range(3))
        s = self.setup
        return sense_swarm(
            x,
            y,
            heading,
            self.broadcast,
            s.drop_keys,
            step,
            self.entry,
            self.p,
            s.faults,
            s.bearing_keys,
        )


class Delivery:
    """How each robot's readings reach its controller when the link is worse than the model's radio: a pair
    of readings (ground and range-and-bearing of one sensing period) is lost with probability ``loss``, or
    held back a whole number of sensing periods drawn uniformly from 0 to ``delay`` (so it may arrive after a
    newer one: late). The draws come from ``seed``."""

    def __init__(self, loss: float = 0.0, delay: int = 0, seed: int = 0) -> None:
        if not 0.0 <= loss <= 1.0:
            raise ValueError(f"loss must be a probability in [0, 1], got {loss}")
        if delay < 0:
            raise ValueError(f"delay must be a number of sensing periods >= 0, got {delay}")
        self.loss, self.delay = loss, delay
        self.rng = np.random.default_rng(seed)
        self.pending: list[tuple[int, int, Any]] = []  # (due period, order sent, item)
        self.sent = 0
        self.lost = 0

    def send(self, period: int, item: Any) -> None:
        """Send ``item`` at sensing period ``period``: lost, or due at a period from ``period`` on."""
        if self.loss and self.rng.random() < self.loss:
            self.lost += 1
            return
        due = period + (int(self.rng.integers(0, self.delay + 1)) if self.delay else 0)
        self.pending.append((due, self.sent, item))
        self.sent += 1

    def due(self, period: int) -> list[Any]:
        """The items due at or before ``period``, in the order they were sent; they leave the link."""
        ready = [entry for entry in self.pending if entry[0] <= period]
        self.pending = [entry for entry in self.pending if entry[0] > period]
        return [item for _, _, item in sorted(ready, key=lambda entry: entry[1])]

    def clear(self) -> int:
        """Drop every item still held back (a new trial's world makes them stale); return how many."""
        dropped = len(self.pending)
        self.pending = []
        return dropped
