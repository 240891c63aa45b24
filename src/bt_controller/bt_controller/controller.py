"""A footbot's onboard software, one sensing step at a time: perception, then at each tick the behaviour tree.

This is the core of the footbot controller node (``bt_controller.nodes.footbot_controller``), kept free of ROS
so that it can be tested, and checked against the reference road, without a graph. It ticks the tree with the
reference interpreter, the readable definition of a tick.
"""

from __future__ import annotations

from dataclasses import dataclass

from bt_controller.perception import PerceptionParams, Readings, RobotView
from bt_controller.semantics import ReferenceRobot
from bt_controller.tree import Node
from bt_controller.validate import integer
from bt_controller.vocabulary import ACTION_WHEELS, RUNNING, STOP


@dataclass(frozen=True)
class Schedule:
    """When a robot ticks: after reading step ``settle_steps - 1``, then every ``steps_per_tick`` steps,
    ``ticks`` times in all."""

    settle_steps: int = 16
    steps_per_tick: int = 4
    ticks: int = 40

    def __post_init__(self) -> None:
        for name in ("settle_steps", "steps_per_tick", "ticks"):
            integer(getattr(self, name), name, 1)

    @property
    def last_step(self) -> int:
        """The trial's last sensing step."""
        return self.settle_steps + self.ticks * self.steps_per_tick - 1

    def tick_at(self, step: int) -> int:
        """The tick run after reading ``step``, or -1 when the robot does not tick then."""
        since_first = step - (self.settle_steps - 1)
        if since_first < 0 or since_first % self.steps_per_tick:
            return -1
        tick = since_first // self.steps_per_tick
        return tick if tick < self.ticks else -1


@dataclass(frozen=True)
class TickOutcome:
    """What one tick did."""

    tick: int
    status: int
    started: int
    """The action this tick started, or -1."""
    condition_ticks: int
    """Condition nodes ticked during this tick."""


@dataclass(frozen=True)
class StepOutcome:
    """A robot's answer to one sensing step."""

    step: int
    action: int
    """The action driving the wheels until the next tick (``STOP`` when the last tick left none running)."""
    wheels: tuple[int, int]
    broadcast: tuple[float, float]
    smoothed: tuple[float, float, float]
    tick: TickOutcome | None
    """The tick run after this step, if any."""


class FootbotController:
    """One footbot's perception and behaviour tree across trials."""

    def __init__(self) -> None:
        self.tree: Node | None = None
        self.schedule = Schedule()
        self.view: RobotView | None = None
        self.robot: ReferenceRobot | None = None
        self.action = STOP
        self.next_step = 0

    def load(self, tree: Node) -> None:
        """Run ``tree`` from the next trial on."""
        self.tree = tree
        self.view = None
        self.robot = None

    def start_trial(self, tree_key: int, schedule: Schedule, perception: PerceptionParams) -> None:
        """Reset for a new trial: fresh tree memory and counts, an empty smoothing window."""
        if self.tree is None:
            raise RuntimeError("no tree is loaded: call load_tree first")
        self.schedule = schedule
        self.view = RobotView(perception)
        self.robot = ReferenceRobot(self.tree, tree_key)
        self.action = STOP
        self.next_step = 0

    @property
    def in_trial(self) -> bool:
        """Whether a trial is under way (started and its last step not yet answered)."""
        return self.view is not None and self.next_step <= self.schedule.last_step

    def on_step(self, step: int, readings: Readings) -> StepOutcome:
        """Take the readings of sensing step ``step`` (steps come in order from 0) and answer it."""
        if self.view is None or self.robot is None:
            raise RuntimeError("no trial is under way: call start_trial first")
        if step != self.next_step:
            raise ValueError(f"expected the readings of step {self.next_step}, got step {step}")
        self.view.update(readings)
        tick = None
        tick_index = self.schedule.tick_at(step)
        if tick_index >= 0:
            conditions_before = self.robot.counts[0]
            status, started = self.robot.step(self.view.blackboard())
            self.action = started if status == RUNNING else STOP
            tick = TickOutcome(tick_index, status, started, self.robot.counts[0] - conditions_before)
        self.next_step = step + 1
        return StepOutcome(
            step=step,
            action=self.action,
            wheels=ACTION_WHEELS[self.action],
            broadcast=self.view.broadcast(),
            smoothed=self.view.smoothed(),
            tick=tick,
        )
