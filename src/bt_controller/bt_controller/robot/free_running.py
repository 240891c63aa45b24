"""A footbot controller on its own clock: ticks at its own rate against the latest sensing, as on a robot.

The lockstep controller (``bt_controller.robot.controller``) answers sensing step N only once both readings of
step N are in, and expects the steps in order: exact against the simulator, but one lost reading would stop
it. This one is driven by two calls from outside, each with the time ``now`` in seconds on the caller's clock
(the node's: simulated under ``use_sim_time``, else wall time):

- ``offer_ground`` / ``offer_range_and_bearing``: a sensing step's two readings, in any order, as they arrive.
  Once both readings of a step ``s`` are in and ``s`` is newer than the newest step used, the step is *used*:
  sensed into the estimate window as the model keeps it (one sample per sensing step, the window of the
  perception parameters). The policy for what does not come as sent:

  - **lost**: steps skipped between two used steps (a reading of either kind missing) are counted and never
    waited for; a half step older than the newest used one is dropped;
  - **late**: a reading of a step older than the newest used one is dropped (its sample would enter the window
    out of order, and a newer state is already in it);
  - **duplicated**: a reading of a step already used, or a second reading of the same kind for a step not yet
    complete (the first is kept), is dropped.

- ``tick``: the timer's tick. When a step was used within ``sensing_timeout`` seconds the smoothed values are
  refreshed from the window, the tree is ticked once with the reference interpreter on the blackboard of the
  newest used step, and the motors follow (``motors.motors_after_tick``). Otherwise the sensing has *timed
  out*: the tree is not ticked (its memory is kept for when the readings come back) and the motors stop; the
  outcome says so, and the node warns and reports it on ``/diagnostics``. Before the first reading the timeout
  counts from the controller's start (``now`` None: from the first time it is given, e.g. once a simulated
  clock has started).

No ROS here: ``bt_controller.nodes.footbot_controller`` (``timing:=free``) calls it from its subscriptions and
its timer.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, replace

import numpy as np

from bt_controller.interpreters.network import Network, NetworkRobot
from bt_controller.interpreters.semantics import ReferenceRobot
from bt_controller.language.tree import Node
from bt_controller.language.vocabulary import ACTION_WHEELS, STOP
from bt_controller.model_settings import PerceptionParams
from bt_controller.robot.motors import motors_after_tick, running_action
from bt_controller.robot.perception import Readings, RobotView


@dataclass
class SensingCounts:
    """What became of the sensing steps offered so far."""

    used: int = 0
    """Steps sensed into the estimate window."""
    lost: int = 0
    """Steps skipped between two used steps, or dropped half complete."""
    late: int = 0
    """Readings of a step older than the newest used one, dropped."""
    duplicated: int = 0
    """Readings of a step already used, or a second reading of one kind for a step, dropped."""


@dataclass(frozen=True)
class FreeTick:
    """What one timer tick did."""

    tick: int
    """The tree's tick number (counting only ticks run), or -1 when the sensing timed out."""
    status: int
    """The tree's status (-1 when not ticked)."""
    started: int
    """The action the tick started, or -1."""
    condition_ticks: int
    action: int
    """The motors from now on (``STOP`` after a timeout)."""
    wheels: tuple[int, int]
    broadcast: tuple[float, ...]
    """The values the robot broadcasts per region (nest, food, food2, food3) (mm)."""
    smoothed: tuple[float, ...]
    step: int
    """The newest sensing step used (0: none yet)."""
    timed_out: bool
    """Whether no step was used within the timeout: the robot is stopped and the tree not ticked (before the
    first reading, within the timeout, it is stopped too, without a timeout)."""
    silence: float
    """Seconds since the newest step was used (since the start when none was)."""


_Ground = tuple[tuple[bool, ...], tuple[bool, ...] | None]
"""A ground reading and where the robot really stands (None: where it reads)."""


class FreeRunningController:
    """One footbot's perception and tree, ticked on its own clock (see the module for the policy)."""

    def __init__(
        self,
        tree: Node | Network,
        tree_key: int,
        perception: PerceptionParams,
        sensing_timeout: float,
        now: float | None,
    ) -> None:
        if not sensing_timeout > 0:
            raise ValueError(f"sensing_timeout must be positive, got {sensing_timeout!r}")
        self.view = RobotView(perception)
        self.robot: ReferenceRobot | NetworkRobot
        if isinstance(tree, Network):
            self.robot = NetworkRobot(tree)
        else:
            self.robot = ReferenceRobot(tree, tree_key, perception.profile)
        self.sensing_timeout = float(sensing_timeout)
        self.counts = SensingCounts()
        self.action = STOP
        self.resumed = -1
        self.newest = 0
        self.last_used: float | None = None if now is None else float(now)
        """When the newest step was used (the start before any); None: not yet known."""
        self._ground: dict[int, _Ground] = {}
        self._rab: dict[int, Readings] = {}

    def offer_ground(
        self, step: int, ground: Sequence[bool], now: float, footing: Sequence[bool] | None = None
    ) -> None:
        """The ground reading of sensing step ``step`` (per region: nest, food, food2, food3), received at
        ``now``, with where the robot really stands when the sensor is faulty (``Readings.footing``)."""
        if self._stale(step) or self._duplicate(step, self._ground):
            return
        for name, given in (("ground reading", ground), ("footing", footing)):
            if given is not None and len(given) != self.view.regions:
                raise ValueError(f"a {name} of {len(given)} regions, expected {self.view.regions}")
        self._ground[step] = (
            tuple(bool(g) for g in ground),
            None if footing is None else tuple(bool(f) for f in footing),
        )
        self._use_complete(now)

    def offer_range_and_bearing(self, step: int, readings: Readings, now: float) -> None:
        """The range-and-bearing readings of sensing step ``step`` (``readings``' ground fields unused)."""
        if self._stale(step) or self._duplicate(step, self._rab):
            return
        self._rab[step] = readings
        self._use_complete(now)

    def _stale(self, step: int) -> bool:
        if step == self.newest:
            self.counts.duplicated += 1
            return True
        if step < self.newest:
            self.counts.late += 1
            return True
        return False

    def _duplicate(self, step: int, pending: dict[int, _Ground] | dict[int, Readings]) -> bool:
        if step in pending:
            self.counts.duplicated += 1
            return True
        return False

    def _use_complete(self, now: float) -> None:
        complete = sorted(set(self._ground) & set(self._rab))
        if not complete:
            return
        step = complete[-1]
        rab = self._rab[step]
        ground, footing = self._ground[step]
        standing = None if footing is None else np.array(footing, dtype=np.bool_)
        self.view.sense(replace(rab, ground=np.array(ground, dtype=np.bool_), footing=standing))
        self.counts.lost += step - self.newest - 1
        self.counts.used += 1
        self.newest = step
        self.last_used = float(now)
        for pending in (self._ground, self._rab):
            for old in [s for s in pending if s <= step]:
                del pending[old]

    def silence(self, now: float) -> float:
        """Seconds since the newest step was used (since the start when none was) at ``now``."""
        if self.last_used is None:  # the clock was not known at the start: it starts now
            self.last_used = float(now)
        return float(now) - self.last_used

    def timed_out(self, now: float) -> bool:
        """Whether no step was used within the timeout before ``now``."""
        return self.silence(now) > self.sensing_timeout

    def tick(self, now: float) -> FreeTick:
        """The timer's tick at ``now``: tick the tree on the latest sensing, or stop after a timeout."""
        silence = self.silence(now)
        timed_out = silence > self.sensing_timeout
        if timed_out or self.view.latest is None:  # nothing sensed yet: stopped too, not yet timed out
            self.action = STOP  # the tree's memory, and the action it left running, wait for the readings
            return FreeTick(
                -1,
                -1,
                -1,
                0,
                STOP,
                ACTION_WHEELS[STOP],
                tuple(float(v) for v in self.view.broadcast()),
                tuple(float(v) for v in self.view.smoothed()),
                self.newest,
                timed_out,
                silence,
            )
        self.view.refresh()
        number = self.robot.tick_index
        before = self.robot.counts[0]
        status, started = self.robot.step(self.view.blackboard())
        self.action = motors_after_tick(status, started, self.resumed)
        self.resumed = running_action(status, started)
        return FreeTick(
            number,
            status,
            started,
            int(self.robot.counts[0] - before),
            self.action,
            ACTION_WHEELS[self.action],
            tuple(float(v) for v in self.view.broadcast()),
            tuple(float(v) for v in self.view.smoothed()),
            self.newest,
            False,
            silence,
        )


def empty_readings(regions: int = 2) -> Readings:
    """Readings with nobody heard (the range-and-bearing arrays empty) and no region under the robot, in a
    world of ``regions`` regions."""
    return Readings(
        ground=np.zeros(regions, dtype=np.bool_),
        senders=np.zeros(0, dtype=np.int64),
        ranges=np.zeros(0, dtype=np.float64),
        bearings=np.zeros(0, dtype=np.float64),
        values=np.zeros((0, regions), dtype=np.float64),
    )
