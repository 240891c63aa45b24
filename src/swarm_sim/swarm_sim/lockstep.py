"""The simulator's side of one trial, advanced one sensing step at a time by the robots' answers.

This is what the simulator node runs: it owns the world (poses, wheel gains, the radio channel, the ground
sensor) and nothing of the robots' minds. After each sensing step it hands every robot its readings and waits
for every robot's answer: the estimates it will broadcast next, its smoothed values, and (when the robots
have just ticked their trees) the action that drives its wheels until the next tick. The objectives are scored
from the robots' smoothed values at the first tick and after the last step, as the reference road does
(``swarm_sim.reference_road``), so the node graph reproduces the batch evaluator exactly.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np

from bt_controller.controller import FootbotController, Schedule
from bt_controller.perception import PerceptionParams
from bt_controller.tree import Node
from bt_controller.vocabulary import ACTION_WHEELS, STOP
from swarm_sim import world
from swarm_sim.config import DEFAULT, Config
from swarm_sim.sensing import Readings, sense_swarm
from swarm_sim.trial_data import TrialRecord, setup_trial


@dataclass(frozen=True)
class RobotAnswer:
    """One robot's answer to one sensing step."""

    action: int
    """The action driving the wheels until the next tick (read only after a tick step; else ignored)."""
    broadcast: tuple[float, float]
    """The (nest, food) raw estimates the robot broadcasts at the next step (mm)."""
    smoothed: tuple[float, float, float]
    """The robot's smoothed (nest, food, density) after this step."""


def action_of_wheels(left: float, right: float) -> int:
    """The action whose wheel setting is (left, right); ValueError for a pair no action produces."""
    try:
        return ACTION_WHEELS.index((left, right))
    except ValueError:
        raise ValueError(
            f"wheels ({left}, {right}) are not a footbot action; expected one of {list(ACTION_WHEELS)}"
        ) from None


class LockstepTrial:
    """Trial ``trial`` of ``seed`` with the world advanced only when every robot has answered."""

    def __init__(self, seed: int, trial: int, config: Config = DEFAULT) -> None:
        self.config = config
        self.p = config.params()
        self.setup = setup_trial(seed, trial, config)
        n = self.p.n_robots
        self.x = self.setup.poses[:, 0].copy()
        self.y = self.setup.poses[:, 1].copy()
        self.heading = self.setup.poses[:, 2].copy()
        self._x_before, self._y_before = np.empty(n), np.empty(n)
        self.actions = np.full(n, STOP, dtype=np.int64)
        self.broadcast_nest, self.broadcast_food = np.empty(n), np.empty(n)
        for i in range(n):
            in_nest, on_food = world.ground(self.x[i], self.y[i], self.setup.gap, self.p)
            self.broadcast_nest[i], self.broadcast_food[i] = world.initial_broadcast(in_nest, on_food, self.p)
        self.step = 0
        self.initial: np.ndarray | None = None
        self.final: np.ndarray | None = None
        self._readings = self._sense()

    @property
    def last_step(self) -> int:
        """Index of the trial's last sensing step (settling steps, then the controlled ones)."""
        return self.p.settle_steps + self.p.ticks * self.p.steps_per_tick - 1

    @property
    def done(self) -> bool:
        """Whether the answers to the last step have been taken."""
        return self.final is not None

    def readings(self) -> list[Readings]:
        """Every robot's readings of the current sensing step."""
        return self._readings

    def tick_index(self) -> int:
        """The tick the robots run after reading the current step, or -1 when they do not tick."""
        since_first = self.step - (self.p.settle_steps - 1)
        if since_first < 0 or since_first % self.p.steps_per_tick:
            return -1
        tick = since_first // self.p.steps_per_tick
        return tick if tick < self.p.ticks else -1

    def poses(self) -> np.ndarray:
        """The robots' current poses, n x (x, y, heading)."""
        return np.stack([self.x, self.y, self.heading], axis=1)

    def advance(self, answers: Sequence[RobotAnswer]) -> None:
        """Take every robot's answer to the current step, then move and sense the next step (unless this was
        the last one)."""
        if self.done:
            raise RuntimeError("the trial is over: no step is waiting for answers")
        if len(answers) != self.p.n_robots:
            raise ValueError(f"expected {self.p.n_robots} answers, got {len(answers)}")
        for i, answer in enumerate(answers):
            self.broadcast_nest[i], self.broadcast_food[i] = answer.broadcast
        if self.tick_index() >= 0:
            self.actions[:] = [answer.action for answer in answers]
        smoothed = np.array([answer.smoothed for answer in answers], dtype=np.float64)
        if self.step == self.p.settle_steps - 1:
            self.initial = smoothed
        if self.step == self.last_step:
            self.final = smoothed
            return
        if self.step >= self.p.settle_steps - 1:
            world.physics_step(
                self.x,
                self.y,
                self.heading,
                self.actions,
                self.setup.gains,
                self.p,
                self._x_before,
                self._y_before,
            )
        self.step += 1
        self._readings = self._sense()

    def record(self, counts: np.ndarray) -> TrialRecord:
        """The finished trial's record, given each robot's tree counts (n x 8: condition ticks, then the
        starts of each action)."""
        if self.initial is None or self.final is None:
            raise RuntimeError("the trial is not finished")
        end_ground = np.array([[r.in_nest, r.on_food] for r in self._readings], dtype=np.bool_)
        values = world.trial_values(
            self.initial, self.final, end_ground, np.asarray(counts, np.int64), self.p
        )
        return TrialRecord(
            trial=self.setup.trial,
            gap=self.setup.gap,
            values=tuple(float(v) for v in values),
            start_poses=self.setup.poses.copy(),
            end_poses=self.poses(),
        )

    def _sense(self) -> list[Readings]:
        return sense_swarm(
            self.x,
            self.y,
            self.heading,
            self.broadcast_nest,
            self.broadcast_food,
            self.setup.drop_keys,
            self.step,
            self.setup.gap,
            self.p,
        )


def run_with_controllers(
    tree: Node,
    seed: int,
    trial: int,
    config: Config = DEFAULT,
    on_step: Callable[[LockstepTrial], None] | None = None,
    on_answers: Callable[[LockstepTrial, Sequence[RobotAnswer]], None] | None = None,
) -> TrialRecord:
    """Run a trial in-process exactly as the node graph runs it: the lockstep world and one
    ``FootbotController`` per robot, exchanging readings and answers. ``on_step(trial)`` is called after
    each step's readings are out (for example to collect the poses a simulator node would publish);
    ``on_answers(trial, answers)`` with the robots' answers to the step, before the world takes them."""
    world = LockstepTrial(seed, trial, config)
    p = world.p
    schedule = Schedule(p.settle_steps, p.steps_per_tick, p.ticks)
    perception = PerceptionParams(p.window, p.estimate_cap, p.density_range, p.density_divisor)
    controllers = []
    for key in world.setup.tree_keys:
        controller = FootbotController()
        controller.load(tree)
        controller.start_trial(int(key), schedule, perception)
        controllers.append(controller)
    counts = np.zeros((p.n_robots, 8), dtype=np.int64)
    while not world.done:
        if on_step is not None:
            on_step(world)
        answers = []
        for i, (controller, readings) in enumerate(zip(controllers, world.readings(), strict=True)):
            outcome = controller.on_step(world.step, readings)
            if outcome.tick is not None:
                counts[i, 0] += outcome.tick.condition_ticks
                if outcome.tick.started >= 0:
                    counts[i, 1 + outcome.tick.started] += 1
            answers.append(RobotAnswer(outcome.action, outcome.broadcast, outcome.smoothed))
        if on_answers is not None:
            on_answers(world, answers)
        world.advance(answers)
    return world.record(counts)


def warm_up(config: Config = DEFAULT) -> None:
    """Compile (or load from numba's cache) every world function a lockstep trial uses, by running the first
    moving step of a trial with every robot stopped."""
    trial = LockstepTrial(0, 0, config)
    still = RobotAnswer(STOP, (config.estimate_cap, config.estimate_cap), (0.0, 0.0, 0.0))
    for _ in range(config.settle_steps + 1):
        trial.advance([still] * config.n_robots)
    n = config.n_robots
    world.trial_values(
        np.zeros((n, 3)), np.zeros((n, 3)), np.zeros((n, 2), np.bool_), np.zeros((n, 8), np.int64), trial.p
    )
