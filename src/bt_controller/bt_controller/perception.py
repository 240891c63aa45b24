"""A footbot's perception: what its onboard software makes of its own readings, step by step.

From one sensing step's readings (the ground sensor and the range-and-bearing messages it received) a robot
computes its raw nest and food distance estimates (hop gradients through its neighbours' broadcasts) and its
neighbourhood density, keeps the last ``window`` samples for the smoothed values, keeps its carrying flag and
counts its deliveries (``carry``: foraging), and fills the blackboard its behaviour tree reads
(``docs/model.md``, "One step of a robot", "Foraging" and "Blackboard").

This is robot-side software, so it lives with the controller; the simulator's batch kernels call the same
``njit`` functions inline, and the controller node and the reference road call them from Python, so both roads
compute every number with the same operations in the same order. Arguments ``p`` are any named tuple with the
fields of ``PerceptionParams`` (``PerceptionSettings``; ``swarm_sim.model.config.Params`` has them all).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numba
import numpy as np

import bt_controller.lean_numba  # noqa: F401  (numba without scipy and cffi: see there)
from bt_controller.model_settings import PAPER, PerceptionParams, PerceptionSettings
from bt_controller.vocabulary import N_CONDITIONS


@numba.njit(cache=True, error_model="numpy")
def estimate(
    in_nest: bool,
    on_food: bool,
    count: int,
    ranges: np.ndarray,
    nest_values: np.ndarray,
    food_values: np.ndarray,
    p: PerceptionSettings,
) -> tuple:
    """A robot's raw estimates from one step's messages (one per sender, in sender order).

    Returns ``(nest, food, density, nest_source, food_source, nearest)``: the nest estimate is 0 in the nest,
    else the least of the cap and every sender's broadcast value plus its range (``footbot_bt.cpp:281-331``);
    food likewise. The sources are positions in the messages (-1 for none) of the message that gave the
    minimum (first on ties; none inside the region or when nothing beat the cap) and of the nearest sender
    (first on ties).
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
        q = ranges[k] / p.density_range
        total += 1.0 / (math.pi * (q * q))
        if nearest < 0 or ranges[k] < ranges[nearest]:
            nearest = k
    return nest, food, total / p.density_divisor, nest_source, food_source, nearest


@numba.njit(cache=True, error_model="numpy")
def push_sample(window: np.ndarray, count: int, nest: float, food: float, density: float) -> int:
    """Store one raw sample (nest, food, density) in a ring ``window`` (w x 3) holding ``count`` samples so
    far; returns the new count."""
    slot = count % window.shape[0]
    window[slot, 0] = nest
    window[slot, 1] = food
    window[slot, 2] = density
    return count + 1


@numba.njit(cache=True, error_model="numpy")
def smoothed(window: np.ndarray, count: int) -> tuple:
    """The mean (nest, food, density) of the last ``min(count, w)`` samples, summed oldest first (the mean
    over the samples held, ``CBlackBoard.cpp:64-83``)."""
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
    if m == 0:
        return 0.0, 0.0, 0.0
    return nest / m, food / m, density / m


@numba.njit(cache=True, error_model="numpy")
def broadcast_value(smoothed_estimate: float) -> float:
    """What a robot broadcasts for a smoothed estimate: whole centimetres, truncated (the code sends a
    ``short int``, ``footbot_bt.cpp:444-445``), returned in mm."""
    return 10.0 * math.floor(smoothed_estimate / 10.0)


@numba.njit(cache=True, error_model="numpy")
def region_value(inside: bool, p: PerceptionSettings) -> float:
    """The value broadcast at a chain's first step: 0 inside the region, else the cap
    (``footbot_bt.cpp:144-145``)."""
    return 0.0 if inside else p.estimate_cap


@numba.njit(cache=True, error_model="numpy")
def carry(carrying: bool, in_nest: bool, on_food: bool) -> tuple:
    """``(carrying, delivered)`` after a sensing step's ground reading (``footbot_bt.cpp:243-254`` at
    a73e4af): a robot on food carries food (it is unlimited: no item, no pick-up time); a robot in the nest
    that carries delivers it and carries nothing more."""
    carrying = carrying or on_food
    if in_nest and carrying:
        return False, True
    return carrying, False


@numba.njit(cache=True, error_model="numpy")
def start_carrying(carrying: bool, on_food: bool) -> bool:
    """The carrying flag after a trial's first step, which senses nothing but the start pose's ground
    (``footbot_bt.cpp:134-137``, ``CBlackBoard.cpp:124-145`` at a73e4af): set on food; no delivery."""
    return carrying or on_food


@numba.njit(cache=True, error_model="numpy")
def blackboard(
    in_nest: bool,
    on_food: bool,
    nest: float,
    food: float,
    nest_bearing: float,
    food_bearing: float,
    heard: bool,
    nearest_bearing: float,
    got_food: bool,
    p: PerceptionSettings,
    out: np.ndarray,
) -> None:
    """Fill ``out`` (``vocabulary.N_CONDITIONS`` entries, ``vocabulary.CONDITIONS`` order) from the latest
    sensing step; ``got_food`` is the carrying flag after its delivery check (``carry``).

    ``nest``/``food`` are the raw estimates and the bearings those of their sources
    (``footbot_bt.cpp:389-392``: a side holds when 0 < estimate < cap and the bearing is strictly on it). The
    nearest robot heard is left at a bearing >= 0, right below 0 (``footbot_bt.cpp:358-369``); with nobody
    ``heard`` robot_left holds under ``paper`` (the code reads a bearing of 0, A2) and neither under
    ``clean``.
    """
    out[0] = on_food
    out[1] = in_nest
    food_known = 0.0 < food < p.estimate_cap
    nest_known = 0.0 < nest < p.estimate_cap
    out[2] = food_known and food_bearing > 0.0
    out[3] = food_known and food_bearing < 0.0
    out[4] = nest_known and nest_bearing > 0.0
    out[5] = nest_known and nest_bearing < 0.0
    if heard:
        out[6] = nearest_bearing >= 0.0
        out[7] = nearest_bearing < 0.0
    else:
        out[6] = p.profile == PAPER
        out[7] = False
    out[8] = got_food


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
    """One robot's perception across a chain: raw estimates, smoothing window, smoothed values, carrying flag
    and deliveries, blackboard.

    ``sense`` takes a sensing step's readings; ``first_step`` a trial's first step's ground (no sensing);
    ``refresh`` recomputes the smoothed values (the timeline says when); ``broadcast`` is what the robot
    sends; ``end_trial`` clears the carrying flag and the deliveries at a trial's last step
    (``footbot_bt.cpp:579-580`` at a73e4af). Nothing else is reset between the trials of a chain (A1).
    """

    def __init__(self, p: PerceptionSettings) -> None:
        self.p = p
        self.window = np.zeros((p.window, 3))
        self.samples = 0
        self.nest = p.estimate_cap
        self.food = p.estimate_cap
        self.density = 0.0
        self.smooth = (0.0, 0.0, 0.0)
        self.latest: Readings | None = None
        self.sources = (-1, -1, -1)
        self.carrying = False
        self.deliveries = 0

    def sense(self, readings: Readings) -> None:
        """Take one sensing step's readings: raw estimates, the window and the sources of the blackboard."""
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
        self.carrying, delivered = carry(self.carrying, readings.in_nest, readings.on_food)
        self.deliveries += int(delivered)
        self.samples = push_sample(self.window, self.samples, nest, food, density)
        self.latest = readings
        self.sources = (nest_source, food_source, nearest)

    def first_step(self, on_food: bool) -> None:
        """A trial's first step: the start pose's ground sets the carrying flag (``start_carrying``)."""
        self.carrying = bool(start_carrying(self.carrying, on_food))

    def end_trial(self) -> None:
        """A trial's last step, after its tick and its scores: no carrying, no deliveries."""
        self.carrying = False
        self.deliveries = 0

    def refresh(self) -> None:
        """Recompute the smoothed (nest, food, density) from the window."""
        self.smooth = smoothed(self.window, self.samples)

    def smoothed(self) -> tuple[float, float, float]:
        """The smoothed (nest, food, density) as last refreshed."""
        return self.smooth

    def broadcast(self) -> tuple[float, float]:
        """The (nest, food) values this robot broadcasts: its smoothed estimates in whole centimetres (mm)."""
        return broadcast_value(self.smooth[0]), broadcast_value(self.smooth[1])

    def region_broadcast(self, in_nest: bool, on_food: bool) -> tuple[float, float]:
        """The (nest, food) values broadcast at a chain's first step."""
        return region_value(in_nest, self.p), region_value(on_food, self.p)

    def blackboard(self) -> np.ndarray:
        """The 8 conditions (``vocabulary.CONDITIONS`` order) from the latest readings."""
        if self.latest is None:
            raise RuntimeError("blackboard before any readings")
        r = self.latest
        nest_b, food_b, near_b = (r.bearings[k] if k >= 0 else math.nan for k in self.sources)
        out = np.zeros(N_CONDITIONS, dtype=np.bool_)
        blackboard(
            r.in_nest,
            r.on_food,
            self.nest,
            self.food,
            nest_b,
            food_b,
            self.sources[2] >= 0,
            near_b,
            self.carrying,
            self.p,
            out,
        )
        return out


def warm_up() -> None:
    """Compile (or load from numba's cache) every function of a robot's perception, so that the first step
    of a trial is not slowed down by compilation."""
    view = RobotView(PerceptionParams())
    one = np.ones(1)
    view.first_step(True)
    view.sense(Readings(False, False, np.zeros(1, dtype=np.int64), one * 300.0, one * 0.5, one, one))
    view.refresh()
    view.broadcast()
    view.region_broadcast(False, True)
    view.blackboard()
