"""A footbot's perception: what its onboard software makes of its own readings, step by step.

From one sensing step's readings (the ground sensor and the range-and-bearing messages it received) a robot
computes its raw distance estimates of the nest and of each food kind (hop gradients through its neighbours'
broadcasts) and its neighbourhood density, keeps the last ``window`` samples for the smoothed values, keeps a
carrying flag per food kind and counts its deliveries (``carry``: foraging, from where the robot really
stands, which a faulty ground sensor does not change: ``Readings.footing``), and fills the blackboard its
behaviour tree reads (``docs/model.md``, "One step of a robot", "Foraging" and "Blackboard").

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
from bt_controller.language.vocabulary import (
    MAX_FOOD_KINDS,
    N_CONDITIONS,
    NUMBERED_FOOD,
    REGIONS,
    SIDES,
)
from bt_controller.language.vocabulary import (
    region_column as _region_column,
)
from bt_controller.model_settings import CODE_2026, PAPER, PerceptionParams, PerceptionSettings
from bt_controller.robot.timeline import trials_restart

# For the compiled functions: no disk cache of its own (its source is vocabulary's), so the Python methods
# below call vocabulary's function: called from Python, this would be compiled in every process that calls
# it (about 0.2 s of each footbot controller's start).
region_column = numba.njit(inline="always")(_region_column)
DENSITY = SIDES.index("robot")
"""The column of the density in a robot's samples and smoothed values (``vocabulary.region_column``)."""
ROBOT_SIDE = SIDES.index("robot")


@numba.njit(cache=True, error_model="numpy")
def estimate(
    inside: np.ndarray,
    count: int,
    ranges: np.ndarray,
    values: np.ndarray,
    p: PerceptionSettings,
    raw: np.ndarray,
    sources: np.ndarray,
) -> tuple:
    """A robot's raw estimates from one step's messages (one per sender, in sender order), per region.

    ``inside`` (regions, ``vocabulary.REGIONS`` order: nest, food, food2, food3) says where the ground sensor
    reads the robot is; ``values`` (at least count x regions) holds what each sender broadcast per region.
    Region r's estimate, written to ``raw[r]``, is 0 inside it, else the least of the cap and every sender's
    broadcast value plus its range (``footbot_bt.cpp:281-331``); ``sources[r]`` is the position in the
    messages of the one that gave the minimum (first on ties; -1 inside the region or when nothing beat the
    cap). Returns ``(density, nearest)``: the neighbourhood density and the position of the nearest sender
    (first on ties, -1 for none).
    """
    for r in range(inside.shape[0]):
        best = 0.0
        source = -1
        if not inside[r]:
            best = p.estimate_cap
            for k in range(count):
                candidate = values[k, r] + ranges[k]
                if candidate < best:
                    best = candidate
                    source = k
        raw[r] = best
        sources[r] = source
    total = 0.0
    nearest = -1
    for k in range(count):
        q = ranges[k] / p.density_range
        total += 1.0 / (math.pi * (q * q))
        if nearest < 0 or ranges[k] < ranges[nearest]:
            nearest = k
    return total / p.density_divisor, nearest


@numba.njit(cache=True, error_model="numpy")
def push_sample(window: np.ndarray, count: int, raw: np.ndarray, density: float) -> int:
    """Store one raw sample in a ring ``window`` (w x columns: the regions' estimates and the density, in
    ``vocabulary.region_column`` order) holding ``count`` samples so far; returns the new count."""
    slot = count % window.shape[0]
    for r in range(raw.shape[0]):
        window[slot, region_column(r)] = raw[r]
    window[slot, DENSITY] = density
    return count + 1


@numba.njit(cache=True, error_model="numpy")
def smoothed(window: np.ndarray, count: int, fresh: int, out: np.ndarray) -> None:
    """Write into ``out`` the mean of each column of the samples ``window`` holds, summed oldest first (the
    mean over the samples held, ``CBlackBoard.cpp:64-83``): the density's over the last ``min(count, w)`` of
    the ``count`` pushed, the regions' over the last ``min(fresh, w)`` (``fresh``: the samples pushed since
    the region windows were last emptied, at most ``count``). A column with no sample is written 0."""
    w = window.shape[0]
    for c in range(window.shape[1]):
        m = min(count if c == DENSITY else fresh, w)
        total = 0.0
        for k in range(count - m, count):
            total += window[k % w, c]
        out[c] = 0.0 if m == 0 else total / m


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
    """``(carrying, delivered)`` of one food kind after a sensing step's ground reading
    (``footbot_bt.cpp:243-254`` at a73e4af; per kind, ``footbot_bt.cpp:634-661`` at 1cd2358): a robot on
    food carries food (it is unlimited: no item, no pick-up time); a robot in the nest that carries delivers
    it and carries nothing more. A robot can carry every kind at once. ``in_nest`` and ``on_food`` say where
    the robot really is (``Readings.standing``): a faulty ground sensor changes what the robot perceives, not
    the food it picks up or delivers, so the carrying flag (the ``got_food`` conditions) stays true."""
    carrying = carrying or on_food
    if in_nest and carrying:
        return False, True
    return carrying, False


@numba.njit(cache=True, error_model="numpy")
def start_carrying(carrying: bool, on_food: bool) -> bool:
    """The carrying flag of a food kind after a trial's first step, which senses nothing but the start pose's
    ground (``footbot_bt.cpp:134-137``, ``CBlackBoard.cpp:124-145`` at a73e4af): set on food; no delivery."""
    return carrying or on_food


@numba.njit(cache=True, error_model="numpy", inline="always")
def _sides(known: bool, bearing: float) -> tuple:
    return known and bearing > 0.0, known and bearing < 0.0


@numba.njit(cache=True, error_model="numpy")
def blackboard(
    inside: np.ndarray,
    raw: np.ndarray,
    bearings: np.ndarray,
    heard: bool,
    carrying: np.ndarray,
    p: PerceptionSettings,
    out: np.ndarray,
) -> None:
    """Fill ``out`` (``vocabulary.N_CONDITIONS`` entries, ``vocabulary.CONDITIONS`` order) from the latest
    sensing step: ``inside`` and ``raw`` per region (``estimate``), ``bearings`` per side pair
    (``vocabulary.SIDES``: each region's estimate source and the nearest robot heard, NaN for none or not
    needed), ``carrying`` per food kind (after its delivery check, ``carry``).

    A region's side holds when 0 < estimate < cap and its source's bearing is strictly on it
    (``footbot_bt.cpp:389-392``). The nearest robot heard is left at a bearing >= 0, right below 0
    (``footbot_bt.cpp:358-369``); with nobody ``heard`` robot_left holds under ``paper`` (the code reads a
    bearing of 0, A2) and neither under ``clean`` or the authors' 2026 code (``footbot_bt.cpp:752-763`` at
    1cd2358). The unnumbered food conditions read kind 1; a kind the
    world lacks is never on, carried or on a side.
    """
    cap = p.estimate_cap
    out[0] = inside[1]
    out[1] = inside[0]
    out[2], out[3] = _sides(0.0 < raw[1] < cap, bearings[1])
    out[4], out[5] = _sides(0.0 < raw[0] < cap, bearings[0])
    if heard:
        out[6] = bearings[ROBOT_SIDE] >= 0.0
        out[7] = bearings[ROBOT_SIDE] < 0.0
    else:
        out[6] = p.profile == PAPER and p.authors_code != CODE_2026
        out[7] = False
    out[8] = carrying[0]
    for kind in range(1, MAX_FOOD_KINDS + 1):
        at = NUMBERED_FOOD + 4 * (kind - 1)
        if kind < inside.shape[0]:
            out[at] = inside[kind]
            out[at + 1] = carrying[kind - 1]
            out[at + 2], out[at + 3] = _sides(0.0 < raw[kind] < cap, bearings[region_column(kind)])
        else:
            out[at] = out[at + 1] = out[at + 2] = out[at + 3] = False


@dataclass(frozen=True)
class Readings:
    """One robot's readings of one sensing step: the ground sensor and the messages it received.

    ``ground`` (bool, one per region of the world: ``vocabulary.REGIONS`` order, nest first) says which
    regions the ground sensor reads the robot in: what its conditions, estimates and broadcasts perceive. The
    message arrays are ordered by sender id: ``senders`` (int), ``ranges`` (mm), ``bearings`` (rad, from the
    receiver's heading), and ``values`` (messages x regions): the senders' broadcast estimates (mm) per
    region. ``footing`` (same layout), when given, says where the robot really stands, for picking up and
    delivering food (``carry``, ``start_carrying``): the simulator gives it for a robot whose ground sensor is
    faulty (``swarm_sim.model.faults``), so that a false reading neither makes nor destroys food; None: the
    reading is true (``standing`` is ``ground``).
    """

    ground: np.ndarray
    senders: np.ndarray
    ranges: np.ndarray
    bearings: np.ndarray
    values: np.ndarray
    footing: np.ndarray | None = None

    @property
    def standing(self) -> np.ndarray:
        """Where the robot really stands, per region: ``footing`` if given, else the ground reading."""
        return self.ground if self.footing is None else self.footing

    @property
    def in_nest(self) -> bool:
        """Whether the ground sensor reads the nest."""
        return bool(self.ground[0])

    @property
    def on_food(self) -> bool:
        """Whether the ground sensor reads food of kind 1."""
        return bool(self.ground[1])

    @property
    def regions(self) -> int:
        """How many regions the world has (the nest and its food kinds)."""
        return len(self.ground)


class RobotView:
    """One robot's perception across a chain: raw estimates, smoothing window, smoothed values, carrying flags
    and deliveries per food kind, blackboard.

    ``sense`` takes a sensing step's readings; ``first_step`` a trial's first step's ground (no sensing);
    ``refresh`` recomputes the smoothed values (the timeline says when); ``broadcast`` is what the robot
    sends; ``end_trial`` clears the carrying flags and the deliveries at a trial's last step
    (``footbot_bt.cpp:579-580`` at a73e4af), and where ``timeline.trials_restart`` (the authors' 2026 code)
    also empties the region windows. Nothing else is reset between the trials of a chain (A1).
    ``p.regions``: the nest and the world's food kinds (2 to ``len(REGIONS)``).
    """

    def __init__(self, p: PerceptionSettings) -> None:
        regions = p.regions
        if not 2 <= regions <= len(REGIONS):
            raise ValueError(
                f"regions must be 2 to {len(REGIONS)} (the nest and 1-3 food kinds), got {regions}"
            )
        self.p = p
        self.regions = regions
        self.window = np.zeros((p.window, regions + 1))
        self.samples = 0
        self.fresh = 0
        """Samples pushed since the region windows were last emptied (``smoothed``)."""
        self.raw = np.full(regions, p.estimate_cap)
        self.density = 0.0
        self.smooth = np.zeros(regions + 1)
        self.latest: Readings | None = None
        self.sources = np.full(regions, -1, dtype=np.int64)
        self.nearest = -1
        self.carrying = np.zeros(regions - 1, dtype=np.bool_)
        self.deliveries = np.zeros(regions - 1, dtype=np.int64)

    def _check(self, ground: np.ndarray) -> None:
        if len(ground) != self.regions:
            raise ValueError(f"readings for {len(ground)} regions, expected {self.regions}")

    def sense(self, readings: Readings) -> None:
        """Take one sensing step's readings: raw estimates, carrying and deliveries, the window and the
        sources of the blackboard."""
        self._check(readings.ground)
        self.density, self.nearest = estimate(
            readings.ground, len(readings.senders), readings.ranges, readings.values, self.p, self.raw,
            self.sources,
        )  # fmt: skip
        standing = readings.standing  # food is picked up and delivered where the robot is, whatever it reads
        self._check(standing)
        in_nest = bool(standing[0])
        for k in range(self.regions - 1):
            self.carrying[k], delivered = carry(self.carrying[k], in_nest, standing[k + 1])
            self.deliveries[k] += int(delivered)
        self.samples = push_sample(self.window, self.samples, self.raw, self.density)
        self.fresh += 1
        self.latest = readings

    def first_step(self, standing: np.ndarray) -> None:
        """A trial's first step: the ground the robot starts on (``Readings.standing``: where it really is,
        not what a faulty sensor reads) sets the carrying flags (``start_carrying``)."""
        self._check(standing)
        for k in range(self.regions - 1):
            self.carrying[k] = start_carrying(self.carrying[k], standing[k + 1])

    def end_trial(self) -> None:
        """A trial's last step, after its tick and its scores: no carrying, no deliveries; where
        ``timeline.trials_restart``, the region windows emptied too (the density's is kept)."""
        self.carrying[:] = False
        self.deliveries[:] = 0
        if trials_restart(self.p):
            self.fresh = 0

    def refresh(self) -> None:
        """Recompute the smoothed values (``region_column`` order: nest, food, density, food2, food3)."""
        smoothed(self.window, self.samples, self.fresh, self.smooth)

    def smoothed(self) -> np.ndarray:
        """The smoothed values as last refreshed (nest, food, density, then food2 and food3 if any)."""
        return self.smooth

    def broadcast(self) -> np.ndarray:
        """The values this robot broadcasts, per region: its smoothed estimates in whole centimetres (mm)."""
        return np.array([broadcast_value(self.smooth[_region_column(r)]) for r in range(self.regions)])

    def region_broadcast(self, ground: np.ndarray) -> np.ndarray:
        """The values broadcast at a chain's first step, per region."""
        return np.array([region_value(bool(inside), self.p) for inside in ground])

    def blackboard(self) -> np.ndarray:
        """The conditions (``vocabulary.CONDITIONS`` order) from the latest readings."""
        if self.latest is None:
            raise RuntimeError("blackboard before any readings")
        r = self.latest
        bearings = np.full(len(SIDES), math.nan)
        for region in range(self.regions):
            if self.sources[region] >= 0:
                bearings[_region_column(region)] = r.bearings[self.sources[region]]
        if self.nearest >= 0:
            bearings[ROBOT_SIDE] = r.bearings[self.nearest]
        out = np.zeros(N_CONDITIONS, dtype=np.bool_)
        blackboard(r.ground, self.raw, bearings, self.nearest >= 0, self.carrying, self.p, out)
        return out


def warm_up() -> None:
    """Compile (or load from numba's cache) every function of a robot's perception, so that the first step
    of a trial is not slowed down by compilation."""
    view = RobotView(PerceptionParams())
    one = np.ones(1)
    ground = np.array([False, True])
    view.first_step(ground)
    view.sense(Readings(ground, np.zeros(1, dtype=np.int64), one * 300.0, one * 0.5, np.ones((1, 2))))
    view.refresh()
    view.broadcast()
    view.region_broadcast(ground)
    view.blackboard()
