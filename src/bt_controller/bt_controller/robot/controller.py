"""A footbot's onboard software, one control step at a time: the authors' ``ControlStep`` (``docs/model.md``).

This is the core of the footbot controller node (``bt_controller.nodes.footbot_controller``), kept free of ROS
so that it can be tested, and checked against the batch evaluator, without a graph; the reference road and the
in-process lockstep run it too. It follows ``bt_controller.robot.timeline`` step by step: sense, refresh the
smoothed values, tick the tree with the reference interpreter (or a network,
``bt_controller.interpreters.network``, at the same ticks on the same blackboard), broadcast and drive. A
chain's trials follow each other without a reset: the tree's memory, the smoothing window and the estimates
carry over (A1 under ``paper``; under ``clean`` a chain is one trial; the authors' 2026 code empties the
region windows, ``timeline.trials_restart``).
"""

from __future__ import annotations

from dataclasses import dataclass

from bt_controller.interpreters.network import Network, NetworkRobot
from bt_controller.interpreters.semantics import ReferenceRobot
from bt_controller.language.tree import Node
from bt_controller.language.vocabulary import ACTION_WHEELS, STOP
from bt_controller.model_settings import PerceptionParams, Timeline
from bt_controller.robot import timeline
from bt_controller.robot.motors import motors_after_tick, running_action
from bt_controller.robot.perception import Readings, RobotView


@dataclass(frozen=True)
class TickOutcome:
    """What one tick did."""

    tick: int
    """The tick's number within the chain."""
    status: int
    started: int
    """The action this tick started, or -1."""
    condition_ticks: int
    """Condition nodes ticked during this tick."""
    motors: int
    """The motors after the tick: the last action ticked (``motors.motors_after_tick``)."""


@dataclass(frozen=True)
class StepOutcome:
    """A robot's answer to one control step."""

    step: int
    action: int
    """The motors driving the wheels from the next step on (``STOP`` before the first tick)."""
    wheels: tuple[int, int]
    broadcast: tuple[float, ...]
    """The values broadcast at this step per region (nest, food, food2, food3), heard by the others at the
    next (mm)."""
    smoothed: tuple[float, ...]
    """The smoothed values as last refreshed (nest, food, density, food2, food3)."""
    tick: TickOutcome | None
    """The tick run at this step, if any."""
    carrying: tuple[bool, ...] = (False,)
    """Whether the robot carries food of each kind after this step (got_food1-3)."""
    deliveries: tuple[int, ...] = (0,)
    """Its deliveries of each kind in the trial so far (at a trial's last step: the trial's, before they are
    cleared)."""


class FootbotController:
    """One footbot's perception and behaviour tree (or network) across the steps of a chain."""

    def __init__(self) -> None:
        self.tree: Node | Network | None = None
        self.timeline = Timeline()
        self.view: RobotView | None = None
        self.robot: ReferenceRobot | NetworkRobot | None = None
        self.action = STOP
        self.resumed = -1
        self.tree_key = 0
        self._swap: tuple[int, Node | Network] | None = None
        """A tree to swap in at a step of the chain under way (``swap_at``)."""
        self.next_step = 1
        self.last_step = 0

    def load(self, tree: Node | Network) -> None:
        """Run ``tree`` (a tree or a network) from the next chain on."""
        self.tree = tree
        self.view = None
        self.robot = None

    def start_chain(self, tree_key: int, line: Timeline, perception: PerceptionParams, trials: int) -> None:
        """Start a chain of ``trials`` trials: fresh tree memory, an empty window, the motors at stop."""
        if self.tree is None:
            raise RuntimeError("no tree is loaded: call load_tree first")
        if (
            isinstance(trials, bool)
            or not isinstance(trials, int)
            or not 1 <= trials <= timeline.chain_length(line)
        ):
            raise ValueError(f"a chain has 1 to {timeline.chain_length(line)} trials, got {trials!r}")
        self.timeline = line
        self.view = RobotView(perception)
        self.tree_key = tree_key
        self._swap = None
        self.robot = self._runner(self.tree)
        self.action = STOP
        self.resumed = -1
        self.next_step = 1
        self.last_step = trials * timeline.trial_steps(line)

    def _runner(self, tree: Node | Network) -> ReferenceRobot | NetworkRobot:
        """A fresh interpreter of ``tree`` (empty memory) for the chain under way."""
        if isinstance(tree, Network):
            return NetworkRobot(tree)
        return ReferenceRobot(tree, self.tree_key, self.timeline.profile)

    def swap_at(self, tree: Node | Network, step: int) -> None:
        """Run ``tree`` from step ``step`` of the chain under way on (live adaptation): from that step the new
        tree ticks with fresh memory, its ticks numbered on from the old tree's (the tree stream's draws
        follow the chain's tick), while the perception (smoothing windows, estimates, carrying) carries on
        and the motors keep the last action until the new tree's first tick. ValueError when no chain is
        under way or ``step`` was already answered; a later ``swap_at`` replaces one not yet made."""
        if not self.in_trial:
            raise ValueError("no chain is under way: a tree swapped in at a step needs a running trial")
        if (
            isinstance(step, bool)
            or not isinstance(step, int)
            or not self.next_step <= step <= self.last_step
        ):
            raise ValueError(
                f"cannot swap at step {step!r}: the chain's next step is {self.next_step} and its last "
                f"{self.last_step}"
            )
        self._swap = (step, tree)

    @property
    def in_trial(self) -> bool:
        """Whether a chain is under way (started and its last step not yet answered)."""
        return self.view is not None and self.next_step <= self.last_step

    def on_step(self, step: int, readings: Readings) -> StepOutcome:
        """Take the readings of control step ``step`` (steps come in order from 1) and answer it. At a
        trial's first step only the ground sensor is read, and only at the chain's first step."""
        if self.view is None or self.robot is None:
            raise RuntimeError("no chain is under way: call start_chain first")
        if step != self.next_step:
            raise ValueError(f"expected the readings of step {self.next_step}, got step {step}")
        if self._swap is not None and self._swap[0] == step:
            ticks = self.robot.tick_index
            self.tree, self._swap = self._swap[1], None
            self.robot = self._runner(self.tree)
            self.robot.tick_index = ticks
            self.resumed = -1
        line = self.timeline
        if timeline.senses(line, step):
            self.view.sense(readings)
            if timeline.refreshes(line, step):
                self.view.refresh()
        else:
            self.view.first_step(readings.standing)
        tick = None
        if timeline.ticks_at(line, step):
            conditions_before = self.robot.counts[0]
            number = self.robot.tick_index
            status, started = self.robot.step(self.view.blackboard())
            self.action = motors_after_tick(status, started, self.resumed)
            self.resumed = running_action(status, started)
            tick = TickOutcome(number, status, started, self.robot.counts[0] - conditions_before, self.action)
        if timeline.region_broadcast(line, step):
            broadcast = self.view.region_broadcast(readings.ground)
        else:
            broadcast = self.view.broadcast()
        self.next_step = step + 1
        outcome = StepOutcome(
            step=step,
            action=self.action,
            wheels=ACTION_WHEELS[self.action],
            broadcast=tuple(float(v) for v in broadcast),
            smoothed=tuple(float(v) for v in self.view.smoothed()),
            tick=tick,
            carrying=tuple(bool(c) for c in self.view.carrying),
            deliveries=tuple(int(d) for d in self.view.deliveries),
        )
        if timeline.is_final(line, step):
            self.view.end_trial()
        return outcome
