"""The batch road: whole trials in compiled kernels, with the compiled tree interpreter.

``simulate_trial`` runs one trial of one flat tree exactly as ``swarm_sim.reference_road.run_trial``
does, with the same ``swarm_sim.world`` functions in the same order; it only skips work whose result is never
read (a bearing is computed for the three senders the blackboard needs, at ticks, rather than for every
message).
``run_jobs(trees, params, jobs, out)`` runs many (tree, seed, trial) jobs; each job writes only its own
output rows, so a job's result never depends on the others, their order or their number.

The kernels' arguments are named tuples of arrays, which numba passes whole: ``PackedTrees`` (the trees),
``Jobs`` (what to run), ``Outputs`` (where results go); inside a trial, ``Swarm`` holds every robot's state
and ``Inbox`` the messages of one sensing step. ``make_jobs`` builds ``Jobs`` from Python.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import NamedTuple

import numba
import numpy as np

from bt_controller.compiled import N_COUNTS, OP_CONDITION, FlatTree, PackedTrees, reset_memory, tick, tree_at
from bt_controller.draws import DROPS, GAINS, HEADING, POSITION, TREE, trial_keys
from bt_controller.vocabulary import CONDITION_INDEX, RUNNING, STOP
from swarm_sim import world
from swarm_sim._numba_cache import drop_stale_cache
from swarm_sim.config import Params

FOOD_LEFT, FOOD_RIGHT = CONDITION_INDEX["food_left"], CONDITION_INDEX["food_right"]
NEST_LEFT, NEST_RIGHT = CONDITION_INDEX["nest_left"], CONDITION_INDEX["nest_right"]
ROBOT_LEFT, ROBOT_RIGHT = CONDITION_INDEX["robot_left"], CONDITION_INDEX["robot_right"]

drop_stale_cache(
    __file__,
    (
        "bt_controller.compiled",
        "bt_controller.draws",
        "bt_controller.perception",
        "bt_controller.vocabulary",
        "swarm_sim.config",
        "swarm_sim.world",
    ),
)


@numba.njit(cache=True, inline="always")
def _source_bearing(
    needed: bool, i: int, source: int, x: np.ndarray, y: np.ndarray, heading: np.ndarray
) -> float:
    # A bearing the tree never reads is not computed (NaN: neither side); the ticks are the same.
    if source < 0 or not needed:
        return math.nan
    return world.bearing(x[i], y[i], heading[i], x[source], y[source])


@numba.njit(cache=True)
def _sides_read(op: np.ndarray, arg: np.ndarray) -> np.ndarray:
    """Which of the blackboard's side pairs the tree reads: (nest, food, robot), from its condition nodes."""
    read = np.zeros(3, dtype=np.bool_)
    for k in range(op.shape[0]):
        if op[k] == OP_CONDITION:
            if arg[k] == FOOD_LEFT or arg[k] == FOOD_RIGHT:
                read[1] = True
            elif arg[k] == NEST_LEFT or arg[k] == NEST_RIGHT:
                read[0] = True
            elif arg[k] == ROBOT_LEFT or arg[k] == ROBOT_RIGHT:
                read[2] = True
    return read


class Jobs(NamedTuple):
    """Many jobs; job ``j`` runs tree ``tree[j]`` of a pack with stream key ``seed_key[j]`` (``root_key`` of
    its seed), trial number ``trial[j]`` and nest-food gap ``gap[j]``."""

    tree: np.ndarray  # int64
    seed_key: np.ndarray  # uint64
    trial: np.ndarray  # int64
    gap: np.ndarray  # float64

    @property
    def n_jobs(self) -> int:
        """Number of jobs."""
        return len(self.tree)


def make_jobs(seed_keys: Sequence[np.uint64], trials: Sequence[int], gaps: Sequence[float]) -> Jobs:
    """Trials ``0 .. trials[t] - 1`` of tree ``t`` with seed key ``seed_keys[t]``, tree after tree; trial
    ``k`` has gap ``gaps[k % len(gaps)]``."""
    tree = np.repeat(np.arange(len(trials), dtype=np.int64), trials)
    trial = np.concatenate([np.arange(t, dtype=np.int64) for t in trials] or [np.empty(0, np.int64)])
    seed_key = np.repeat(np.array(seed_keys, dtype=np.uint64), trials)
    gap = np.array(gaps, dtype=np.float64)[trial % len(gaps)]
    return Jobs(tree, seed_key, trial, gap)


class Outputs(NamedTuple):
    """Where jobs write: row ``j`` of each array belongs to job ``j``."""

    values: np.ndarray
    """jobs x ``world.N_VALUES``: the trial's six values."""
    poses: np.ndarray
    """jobs x 2 x n_robots x 3: start and end poses (x, y, heading)."""

    @staticmethod
    def zeros(n_jobs: int, n_robots: int) -> Outputs:
        """Zeroed outputs for ``n_jobs`` jobs."""
        return Outputs(np.zeros((n_jobs, world.N_VALUES)), np.zeros((n_jobs, 2, n_robots, 3)))


class Swarm(NamedTuple):
    """Every robot's state during a trial, one row per robot (the world arrays of ``simulate_trial``)."""

    x: np.ndarray
    y: np.ndarray
    heading: np.ndarray
    x_before: np.ndarray
    """Positions before the current physics step (collision fallback)."""
    y_before: np.ndarray
    gains: np.ndarray
    """(left, right) wheel gains."""
    broadcast_nest: np.ndarray
    """Estimates each robot broadcasts this step (its raw estimates of the previous step)."""
    broadcast_food: np.ndarray
    raw_nest: np.ndarray
    """Raw estimates computed this step."""
    raw_food: np.ndarray
    window: np.ndarray
    """(n, window, 3) raw samples (nest, food, density) for smoothing."""
    ground: np.ndarray
    """(n, 2) bool: in the nest, on food, at the latest step."""
    sources: np.ndarray
    """(n, 3) sender ids of the nest source, food source and nearest robot (-1: none)."""
    actions: np.ndarray
    """The action each robot is running."""
    memory: np.ndarray
    """(n, nodes) the tree interpreter's memory."""
    counts: np.ndarray
    """(n, N_COUNTS) the tree interpreter's counts."""


class Inbox(NamedTuple):
    """The messages of one sensing step (``world.sense_step``'s outputs), per receiving robot."""

    n_heard: np.ndarray
    """(n,) messages received."""
    sender: np.ndarray
    """(n, n) their senders, in sender order; then their ranges, nest and food estimates."""
    range: np.ndarray
    nest: np.ndarray
    food: np.ndarray


@numba.njit(cache=True)
def _new_swarm(poses: np.ndarray, gains: np.ndarray, tree: FlatTree, p: Params) -> Swarm:
    n = p.n_robots
    memory = np.empty((n, tree.op.shape[0]), dtype=np.int8)
    for i in range(n):
        reset_memory(tree.op, memory[i])
    return Swarm(
        poses[:, 0].copy(),
        poses[:, 1].copy(),
        poses[:, 2].copy(),
        np.empty(n),
        np.empty(n),
        gains,
        np.empty(n),
        np.empty(n),
        np.empty(n),
        np.empty(n),
        np.zeros((n, p.window, 3)),
        np.zeros((n, 2), dtype=np.bool_),
        np.full((n, 3), -1, dtype=np.int64),
        np.full(n, STOP, dtype=np.int64),
        memory,
        np.zeros((n, N_COUNTS), dtype=np.int64),
    )


@numba.njit(cache=True)
def _new_inbox(n: int) -> Inbox:
    return Inbox(
        np.zeros(n, dtype=np.int64),
        np.zeros((n, n), dtype=np.int64),
        np.zeros((n, n)),
        np.zeros((n, n)),
        np.zeros((n, n)),
    )


@numba.njit(cache=True)
def simulate_trial(
    tree: FlatTree,
    seed_key: np.uint64,
    trial: int,
    gap: float,
    p: Params,
    values_out: np.ndarray,
    poses_out: np.ndarray,
) -> None:
    """Run one trial of one flat tree; write its ``world.N_VALUES`` values into ``values_out`` and the start
    and end poses into ``poses_out`` (2 x n_robots x 3)."""
    n = p.n_robots
    keys = trial_keys(seed_key, trial, n)
    drop_keys = keys[DROPS]
    tree_keys = keys[TREE]
    poses = world.start_poses(keys[POSITION], keys[HEADING], p)
    swarm = _new_swarm(poses, world.wheel_gains(keys[GAINS], p), tree, p)
    # Locals for the loops below (a field read inside a loop would cost a reference count each time).
    (x, y, heading, x_before, y_before, gains, broadcast_nest, broadcast_food, raw_nest, raw_food, window,
     ground_now, sources, actions, memory, counts) = swarm  # fmt: skip
    counts_in, senders, ranges, nest_values, food_values = _new_inbox(n)
    for i in range(n):
        in_nest, on_food = world.ground(x[i], y[i], gap, p)
        broadcast_nest[i], broadcast_food[i] = world.initial_broadcast(in_nest, on_food, p)

    samples = 0
    board = np.zeros(8, dtype=np.bool_)
    sides = _sides_read(tree.op, tree.arg)
    initial = np.empty((n, 3))
    final = np.empty((n, 3))

    total_steps = p.settle_steps + p.ticks * p.steps_per_tick
    for step in range(total_steps):
        controlled = step - p.settle_steps
        if controlled >= 0:
            if controlled % p.steps_per_tick == 0:
                tick_index = controlled // p.steps_per_tick
                for i in range(n):
                    world.blackboard(
                        ground_now[i, 0],
                        ground_now[i, 1],
                        _source_bearing(sides[0], i, sources[i, 0], x, y, heading),
                        _source_bearing(sides[1], i, sources[i, 1], x, y, heading),
                        _source_bearing(sides[2], i, sources[i, 2], x, y, heading),
                        board,
                    )
                    status, action = tick(tree, memory[i], board, tree_keys[i], tick_index, counts[i])
                    actions[i] = action if status == RUNNING else STOP
            world.physics_step(x, y, heading, actions, gains, p, x_before, y_before)
        # Sense: every robot hears the estimates broadcast from the previous step.
        world.sense_step(
            x,
            y,
            broadcast_nest,
            broadcast_food,
            drop_keys,
            step,
            p,
            counts_in,
            senders,
            ranges,
            nest_values,
            food_values,
        )
        for i in range(n):
            in_nest, on_food = world.ground(x[i], y[i], gap, p)
            nest, food, density, nest_source, food_source, nearest = world.estimate(
                in_nest, on_food, counts_in[i], ranges[i], nest_values[i], food_values[i], p
            )
            world.push_sample(window[i], samples, nest, food, density)
            raw_nest[i] = nest
            raw_food[i] = food
            ground_now[i, 0] = in_nest
            ground_now[i, 1] = on_food
            sources[i, 0] = senders[i, nest_source] if nest_source >= 0 else -1
            sources[i, 1] = senders[i, food_source] if food_source >= 0 else -1
            sources[i, 2] = senders[i, nearest] if nearest >= 0 else -1
        samples += 1
        for i in range(n):
            broadcast_nest[i] = raw_nest[i]
            broadcast_food[i] = raw_food[i]
        if step == p.settle_steps - 1:
            for i in range(n):
                initial[i, 0], initial[i, 1], initial[i, 2] = world.smoothed(window[i], samples)

    for i in range(n):
        final[i, 0], final[i, 1], final[i, 2] = world.smoothed(window[i], samples)
    values = world.trial_values(initial, final, ground_now, counts, p)
    for k in range(values.shape[0]):
        values_out[k] = values[k]
    for i in range(n):
        for k in range(3):
            poses_out[0, i, k] = poses[i, k]
        poses_out[1, i, 0] = x[i]
        poses_out[1, i, 1] = y[i]
        poses_out[1, i, 2] = heading[i]


@numba.njit(cache=True, inline="always")
def _run_job(j: int, trees: PackedTrees, params: Params, jobs: Jobs, out: Outputs) -> None:
    """Run job ``j`` into row ``j`` of the outputs."""
    simulate_trial(
        tree_at(trees, jobs.tree[j]),
        jobs.seed_key[j],
        jobs.trial[j],
        jobs.gap[j],
        params,
        out.values[j],
        out.poses[j],
    )


@numba.njit(cache=True)
def run_jobs(trees: PackedTrees, params: Params, jobs: Jobs, out: Outputs) -> None:
    """Run every job ``j`` of ``jobs`` (a tree of ``trees``, seed key, trial, gap) in world ``params`` into
    row ``j`` of ``out``."""
    for j in range(jobs.tree.shape[0]):
        _run_job(j, trees, params, jobs, out)


@numba.njit(cache=True, parallel=True)
def run_jobs_parallel(trees: PackedTrees, params: Params, jobs: Jobs, out: Outputs) -> None:
    """``run_jobs`` with the jobs spread over numba's threads; every job still writes only its own rows."""
    for j in numba.prange(jobs.tree.shape[0]):
        _run_job(j, trees, params, jobs, out)
