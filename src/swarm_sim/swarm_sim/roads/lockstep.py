"""The simulator's side of one chain, advanced one control step at a time by the robots' answers.

This is what the simulator node and the reference road run: it owns the world (poses, wheel gains, the radio
channel, the ground sensor, and the robots' faults in them: ``swarm_sim.model.faults``) and nothing of the
robots' minds. At each step ``k`` of the chain it first
teleports the robots if a trial starts (``world.place_robots``), moves them with the motors they answered at
step ``k - 1``, and hands every robot its readings (the messages carry what the senders broadcast at ``k -
1``); then it waits for every robot's answer: the motors, the values it broadcasts, its smoothed values and,
at a tick, what the tick did. It scores each trial from those answers (``bt_controller.robot.timeline`` says
when), so the node graph, the reference road and the batch evaluator compute the same numbers.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass, replace

import numpy as np

from bt_controller.interpreters import Network
from bt_controller.language import ACTION_WHEELS, ACTIONS, STOP, Node
from bt_controller.model_settings import chain_of_trial
from bt_controller.robot import FootbotController, Readings, StepOutcome, movement_of, rotation_of, timeline
from swarm_sim.core import TrialRecord, sense_swarm, setup_chain, world
from swarm_sim.model import DEFAULT, N_PROBES, Config


@dataclass(frozen=True)
class RobotAnswer:
    """One robot's answer to one control step."""

    action: int
    """The motors driving the wheels from the next step on."""
    broadcast: Sequence[float]
    """The values the robot broadcasts at this step, per region (nest, food, food2, food3) (mm)."""
    smoothed: Sequence[float]
    """The robot's smoothed values as last refreshed (nest, food, density, food2, food3)."""
    condition_ticks: int = 0
    """Condition nodes ticked by this step's tick (0 without a tick)."""
    started: int = -1
    """The action this step's tick started, or -1."""
    carrying: Sequence[bool] = (False,)
    """Whether the robot carries food of each kind after this step (foraging)."""
    deliveries: Sequence[int] = (0,)
    """The robot's deliveries of each kind in the trial so far; the foraging objectives are scored from
    them."""


def action_of_wheels(left: float, right: float) -> int:
    """The action whose wheel setting is (left, right); ValueError for a pair no action produces."""
    try:
        return ACTION_WHEELS.index((left, right))
    except ValueError:
        raise ValueError(
            f"wheels ({left}, {right}) are not a footbot action; expected one of {list(ACTION_WHEELS)}"
        ) from None


class LockstepChain:
    """The first ``trials`` trials of chain ``chain`` of ``seed``, the world advanced only when every robot
    has answered."""

    def __init__(self, seed: int, chain: int, trials: int, config: Config = DEFAULT) -> None:
        self.config = config
        self.seed = seed
        self.p = config.params()
        self.line = config.timeline
        if isinstance(trials, bool) or not isinstance(trials, int) or not 1 <= trials <= config.chain_length:
            raise ValueError(f"a chain has 1 to {config.chain_length} trials, got {trials!r}")
        self.setup = setup_chain(seed, chain, config)
        self.trials = trials
        self.drive = world.drive(self.setup.gains, self.p)
        n = self.p.n_robots
        self.x, self.y, self.heading = np.zeros(n), np.zeros(n), np.zeros(n)
        self._motion, self._contacts, self._pairs = world.new_dynamics(n)
        self.actions = np.full(n, STOP, dtype=np.int64)
        regions = self.p.regions
        self.broadcast = np.full((n, regions), self.p.estimate_cap)
        """What each robot broadcast at the last step, per region."""
        self.counts = np.zeros((n, 1 + len(ACTIONS)), dtype=np.int64)
        self.motion = np.zeros((n, 2), dtype=np.int64)
        self.initial = np.zeros((n, regions + 1))
        self.probes = np.zeros((n, 2, N_PROBES))
        """Each robot's probes (``world.take_probes``) at the trial's first step, and at its last."""
        self.carrying = np.zeros((n, regions - 1), dtype=np.bool_)
        """Each robot's carrying flag per food kind, as it answered the last step (for viewers:
        swarm_state)."""
        self.deliveries = np.zeros((n, regions - 1), dtype=np.int64)
        """Each robot's deliveries per food kind in the trial, as it answered the last step."""
        self.start_poses = np.zeros((n, 3))
        self.records: list[TrialRecord] = []
        self.last_step = trials * timeline.trial_steps(self.line)
        self._scheduled: tuple[int, Config] | None = None
        self.fault_changes: list[tuple[int, np.ndarray]] = []
        """The faults injected into the chain (``schedule_faults``) as they took effect: (step, each robot's
        fault code)."""
        self.step = 1
        self._readings = self._begin_step()

    def schedule_faults(self, config: Config, step: int) -> int:
        """Let the faults of ``config`` (``swarm_sim.model.faults``; everything else must be this chain's)
        strike from step ``step`` on (live fault injection): the robots move with the faulty wheels from that
        step's motion and read that step's readings through the faults; a step already begun means the next
        one. Returns the step they will hold from; replaces faults scheduled and not yet in effect."""
        if replace(config, fault_rate=0.0, fault_kinds=(), fault_robots=()) != replace(
            self.config, fault_rate=0.0, fault_kinds=(), fault_robots=()
        ):
            raise ValueError("injected faults may change the robots' faults only, not the rest of the world")
        step = max(int(step), self.step + 1)
        self._scheduled = (step, config)
        return step

    def _strike(self) -> None:
        """Put the scheduled faults into effect when the step about to begin is theirs."""
        if self._scheduled is None or self._scheduled[0] > self.step:
            return
        config = self._scheduled[1]
        self._scheduled = None
        fresh = setup_chain(self.seed, self.setup.chain, config)  # the same streams: only faults differ
        self.setup = replace(self.setup, gains=fresh.gains, faults=fresh.faults)
        self.drive = world.drive(self.setup.gains, self.p)
        self.config = config
        self.fault_changes.append((self.step, fresh.faults.copy()))

    @property
    def done(self) -> bool:
        """Whether the answers to the chain's last step have been taken."""
        return len(self.records) == self.trials

    @property
    def trial(self) -> int:
        """The evaluation's index of the trial under way."""
        return self.setup.first_trial + timeline.trial_in_chain(self.line, self.step)

    def readings(self) -> list[Readings]:
        """Every robot's readings of the current step."""
        return self._readings

    def ticks_now(self) -> bool:
        """Whether the robots tick their trees at the current step."""
        return timeline.ticks_at(self.line, self.step)

    def poses(self) -> np.ndarray:
        """The robots' current poses, n x (x, y, heading)."""
        return np.stack([self.x, self.y, self.heading], axis=1)

    def advance(self, answers: Sequence[RobotAnswer]) -> TrialRecord | None:
        """Take every robot's answer to the current step, then teleport, move and sense for the next step
        (unless this was the last one). Returns the record of the trial this step finished, if any."""
        if self.done:
            raise RuntimeError("the chain is over: no step is waiting for answers")
        if len(answers) != self.p.n_robots:
            raise ValueError(f"expected {self.p.n_robots} answers, got {len(answers)}")
        k = self.step
        for i, answer in enumerate(answers):
            self.broadcast[i] = answer.broadcast
            self.actions[i] = answer.action
            self.carrying[i] = answer.carrying
            self.deliveries[i] = answer.deliveries
        if timeline.ticks_at(self.line, k):
            for i, answer in enumerate(answers):
                self.counts[i, 0] += answer.condition_ticks
                if answer.started >= 0:
                    self.counts[i, 1 + answer.started] += 1
                self.motion[i, 0] += movement_of(answer.action)
                self.motion[i, 1] += rotation_of(answer.action)
        smoothed = np.array([answer.smoothed for answer in answers], dtype=np.float64)
        if timeline.is_initial(self.line, k):
            self.initial = smoothed
        record = None
        if timeline.is_final(self.line, k):
            entry, food_scale = self.config.arena_arrays(self.trial)
            world.take_all_probes(self.x, self.y, entry, self.probes, 1, self.p)
            values = world.trial_values(
                self.initial,
                smoothed,
                self.counts,
                self.motion,
                self.probes,
                self.deliveries,
                food_scale,
                self.p,
            )
            record = TrialRecord(
                trial=self.trial,
                gap=self.setup.gap,
                values=tuple(float(v) for v in values),
                start_poses=self.start_poses.copy(),
                end_poses=self.poses(),
            )
            self.records.append(record)
            self.counts[:] = 0
            self.motion[:] = 0
        if k < self.last_step:
            self.step = k + 1
            self._strike()
            self._readings = self._begin_step()
        return record

    def _begin_step(self) -> list[Readings]:
        k = self.step
        entry, _ = self.config.arena_arrays(self.trial)
        if timeline.step_in_trial(self.line, k) == 1:
            world.place_robots(
                self.x,
                self.y,
                self.heading,
                self.setup.position_keys,
                self.setup.heading_keys,
                timeline.trial_in_chain(self.line, k),
                self.p,
                entry,
            )
            self.start_poses = self.poses()
        world.physics_step(
            self.x,
            self.y,
            self.heading,
            self.actions,
            self.drive,
            self.p,
            self._motion,
            self._contacts,
            self._pairs,
        )
        if timeline.step_in_trial(self.line, k) == 1:
            world.take_all_probes(self.x, self.y, entry, self.probes, 0, self.p)
        return sense_swarm(
            self.x,
            self.y,
            self.heading,
            self.broadcast,
            self.setup.drop_keys,
            k,
            entry,
            self.p,
            self.setup.faults,
            self.setup.bearing_keys,
        )


def robot_trees(tree: Node | Network | Sequence[Node | Network], n_robots: int) -> list[Node | Network]:
    """Each robot's tree: ``tree`` on every robot (a homogeneous swarm), or one tree per robot in id order
    (``swarm_sim.model.swarm_layout.SwarmLayout.parsed``); a network (``bt_controller.interpreters.network``)
    in place of any tree. ValueError for a count that is not ``n_robots``."""
    if isinstance(tree, Node | Network):
        return [tree] * n_robots
    trees = list(tree)
    if len(trees) != n_robots:
        raise ValueError(f"expected one tree per robot ({n_robots}), got {len(trees)}")
    return trees


def run_chain_with_controllers(
    tree: Node | Network | Sequence[Node | Network],
    seed: int,
    chain: int,
    trials: int,
    config: Config = DEFAULT,
    on_step: Callable[[LockstepChain], None] | None = None,
    on_answers: Callable[[LockstepChain, Sequence[RobotAnswer]], None] | None = None,
    on_outcomes: Callable[[LockstepChain, Sequence[StepOutcome]], None] | None = None,
) -> list[TrialRecord]:
    """Run the first ``trials`` trials of a chain in-process exactly as the node graph runs them: the
    lockstep world and one ``FootbotController`` per robot, exchanging readings and answers. ``tree``: every
    robot's tree, or one per robot (``robot_trees``).
    ``on_step(chain)`` is called after each step's readings are out (for example to collect the poses a
    simulator node would publish); ``on_answers(chain, answers)`` with the robots' answers to the step,
    before the world takes them; ``on_outcomes(chain, outcomes)`` with the controllers' own answers (what
    their nodes publish)."""
    sim = LockstepChain(seed, chain, trials, config)
    controllers = []
    for key, own in zip(sim.setup.tree_keys, robot_trees(tree, sim.p.n_robots), strict=True):
        controller = FootbotController()
        controller.load(own)
        controller.start_chain(int(key), config.timeline, config.perception, trials)
        controllers.append(controller)
    while not sim.done:
        if on_step is not None:
            on_step(sim)
        answers = []
        outcomes = []
        for controller, readings in zip(controllers, sim.readings(), strict=True):
            outcome = controller.on_step(sim.step, readings)
            outcomes.append(outcome)
            tick = outcome.tick
            answers.append(
                RobotAnswer(
                    outcome.action,
                    outcome.broadcast,
                    outcome.smoothed,
                    tick.condition_ticks if tick is not None else 0,
                    tick.started if tick is not None else -1,
                    outcome.carrying,
                    outcome.deliveries,
                )
            )
        if on_answers is not None:
            on_answers(sim, answers)
        if on_outcomes is not None:
            on_outcomes(sim, outcomes)
        sim.advance(answers)
    return sim.records


def run_with_controllers(
    tree: Node | Network | Sequence[Node | Network],
    seed: int,
    trial: int,
    config: Config = DEFAULT,
    on_step: Callable[[LockstepChain], None] | None = None,
    on_answers: Callable[[LockstepChain, Sequence[RobotAnswer]], None] | None = None,
    on_outcomes: Callable[[LockstepChain, Sequence[StepOutcome]], None] | None = None,
) -> TrialRecord:
    """Trial ``trial`` of ``seed`` as the node graph runs it: its chain is run from its first trial up to
    ``trial`` (the earlier trials set the state ``trial`` starts from); the record of ``trial``."""
    chain, position = chain_of_trial(config.timeline, trial)
    return run_chain_with_controllers(
        tree, seed, chain, position + 1, config, on_step, on_answers, on_outcomes
    )[-1]


def warm_up(config: Config = DEFAULT) -> None:
    """Compile (or load from numba's cache) every world function a lockstep chain uses, by running the first
    steps of a chain with every robot stopped, and scoring a trial."""
    sim = LockstepChain(0, 0, 1, config)
    regions = config.regions
    still = RobotAnswer(
        STOP, (config.estimate_cap,) * regions, (0.0,) * (regions + 1), 0, -1, (False,) * (regions - 1),
        (0,) * (regions - 1),
    )  # fmt: skip
    for _ in range(config.steps_per_tick + 1):
        sim.advance([still] * config.n_robots)
    n = config.n_robots
    counts = np.zeros((n, 1 + len(ACTIONS)), np.int64)
    world.trial_values(
        np.zeros((n, regions + 1)), np.zeros((n, regions + 1)), counts, np.zeros((n, 2), np.int64),
        np.zeros((n, 2, N_PROBES)), np.zeros((n, regions - 1), np.int64), 500.0, sim.p,
    )  # fmt: skip
    world.take_all_probes(sim.x, sim.y, config.arena_arrays(0)[0], np.zeros((n, 2, N_PROBES)), 0, sim.p)
