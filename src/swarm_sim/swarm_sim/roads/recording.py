"""One trial step by step, for animations: ``record_trial`` (the batch road's kernels, about a millisecond)
and ``record_trial_reference`` (the reference road, as the node graph runs it; about a tenth of a second).

Both give a ``RecordedTrial``: per control step of trial ``trial`` of ``seed`` (its chain's earlier trials are
run first, not recorded; ``bt_controller.robot.timeline``) the robots' poses, the motors their last tick set,
the last tick's number, the messages each robot received, its smoothed values, its ground sensor, its carrying
flag and deliveries, and the fitness so far (each objective scored from the values of the step as if the trial
ended there). The two are
equal array for array, as the two roads' results are (``test_recording.py``).

``record_trial`` runs the batch road's ``kernel.simulate_chain`` itself, asked to record one trial
(``kernel.record_chain``): one source for the physics, perception and ticks of both.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from bt_controller.draws import check_seed, root_key
from bt_controller.interpreters import N_COUNTS, pack, parse_controller
from bt_controller.language import Library
from bt_controller.model_settings import chain_of_trial
from bt_controller.robot import timeline
from bt_controller.validate import integer
from swarm_sim.core import kernel, robot_faults, world
from swarm_sim.model import DEFAULT, Config, SwarmLayout


@dataclass(frozen=True)
class RecordedTrial:
    """Trial ``trial`` of ``seed`` with ``trees[i]`` on robot ``i``, one row per control step of the trial."""

    tree: str
    """The swarm's ``SwarmLayout.label``: the tree text of a homogeneous swarm, else a JSON list of trees."""
    seed: int
    trial: int
    gap: float
    """The trial's nest-food gap (mm)."""
    steps: np.ndarray
    """(T,) int64: the chain's step number of each row (T: ``Config.trial_steps``)."""
    poses: np.ndarray
    """(T, n, 3): x, y (mm) and heading (rad) after the step's teleport and move (what the simulator
    publishes)."""
    actions: np.ndarray
    """(T, n) int64: the action driving each robot's wheels after the step, as its chain's last tick at or
    before the step set it (index into ``ACTIONS``; -1 before the chain's first tick)."""
    ticks: np.ndarray
    """(T,) int64: the number within the chain of that tick (-1 before the first)."""
    links: tuple[np.ndarray, ...]
    """Per row, (k, 2) int64: (receiver, sender) of every message received at the step, by receiver, then
    sender (at a trial's first step the robots ignore them)."""
    smoothed: np.ndarray
    """(T, n, R + 1): each robot's smoothed values as last refreshed (nest, food, density, then food2 and
    food3 in a world of R = 3 or 4 regions)."""
    ground: np.ndarray
    """(T, n, R) bool: in each region (nest, food, food2, food3)."""
    initial: np.ndarray
    """(n, R + 1): the trial's initial smoothed values (taken at step ``initial_step`` of the trial)."""
    fitness: np.ndarray
    """(T, ``world.N_OBJECTIVES``): every objective so far (NaN before the initial step)."""
    values: tuple[float, ...]
    """The trial's values (``world.VALUE_NAMES``), as an evaluation scores it."""
    carrying: np.ndarray
    """(T, n, kinds) bool: whether each robot carries food of each kind after the step."""
    deliveries: np.ndarray
    """(T, n, kinds) int64: each robot's deliveries of each kind in the trial after the step."""
    trees: tuple[str, ...]
    """Each robot's tree text, robot 0 first."""


def _layout(tree: str | SwarmLayout, config: Config) -> SwarmLayout:
    layout = tree if isinstance(tree, SwarmLayout) else SwarmLayout.uniform(tree, config.n_robots)
    if layout.n_robots != config.n_robots:
        raise ValueError(f"the swarm layout has {layout.n_robots} trees for {config.n_robots} robots")
    return layout


def _check(seed: int, trial: int) -> int:
    check_seed(seed)
    return integer(trial, "trial", 0, numpy=True)


def _steps(config: Config, trial: int) -> np.ndarray:
    """The chain steps of trial ``trial``: its position in its chain times the trial's length, plus 1 .. T."""
    _, position = chain_of_trial(config.timeline, trial)
    return position * config.trial_steps + np.arange(1, config.trial_steps + 1, dtype=np.int64)


def _links(heard: np.ndarray, senders: np.ndarray) -> tuple[np.ndarray, ...]:
    """Per step, (receiver, sender) pairs from each receiver's count of messages and their senders."""
    n = heard.shape[1]
    row, receiver, slot = np.nonzero(np.arange(n) < heard[:, :, None])
    pairs = np.stack([receiver, senders[row, receiver, slot]], axis=1).astype(np.int64)
    ends = np.cumsum(heard.sum(axis=1)).tolist()
    return tuple(pairs[a:b] for a, b in zip([0, *ends[:-1]], ends, strict=True))  # (np.split: 8x slower)


def record_trial(
    tree: str | SwarmLayout,
    seed: int,
    trial: int = 0,
    config: Config = DEFAULT,
    library: Library | None = None,
) -> RecordedTrial:
    """Trial ``trial`` of ``seed`` with ``tree`` (tree text) on every robot, or a swarm layout's tree on each
    robot, through the batch road's kernels, in world ``config`` (its profile and conditions). Raises
    ``TreeError`` for a bad tree and ``ValueError`` for a bad seed, trial or layout."""
    trial = _check(seed, trial)
    layout = _layout(tree, config)
    trees = pack([parse_controller(text, library=library) for text in layout.distinct])
    chain, position = chain_of_trial(config.timeline, trial)
    p = config.params()
    rec = kernel.new_recording(config.trial_steps, p.n_robots, p.regions)
    gap = config.gap(trial)  # the gap of its chain (a chain's trials share one)
    pieces, food_scale = config.arena_table
    arena = config.arena_of_trial(trial)
    key = np.uint64(root_key(int(seed)))  # (a Python int from numba: keep the kernel's uint64)
    robot_tree = np.array(layout.robot_tree, dtype=np.int64)
    faults = robot_faults(config, key)
    values = kernel.record_chain(
        trees, robot_tree, key, chain, position, pieces[arena], food_scale[arena], p, rec, faults
    )
    return RecordedTrial(
        tree=layout.label,
        seed=int(seed),
        trial=trial,
        gap=gap,
        steps=_steps(config, trial),
        poses=rec.poses,
        actions=rec.actions,
        ticks=rec.ticks,
        links=_links(rec.heard, rec.senders),
        smoothed=rec.smoothed,
        ground=rec.ground,
        initial=rec.initial,
        fitness=rec.fitness,
        values=tuple(float(v) for v in values),
        carrying=rec.carrying,
        deliveries=rec.deliveries,
        trees=layout.trees,
    )


def record_trial_reference(
    tree: str | SwarmLayout,
    seed: int,
    trial: int = 0,
    config: Config = DEFAULT,
    library: Library | None = None,
) -> RecordedTrial:
    """``record_trial`` through the reference road (``lockstep.run_with_controllers``: the simulator's side
    and one ``FootbotController`` per robot, as the node graph runs them), from the robots' answers."""
    from swarm_sim.roads.lockstep import (
        LockstepChain,
        RobotAnswer,
        run_with_controllers,
    )  # (the slow road: on demand)

    trial = _check(seed, trial)
    layout = _layout(tree, config)
    parsed = [parse_controller(text, library=library) for text in layout.trees]
    line = config.timeline
    p = config.params()
    n = p.n_robots
    poses: list[np.ndarray] = []
    actions: list[np.ndarray] = []
    ticks: list[int] = []
    links: list[np.ndarray] = []
    smoothed_rows: list[np.ndarray] = []
    ground: list[np.ndarray] = []
    fitness: list[np.ndarray] = []
    carrying: list[np.ndarray] = []
    deliveries: list[np.ndarray] = []
    current = np.full(n, -1, dtype=np.int64)
    last_tick = -1
    initial = np.zeros((n, p.regions + 1))
    no_counts, no_motion = np.zeros((n, N_COUNTS), dtype=np.int64), np.zeros((n, 2), dtype=np.int64)

    def on_answers(sim: LockstepChain, answers: Sequence[RobotAnswer]) -> None:
        nonlocal last_tick, initial
        if sim.ticks_now():
            current[:] = [a.action for a in answers]
            last_tick = timeline.tick_number(line, sim.step)
        if sim.trial != trial:  # an earlier trial of the chain: it sets the state, it is not recorded
            return
        readings = sim.readings()
        smoothed = np.array([a.smoothed for a in answers], dtype=np.float64)
        if timeline.is_initial(line, sim.step):
            initial = smoothed
        poses.append(sim.poses())
        actions.append(current.copy())
        ticks.append(last_tick)
        pairs = [(i, int(s)) for i, r in enumerate(readings) for s in r.senders]
        links.append(np.array(pairs, dtype=np.int64).reshape(-1, 2))
        smoothed_rows.append(smoothed)
        ground.append(np.array([r.ground for r in readings], dtype=np.bool_))
        carrying.append(np.array([a.carrying for a in answers], dtype=np.bool_))
        delivered = np.array([a.deliveries for a in answers], dtype=np.int64)
        deliveries.append(delivered)
        if timeline.step_in_trial(line, sim.step) < line.initial_step:
            fitness.append(np.full(world.N_OBJECTIVES, np.nan))
        else:
            probes = sim.probes.copy()
            entry, food_scale = config.arena_arrays(trial)
            world.take_all_probes(sim.x, sim.y, entry, probes, 1, p)
            values = world.trial_values(
                initial, smoothed, no_counts, no_motion, probes, delivered, food_scale, p
            )
            fitness.append(values[: world.N_OBJECTIVES])

    record = run_with_controllers(parsed, seed, trial, config, on_answers=on_answers)
    return RecordedTrial(
        tree=layout.label,
        seed=int(seed),
        trial=trial,
        gap=config.gap(trial),
        steps=_steps(config, trial),
        poses=np.array(poses),
        actions=np.array(actions),
        ticks=np.array(ticks, dtype=np.int64),
        links=tuple(links),
        smoothed=np.array(smoothed_rows),
        ground=np.array(ground),
        initial=initial,
        fitness=np.array(fitness),
        values=record.values,
        carrying=np.array(carrying),
        deliveries=np.array(deliveries),
        trees=layout.trees,
    )
