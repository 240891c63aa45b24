"""The batch road: whole trials in compiled kernels, with the compiled tree interpreter.

``simulate_trial`` runs one trial of one flat tree exactly as ``swarm_sim.reference_road.run_trial``
does, with the same ``swarm_sim.world`` functions in the same order; it only skips work whose result is never
read (a bearing is computed for the three senders the blackboard needs, at ticks, rather than for every
message).
``run_jobs`` runs many (tree, seed, trial) jobs; each job writes only its own output rows, so a job's result
never depends on the others, their order or their number.
"""

from __future__ import annotations

import math

import numba
import numpy as np

from bt_controller.compiled import N_COUNTS, OP_CONDITION, reset_memory, tick
from bt_controller.vocabulary import CONDITION_INDEX, RUNNING, STOP
from swarm_sim import world
from swarm_sim._numba_cache import drop_stale_cache
from swarm_sim.config import Params
from swarm_sim.streams import DROPS, GAINS, HEADING, POSITION, TREE, trial_keys

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
        "swarm_sim.streams",
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


@numba.njit(cache=True)
def simulate_trial(
    op: np.ndarray,
    arg: np.ndarray,
    first: np.ndarray,
    nchild: np.ndarray,
    children: np.ndarray,
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
    gains = world.wheel_gains(keys[GAINS], p)
    x = poses[:, 0].copy()
    y = poses[:, 1].copy()
    heading = poses[:, 2].copy()
    x_before = np.empty(n)
    y_before = np.empty(n)

    broadcast_nest = np.empty(n)
    broadcast_food = np.empty(n)
    for i in range(n):
        in_nest, on_food = world.ground(x[i], y[i], gap, p)
        broadcast_nest[i], broadcast_food[i] = world.initial_broadcast(in_nest, on_food, p)

    raw_nest = np.empty(n)
    raw_food = np.empty(n)
    window = np.zeros((n, p.window, 3))
    ground_now = np.zeros((n, 2), dtype=np.bool_)
    sources = np.full((n, 3), -1, dtype=np.int64)  # sender ids: nest source, food source, nearest
    counts_in = np.zeros(n, dtype=np.int64)  # messages received by each robot this step
    senders = np.zeros((n, n), dtype=np.int64)
    ranges = np.zeros((n, n))
    nest_values = np.zeros((n, n))
    food_values = np.zeros((n, n))
    samples = 0

    memory = np.empty((n, op.shape[0]), dtype=np.int8)
    for i in range(n):
        reset_memory(op, memory[i])
    counts = np.zeros((n, N_COUNTS), dtype=np.int64)
    board = np.zeros(8, dtype=np.bool_)
    sides = _sides_read(op, arg)
    actions = np.full(n, STOP, dtype=np.int64)
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
                    status, action = tick(
                        op,
                        arg,
                        first,
                        nchild,
                        children,
                        memory[i],
                        board,
                        tree_keys[i],
                        tick_index,
                        counts[i],
                    )
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
def _run_job(
    j: int,
    op: np.ndarray,
    arg: np.ndarray,
    first: np.ndarray,
    nchild: np.ndarray,
    children: np.ndarray,
    node_offset: np.ndarray,
    child_offset: np.ndarray,
    job_tree: np.ndarray,
    job_seed_key: np.ndarray,
    job_trial: np.ndarray,
    job_gap: np.ndarray,
    p: Params,
    values_out: np.ndarray,
    poses_out: np.ndarray,
) -> None:
    """Run job ``j`` into row ``j`` of the outputs: its tree's slices of the pack, seed key, trial, gap."""
    t = job_tree[j]
    a, b = node_offset[t], node_offset[t + 1]
    c, d = child_offset[t], child_offset[t + 1]
    simulate_trial(
        op[a:b],
        arg[a:b],
        first[a:b],
        nchild[a:b],
        children[c:d],
        job_seed_key[j],
        job_trial[j],
        job_gap[j],
        p,
        values_out[j],
        poses_out[j],
    )


@numba.njit(cache=True)
def run_jobs(
    op: np.ndarray,
    arg: np.ndarray,
    first: np.ndarray,
    nchild: np.ndarray,
    children: np.ndarray,
    node_offset: np.ndarray,
    child_offset: np.ndarray,
    job_tree: np.ndarray,
    job_seed_key: np.ndarray,
    job_trial: np.ndarray,
    job_gap: np.ndarray,
    p: Params,
    values_out: np.ndarray,
    poses_out: np.ndarray,
) -> None:
    """Run every job ``j`` (tree ``job_tree[j]`` of a pack, seed key, trial, gap) into row ``j`` of the
    outputs (``values_out``: jobs x N_VALUES; ``poses_out``: jobs x 2 x n_robots x 3)."""
    for j in range(job_tree.shape[0]):
        _run_job(
            j,
            op,
            arg,
            first,
            nchild,
            children,
            node_offset,
            child_offset,
            job_tree,
            job_seed_key,
            job_trial,
            job_gap,
            p,
            values_out,
            poses_out,
        )


@numba.njit(cache=True, parallel=True)
def run_jobs_parallel(
    op: np.ndarray,
    arg: np.ndarray,
    first: np.ndarray,
    nchild: np.ndarray,
    children: np.ndarray,
    node_offset: np.ndarray,
    child_offset: np.ndarray,
    job_tree: np.ndarray,
    job_seed_key: np.ndarray,
    job_trial: np.ndarray,
    job_gap: np.ndarray,
    p: Params,
    values_out: np.ndarray,
    poses_out: np.ndarray,
) -> None:
    """``run_jobs`` with the jobs spread over numba's threads; every job still writes only its own rows."""
    for j in numba.prange(job_tree.shape[0]):
        _run_job(
            j,
            op,
            arg,
            first,
            nchild,
            children,
            node_offset,
            child_offset,
            job_tree,
            job_seed_key,
            job_trial,
            job_gap,
            p,
            values_out,
            poses_out,
        )
