"""The batch road: whole chains of trials in compiled kernels, with the compiled tree interpreter.

``simulate_chain`` runs the trials of one chain (``bt_controller.robot.timeline``: 5 trials as one simulation
under ``paper``, one trial under ``clean``), each robot with its own tree of a pack (the same for every robot
in a homogeneous swarm), exactly as the reference road
(``swarm_sim.roads.reference_road``: the simulator of ``swarm_sim.roads.lockstep`` with one
``bt_controller.robot.controller.FootbotController`` per robot) does, with the same ``swarm_sim.core.world``,
``bt_controller.robot.perception``, ``bt_controller.robot.motors`` and ``bt_controller.robot.timeline``
functions in the same order; it only skips work whose result is never read (a bearing is computed for the
three senders the blackboard needs, at ticks, rather than for every message) or known
(``fast_world.physics_step``, the physics to the same bits).
``run_jobs(trees, params, jobs, out)`` runs many (robots' trees, seed, chain) jobs; each job writes only its
own output rows (one per trial), so a job's result never depends on the others, their order or their number.
``record_chain`` runs one chain through the very same ``simulate_chain`` and also writes, step by step, what
one of its trials looks like (``Recording``: poses, actions, messages, smoothed values, fitness so far), for
animations (``swarm_sim.roads.recording``); the batch road asks for none and pays two comparisons a step.

The kernels' arguments are named tuples of arrays, which numba passes whole: ``PackedTrees`` (the trees),
``Jobs`` (what to run), ``Outputs`` (where results go), ``Recording`` (one trial, step by step); inside a
chain, ``Swarm`` holds every robot's state, ``Cargo`` its foraging state and ``Inbox`` the messages of one
step. ``make_jobs`` builds
``Jobs`` from Python.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import NamedTuple

import numba
import numpy as np

from bt_controller.draws import BEARINGS, DROPS, GAINS, HEADING, POSITION, TREE, chain_keys
from bt_controller.interpreters import (
    N_COUNTS,
    OP_CONDITION,
    OP_NETWORK,
    PackedTrees,
    act,
    start_memory,
    tick,
    tree_at,
)
from bt_controller.language import CONDITION_SIDE, N_CONDITIONS, RUNNING, SIDES, STOP
from bt_controller.robot import (
    ROBOT_SIDE,
    motors_after_tick,
    movement_of,
    region_column,
    rotation_of,
    running_action,
    timeline,
)
from swarm_sim.core import fast_world, world
from swarm_sim.core._numba_cache import drop_stale_cache
from swarm_sim.core.trial_data import chain_plan, robot_faults
from swarm_sim.model import N_PROBES, Config, Params

drop_stale_cache(
    __file__,
    (
        "bt_controller.interpreters.compiled",
        "bt_controller.draws",
        "bt_controller.robot.motors",
        "bt_controller.interpreters.network",
        "bt_controller.robot.perception",
        "bt_controller.robot.timeline",
        "bt_controller.language.vocabulary",
        "swarm_sim.model.config",
        "swarm_sim.model.faults",
        "swarm_sim.model.regions",
        "swarm_sim.core.fast_world",
        "swarm_sim.core.world",
    ),
)


@numba.njit(cache=True, error_model="numpy", inline="always")
def _source_bearing(
    needed: bool, i: int, source: int, x: np.ndarray, y: np.ndarray, heading: np.ndarray
) -> float:
    # A bearing the tree never reads is not computed (NaN: neither side); the ticks are the same.
    if source < 0 or not needed:
        return math.nan
    return world.bearing(x[i], y[i], heading[i], x[source], y[source])


_CONDITION_SIDE = np.array(CONDITION_SIDE, dtype=np.int64)
"""Each condition's side pair (``vocabulary.CONDITION_SIDE``: -1 for none), a constant of the kernels."""


@numba.njit(cache=True, error_model="numpy")
def _sides_read(op: np.ndarray, arg: np.ndarray) -> np.ndarray:
    """Which of the blackboard's side pairs (``vocabulary.SIDES``: nest, food, robot, food2, food3) the tree
    reads, from its condition nodes and the conditions table; a network reads them all."""
    read = np.zeros(len(SIDES), dtype=np.bool_)
    for k in range(op.shape[0]):
        if op[k] == OP_NETWORK:
            read[:] = True
        if op[k] == OP_CONDITION:
            side = _CONDITION_SIDE[arg[k]]
            if side >= 0:
                read[side] = True
    return read


class Jobs(NamedTuple):
    """Many jobs; job ``j`` runs the first ``trials[j]`` trials of chain ``chain[j]``, robot ``i`` running
    tree ``robot_tree[j, i]`` of a pack, with stream key ``seed_key[j]`` (``root_key`` of its seed) in arena
    configuration ``arena[j]`` of the layout (``regions.layout_table``: ``layout`` and ``food_scale``, shared
    by the jobs), into output rows ``row[j] .. row[j] + trials[j] - 1``; robot ``i`` has fault
    ``faults[j, i]`` (``trial_data.robot_faults`` of the job's seed; 0: none)."""

    robot_tree: np.ndarray  # int64 (jobs, n_robots)
    seed_key: np.ndarray  # uint64
    chain: np.ndarray  # int64
    trials: np.ndarray  # int64
    arena: np.ndarray  # int64
    row: np.ndarray  # int64
    layout: np.ndarray  # float64 (configurations, entries, pieces, PIECE_FIELDS)
    food_scale: np.ndarray  # float64 (configurations, entries)
    faults: np.ndarray  # int64 (jobs, n_robots)

    @property
    def n_jobs(self) -> int:
        """Number of jobs."""
        return len(self.robot_tree)

    @property
    def n_rows(self) -> int:
        """Number of output rows: trials over all jobs."""
        return int(self.trials.sum())


def make_jobs(
    seed_keys: Sequence[np.uint64],
    trials: Sequence[int],
    config: Config,
    robot_trees: Sequence[Sequence[int]] | None = None,
) -> Jobs:
    """Trials ``0 .. trials[t] - 1`` of request ``t`` with seed key ``seed_keys[t]``, request after request,
    as the chains of ``trial_data.chain_plan``; each request's trials take consecutive output rows in trial
    order. Robot ``i`` of request ``t`` runs tree ``robot_trees[t][i]`` of the pack (None: every robot of
    request ``t`` runs tree ``t``, a homogeneous swarm)."""
    n_robots = config.n_robots
    if robot_trees is None:
        robot_trees = [[t] * n_robots for t in range(len(seed_keys))]
    robot_tree, seed_key, chain, length, arena, row, faults = [], [], [], [], [], [], []
    layout, food_scale = config.arena_table
    next_row = 0
    for key, n, robots in zip(seed_keys, trials, robot_trees, strict=True):
        if len(robots) != n_robots:
            raise ValueError(f"expected a tree index for each of the {n_robots} robots, got {len(robots)}")
        robots_faults = robot_faults(config, key)
        for c, count in chain_plan(int(n), config):
            faults.append(robots_faults)
            robot_tree.append(list(robots))
            seed_key.append(key)
            chain.append(c)
            length.append(count)
            arena.append(config.arena_of_trial(c * config.chain_length))
            row.append(next_row)
            next_row += count
    return Jobs(
        np.array(robot_tree, dtype=np.int64).reshape(len(robot_tree), n_robots),
        np.array(seed_key, dtype=np.uint64),
        np.array(chain, dtype=np.int64),
        np.array(length, dtype=np.int64),
        np.array(arena, dtype=np.int64),
        np.array(row, dtype=np.int64),
        layout,
        food_scale,
        np.array(faults, dtype=np.int64).reshape(len(faults), n_robots),
    )


class Outputs(NamedTuple):
    """Where jobs write: one row per trial, rows ``jobs.row[j] ..`` belonging to job ``j``."""

    values: np.ndarray
    """rows x ``world.N_VALUES``: the trial's six values."""
    poses: np.ndarray
    """rows x 2 x n_robots x 3: start and end poses (x, y, heading)."""

    @staticmethod
    def zeros(n_rows: int, n_robots: int) -> Outputs:
        """Zeroed outputs for ``n_rows`` trials."""
        return Outputs(np.zeros((n_rows, world.N_VALUES)), np.zeros((n_rows, 2, n_robots, 3)))


class Swarm(NamedTuple):
    """Every robot's state during a chain, one row per robot (the world and the robots' minds)."""

    x: np.ndarray
    y: np.ndarray
    heading: np.ndarray
    dynamics: np.ndarray
    """(n, ``world.MOTION_FIELDS``) velocities and drive impulses carried between physics steps."""
    contacts: np.ndarray
    """(n, n, ``world.CONTACT_FIELDS``) the contacts' impulses carried between physics substeps."""
    pairs: np.ndarray
    """Workspace of ``world.physics_step``: the pairs of robots near enough to touch in a step."""
    solver: np.ndarray
    """(n, 10) workspace of ``fast_world.physics_step``'s solver."""
    gains: np.ndarray
    """(left, right) wheel gains."""
    broadcast: np.ndarray
    """(n, regions) values each robot broadcast at the last step (heard by the others at this one), per
    region (``vocabulary.REGIONS`` order: nest, food, food2, food3)."""
    raw: np.ndarray
    """(n, regions) raw estimates of the latest sensing step."""
    window: np.ndarray
    """(n, window, regions + 1) raw samples for smoothing (``vocabulary.region_column`` order: nest, food,
    density, food2, food3)."""
    smooth: np.ndarray
    """(n, regions + 1) smoothed values, as last refreshed (columns as ``window``'s)."""
    ground: np.ndarray
    """(n, regions) bool: in each region, at the latest sensing step."""
    here: np.ndarray
    """(n, regions) bool: the ground at a step that senses nothing (a trial's first)."""
    sources: np.ndarray
    """(n, ``len(SIDES)``) sender ids of each region's estimate source (at its ``region_column``) and of the
    nearest robot (at ``ROBOT_SIDE``); -1: none."""
    positions: np.ndarray
    """(regions,) workspace: the positions in the messages of a robot's estimate sources."""
    bearings: np.ndarray
    """(``len(SIDES)``,) workspace: a robot's bearings of its side pairs at a tick."""
    actions: np.ndarray
    """The motors of each robot: the last action its last tick ticked."""
    resumed: np.ndarray
    """The action each robot's last tick left running, or -1."""
    memory: np.ndarray
    """(n, nodes) the tree interpreter's memory."""
    counts: np.ndarray
    """(n, N_COUNTS) the tree interpreter's counts in the current trial."""
    motion: np.ndarray
    """(n, 2) movement and rotation sums of the current trial."""
    initial: np.ndarray
    """(n, regions + 1) the current trial's initial smoothed values."""


class Cargo(NamedTuple):
    """Every robot's foraging state during a chain (beside ``Swarm``): what it carries and has delivered, and
    where the trial found it (``docs/model.md``, "Foraging")."""

    carrying: np.ndarray
    """(n, food kinds) bool: whether each robot carries food of each kind (``perception.carry``)."""
    deliveries: np.ndarray
    """(n, food kinds) int64: each robot's deliveries of each kind in the current trial."""
    probes: np.ndarray
    """(n, 2, ``N_PROBES``) each robot's probes (``world.take_probes``) at the current trial's first step and,
    once taken, its last."""


class Inbox(NamedTuple):
    """The messages of one sensing step (``world.sense_step``'s outputs), per receiving robot."""

    n_heard: np.ndarray
    """(n,) messages received."""
    sender: np.ndarray
    """(n, n) their senders, in sender order; then their ranges (n, n) and estimates (n, n, regions)."""
    range: np.ndarray
    values: np.ndarray


class Recording(NamedTuple):
    """One trial of a chain, step by step (row ``r``: the trial's step ``r + 1``), as the simulator and the
    robots' answers show it (``swarm_sim.roads.lockstep``): what ``simulate_chain`` writes when asked to
    record. ``new_recording`` makes one."""

    poses: np.ndarray
    """(steps, n, 3): x, y, heading after the step's teleport and move."""
    actions: np.ndarray
    """(steps, n) int64: the motors the last tick at or before the step set (-1 before the chain's first)."""
    ticks: np.ndarray
    """(steps,) int64: the number of that tick within the chain (-1 before the first)."""
    heard: np.ndarray
    """(steps, n) int64: messages each robot received at the step (the first ``heard`` entries of its row of
    ``senders``); at a trial's first step the robots ignore them, as the timeline says."""
    senders: np.ndarray
    """(steps, n, n) int64: their senders, in sender order."""
    smoothed: np.ndarray
    """(steps, n, regions + 1): each robot's smoothed values as last refreshed (nest, food, density, food2,
    food3)."""
    ground: np.ndarray
    """(steps, n, regions) bool: in each region (the ground sensor at the step)."""
    fitness: np.ndarray
    """(steps, ``world.N_OBJECTIVES``): every objective scored as if the trial ended at the step (foraging:
    the deliveries so far); NaN before the initial step."""
    initial: np.ndarray
    """(n, regions + 1): the trial's initial smoothed values (taken at its initial step)."""
    carrying: np.ndarray
    """(steps, n, food kinds) bool: whether each robot carries food of each kind after the step (what it
    answered)."""
    deliveries: np.ndarray
    """(steps, n, food kinds) int64: each robot's deliveries of each kind in the trial after the step."""


@numba.njit(cache=True, error_model="numpy")
def new_recording(steps: int, n: int, regions: int) -> Recording:
    """A zeroed recording of ``steps`` steps of ``n`` robots in a world of ``regions`` regions (0 steps: the
    batch road's, which records nothing)."""
    return Recording(
        np.zeros((steps, n, 3)),
        np.zeros((steps, n), dtype=np.int64),
        np.zeros(steps, dtype=np.int64),
        np.zeros((steps, n), dtype=np.int64),
        np.zeros((steps, n, n), dtype=np.int64),
        np.zeros((steps, n, regions + 1)),
        np.zeros((steps, n, regions), dtype=np.bool_),
        np.zeros((steps, world.N_OBJECTIVES)),
        np.zeros((n, regions + 1)),
        np.zeros((steps, n, regions - 1), dtype=np.bool_),
        np.zeros((steps, n, regions - 1), dtype=np.int64),
    )


@numba.njit(cache=True, error_model="numpy", inline="always")
def _last_tick(p: Params, k: int) -> int:
    """The number of the last tick at or before chain step ``k``, or -1 if there was none."""
    for s in range(k, 0, -1):
        if timeline.ticks_at(p, s):
            return timeline.tick_number(p, s)
    return -1


# Makes arrays: compiled with reference counting, which it would otherwise inherit from ``_steps``.
@numba.njit(cache=True, error_model="numpy", _nrt=True)  # type: ignore[call-overload]  # _nrt: numba's option, not in its type stubs
def _record_step(
    rec: Recording,
    k: int,
    entry: np.ndarray,
    food_scale: float,
    p: Params,
    x: np.ndarray,
    y: np.ndarray,
    heading: np.ndarray,
    actions: np.ndarray,
    smooth: np.ndarray,
    initial: np.ndarray,
    heard: np.ndarray,
    senders: np.ndarray,
    carrying: np.ndarray,
    deliveries: np.ndarray,
    probes: np.ndarray,
    faults: np.ndarray,
) -> None:
    """Write chain step ``k`` (of the recorded trial) into its row of ``rec``, from the swarm after the step:
    what the simulator publishes and what the robots answered to it."""
    n = x.shape[0]
    row = timeline.step_in_trial(p, k) - 1
    last = _last_tick(p, k)
    rec.ticks[row] = last
    for i in range(n):
        rec.poses[row, i, 0] = x[i]
        rec.poses[row, i, 1] = y[i]
        rec.poses[row, i, 2] = heading[i]
        rec.actions[row, i] = actions[i] if last >= 0 else -1
        world.ground(x[i], y[i], entry, rec.ground[row, i])
        world.swap_ground(i, p, rec.ground[row, i])
        world.faulty_ground(faults[i], rec.ground[row, i])
        rec.heard[row, i] = heard[i]
        for c in range(heard[i]):
            rec.senders[row, i, c] = senders[i, c]
        for c in range(smooth.shape[1]):
            rec.smoothed[row, i, c] = smooth[i, c]
        for f in range(carrying.shape[1]):
            rec.carrying[row, i, f] = carrying[i, f]
            rec.deliveries[row, i, f] = deliveries[i, f]
    if timeline.is_initial(p, k):
        rec.initial[:, :] = initial
    if row + 1 >= p.initial_step:
        # The objectives only (counts and motion feed the descriptors), from this trial's initial values, the
        # robots' probes now and their deliveries so far.
        now = probes.copy()
        world.take_all_probes(x, y, entry, now, 1, p)
        values = world.trial_values(
            initial,
            smooth,
            np.zeros((n, N_COUNTS), dtype=np.int64),
            np.zeros((n, 2), dtype=np.int64),
            now,
            deliveries,
            food_scale,
            p,
        )
        for c in range(world.N_OBJECTIVES):
            rec.fitness[row, c] = values[c]
    else:
        rec.fitness[row, :] = np.nan


@numba.njit(cache=True, error_model="numpy")
def _new_swarm(gains: np.ndarray, trees: PackedTrees, robot_tree: np.ndarray, p: Params) -> Swarm:
    n = p.n_robots
    regions = p.regions
    width = 1
    for i in range(n):
        width = max(width, tree_at(trees, robot_tree[i]).op.shape[0])
    memory = np.zeros((n, width), dtype=np.int8)
    for i in range(n):
        start_memory(tree_at(trees, robot_tree[i]).op, memory[i], p.profile)
    return Swarm(
        np.zeros(n),
        np.zeros(n),
        np.zeros(n),
        np.zeros((n, world.MOTION_FIELDS)),
        np.zeros((n, n, world.CONTACT_FIELDS)),
        np.zeros((n * (n - 1) // 2, 2), dtype=np.int64),
        np.zeros((n, 10)),
        gains,
        np.full((n, regions), p.estimate_cap),
        np.full((n, regions), p.estimate_cap),
        np.zeros((n, p.window, regions + 1)),
        np.zeros((n, regions + 1)),
        np.zeros((n, regions), dtype=np.bool_),
        np.zeros((n, regions), dtype=np.bool_),
        np.full((n, len(SIDES)), -1, dtype=np.int64),
        np.full(regions, -1, dtype=np.int64),
        np.full(len(SIDES), math.nan),
        np.full(n, STOP, dtype=np.int64),
        np.full(n, -1, dtype=np.int64),
        memory,
        np.zeros((n, N_COUNTS), dtype=np.int64),
        np.zeros((n, 2), dtype=np.int64),
        np.zeros((n, regions + 1)),
    )


@numba.njit(cache=True, error_model="numpy")
def _new_cargo(n: int, kinds: int) -> Cargo:
    return Cargo(
        np.zeros((n, kinds), dtype=np.bool_), np.zeros((n, kinds), dtype=np.int64), np.zeros((n, 2, N_PROBES))
    )


@numba.njit(cache=True, error_model="numpy")
def _new_inbox(n: int, regions: int) -> Inbox:
    return Inbox(
        np.zeros(n, dtype=np.int64),
        np.zeros((n, n), dtype=np.int64),
        np.zeros((n, n)),
        np.zeros((n, n, regions)),
    )


@numba.njit(cache=True, error_model="numpy")
def simulate_chain(
    trees: PackedTrees,
    robot_tree: np.ndarray,
    seed_key: np.uint64,
    chain: int,
    trials: int,
    layout: np.ndarray,
    food_scale: np.ndarray,
    p: Params,
    values_out: np.ndarray,
    poses_out: np.ndarray,
    recorded: int,
    rec: Recording,
    faults: np.ndarray,
) -> None:
    """Run the first ``trials`` trials of chain ``chain``, robot ``i`` running tree ``robot_tree[i]`` of
    ``trees``, the chain's trial ``t`` on the regions of entry ``t`` of ``layout`` (its arena configuration's
    row of ``regions.layout_table``, cycling; ``food_scale`` that row's); write the chain's trial ``t``'s
    ``world.N_VALUES`` values into ``values_out[t]`` and its start and end poses into ``poses_out[t]`` (2 x
    n_robots x 3), and the chain's trial ``recorded`` step by step into ``rec`` (-1: none); robot ``i`` has
    fault ``faults[i]`` (``trial_data.robot_faults``; 0: none). Makes the chain's state, then runs its steps
    (``_steps``)."""
    n = p.n_robots
    keys = chain_keys(seed_key, chain, n)
    gains = world.wheel_gains(keys[GAINS], p)
    world.faulty_wheels(gains, faults)
    swarm = _new_swarm(gains, trees, robot_tree, p)
    sides = np.zeros((n, len(SIDES)), dtype=np.bool_)
    network = np.full(n, -1, dtype=np.int64)
    for i in range(n):
        own = tree_at(trees, robot_tree[i])
        sides[i] = _sides_read(own.op, own.arg)
        if own.op[0] == OP_NETWORK:
            network[i] = robot_tree[i]
    _steps(
        trees,
        robot_tree,
        network,
        keys,
        sides,
        swarm,
        _new_cargo(n, p.regions - 1),
        _new_inbox(n, p.regions),
        world.drive(swarm.gains, p),
        np.zeros(N_CONDITIONS, dtype=np.bool_),
        trials,
        (chain * timeline.chain_length(p)) % p.chain_trials,
        layout,
        food_scale,
        p,
        values_out,
        poses_out,
        recorded,
        rec,
        faults,
    )


# Makes an array: compiled with reference counting, which it would otherwise inherit from ``_steps``.
@numba.njit(cache=True, error_model="numpy", _nrt=True)  # type: ignore[call-overload]  # _nrt: numba's option, not in its type stubs
def _score_trial(
    swarm: Swarm, cargo: Cargo, food_scale: float, p: Params, values_out: np.ndarray, position: int
) -> None:
    """Write a finished trial's values into ``values_out[position]`` (``world.trial_values``, which makes an
    array: called from ``_steps``, which cannot own one, as a function of its own)."""
    values = world.trial_values(
        swarm.initial, swarm.smooth, swarm.counts, swarm.motion, cargo.probes, cargo.deliveries, food_scale, p
    )
    for c in range(values.shape[0]):
        values_out[position, c] = values[c]


# No reference counting (numba's ``_nrt=False``, an option of numba's own, pinned in ws/requirements.txt):
# each array view this loop makes (a robot's row, a tree of the pack, an inlined helper's array arguments)
# would otherwise cost two atomic operations, which were about a third of the kernel's time. So the loop and
# what it inlines make no array; what needs one (``_score_trial``, ``_record_step``) is compiled apart with
# reference counting (``_nrt=True``, else it would inherit this one's) and frees what it makes.
@numba.njit(cache=True, error_model="numpy", _nrt=False)  # type: ignore[call-overload]  # _nrt: numba's option, not in its type stubs
def _steps(
    trees: PackedTrees,
    robot_tree: np.ndarray,
    network: np.ndarray,
    keys: np.ndarray,
    sides: np.ndarray,
    swarm: Swarm,
    cargo: Cargo,
    inbox: Inbox,
    robot_drive: np.ndarray,
    board: np.ndarray,
    trials: int,
    block_start: int,
    layout: np.ndarray,
    food_scale: np.ndarray,
    p: Params,
    values_out: np.ndarray,
    poses_out: np.ndarray,
    recorded: int,
    rec: Recording,
    faults: np.ndarray,
) -> None:
    """The control steps of ``simulate_chain``'s chain, from the state it made. ``block_start``: the place of
    the chain's first trial in its block of ``chain_trials``, so that trial k of a block takes entry k of
    ``layout`` (``Config.arena_arrays``) under either profile. ``network[i]``: the pack's index of robot
    ``i``'s network, or -1 when it runs a tree; a network ticks where a tree would (``network.act`` on the
    same blackboard), returning running with its action started (``network.NetworkRobot``)."""
    n = p.n_robots
    position_keys = keys[POSITION]
    heading_keys = keys[HEADING]
    drop_keys = keys[DROPS]
    tree_keys = keys[TREE]
    bearing_keys = keys[BEARINGS]
    faulty = False  # without faults, the steps pay one test of this where a fault would act
    for i in range(n):
        faulty = faulty or faults[i] != 0
    typed = p.robot_types == 2  # likewise for the odd robots' swapped regions (world.swaps_regions)
    (x, y, heading, dynamics, contacts, pairs, solver, _, broadcast, raw, window, smooth, ground_now, here,
     sources, positions, bearings, actions, resumed, memory, counts, motion, initial) = swarm  # fmt: skip
    counts_in, senders, ranges, values = inbox
    carrying, deliveries, probes = cargo
    regions = p.regions
    kinds = regions - 1
    samples = 0
    fresh = 0  # samples since the region windows were last emptied (perception.smoothed)
    # Each robot's tree; one tree for all (a homogeneous swarm) is cut from the pack once, not at every tick.
    shared = tree_at(trees, robot_tree[0])
    uniform = True
    for i in range(n):
        uniform = uniform and robot_tree[i] == robot_tree[0]

    for k in range(1, trials * timeline.trial_steps(p) + 1):
        position = timeline.trial_in_chain(p, k)
        row = ((block_start + position) % p.chain_trials) % layout.shape[0]
        entry = layout[row]
        if timeline.step_in_trial(p, k) == 1:
            world.place_robots(x, y, heading, position_keys, heading_keys, position, p, entry)
            for i in range(n):
                poses_out[position, 0, i, 0] = x[i]
                poses_out[position, 0, i, 1] = y[i]
                poses_out[position, 0, i, 2] = heading[i]
        fast_world.physics_step(x, y, heading, actions, robot_drive, p, dynamics, contacts, pairs, solver)
        sensing = timeline.senses(p, k)
        if sensing or position == recorded:
            # Every robot hears what the others broadcast at the step before (at a trial's first step the
            # robots ignore it, and only a recording looks).
            # (``broadcast`` is rewritten whole at the step's end, so it may carry the air's sense until then)
            if typed:
                world.swap_sent(broadcast, p)
            if faulty:
                world.disrupt(faults, broadcast)
            world.sense_step(x, y, broadcast, drop_keys, k, p, counts_in, senders, ranges, values)
            if typed:
                world.swap_received(counts_in, values, p)
            if faulty:
                world.deafen(faults, counts_in)
        if not sensing:
            # A trial's first step: the start pose's ground sets the carrying flag, and the probes are taken
            # (the food distance: the inverse food objective's first, footbot_bt.cpp:134-137, 495-496 at
            # a73e4af). Food follows where the robot is: the flag is set before a ground fault (which only
            # changes what the robot reads) applies.
            for i in range(n):
                world.ground(x[i], y[i], entry, here[i])
                if typed:
                    world.swap_ground(i, p, here[i])
                for f in range(kinds):
                    on_food = here[i, f + 1] and world.can_carry(i, f, p)  # only the kinds it can carry
                    carrying[i, f] = world.start_carrying(carrying[i, f], on_food)
                world.take_probes(x, y, i, entry, probes, 0, p)
        if sensing:
            for i in range(n):
                inside = ground_now[i]
                world.ground(x[i], y[i], entry, inside)
                if typed:
                    world.swap_ground(i, p, inside)
                # Food is picked up and delivered where the robot is (a kind of those its group can carry:
                # world.can_carry); a ground fault then changes only what it reads (its estimates and
                # conditions: perception.Readings.footing).
                for f in range(kinds):
                    on_food = inside[f + 1] and world.can_carry(i, f, p)  # only the kinds it can carry
                    carrying[i, f], delivered = world.carry(carrying[i, f], inside[0], on_food)
                    deliveries[i, f] += 1 if delivered else 0
                if faulty:
                    world.faulty_ground(faults[i], inside)
                density, nearest = world.estimate(
                    inside, counts_in[i], ranges[i], values[i], p, raw[i], positions
                )
                world.push_sample(window[i], samples, raw[i], density)
                for r in range(regions):
                    sources[i, region_column(r)] = senders[i, positions[r]] if positions[r] >= 0 else -1
                sources[i, ROBOT_SIDE] = senders[i, nearest] if nearest >= 0 else -1
            samples += 1
            fresh += 1
            if timeline.refreshes(p, k):
                for i in range(n):
                    world.smoothed(window[i], samples, fresh, smooth[i])
        if timeline.ticks_at(p, k):
            number = timeline.tick_number(p, k)
            for i in range(n):
                tree = shared if uniform else tree_at(trees, robot_tree[i])
                for side in range(bearings.shape[0]):
                    bearings[side] = _source_bearing(sides[i, side], i, sources[i, side], x, y, heading)
                    if faulty:
                        source = sources[i, side]
                        seen = bearings[side]
                        bearings[side] = world.faulty_bearing(faults[i], seen, bearing_keys[i], k, source, n)
                world.blackboard(
                    ground_now[i], raw[i], bearings, sources[i, ROBOT_SIDE] >= 0, carrying[i], p, board
                )
                if network[i] >= 0:
                    status, started = RUNNING, act(trees.weights[network[i]], board)
                    counts[i, 1 + started] += 1
                else:
                    status, started = tick(tree, memory[i], board, tree_keys[i], number, counts[i])
                motors = motors_after_tick(status, started, resumed[i])
                resumed[i] = running_action(status, started)
                actions[i] = motors
                motion[i, 0] += movement_of(motors)
                motion[i, 1] += rotation_of(motors)
        if timeline.region_broadcast(p, k):
            for i in range(n):
                world.ground(x[i], y[i], entry, here[i])
                if typed:
                    world.swap_ground(i, p, here[i])
                if faulty:
                    world.faulty_ground(faults[i], here[i])
                for r in range(regions):
                    broadcast[i, r] = world.region_value(here[i, r], p)
        else:
            for i in range(n):
                for r in range(regions):
                    broadcast[i, r] = world.broadcast_value(smooth[i, region_column(r)])
        if timeline.is_initial(p, k):
            for i in range(n):
                for c in range(regions + 1):
                    initial[i, c] = smooth[i, c]
        if position == recorded:
            _record_step(
                rec,
                k,
                entry,
                food_scale[row],
                p,
                x,
                y,
                heading,
                actions,
                smooth,
                initial,
                counts_in,
                senders,
                carrying,
                deliveries,
                probes,
                faults,
            )
        if timeline.is_final(p, k):
            world.take_all_probes(x, y, entry, probes, 1, p)
            _score_trial(swarm, cargo, food_scale[row], p, values_out, position)
            for i in range(n):
                poses_out[position, 1, i, 0] = x[i]
                poses_out[position, 1, i, 1] = y[i]
                poses_out[position, 1, i, 2] = heading[i]
            for i in range(n):
                counts[i, :] = 0
                motion[i, 0] = 0
                motion[i, 1] = 0
                # after the scores: no carrying, no deliveries (footbot_bt.cpp:579-580 at a73e4af)
                for f in range(kinds):
                    carrying[i, f] = False
                    deliveries[i, f] = 0
            if timeline.trials_restart(p):
                fresh = 0  # the 2026 code empties the region windows (RobotView.end_trial)


@numba.njit(cache=True, error_model="numpy", inline="always")
def _run_job(j: int, trees: PackedTrees, params: Params, jobs: Jobs, out: Outputs) -> None:
    """Run job ``j`` into its rows of the outputs."""
    a = jobs.row[j]
    b = a + jobs.trials[j]
    simulate_chain(
        trees,
        jobs.robot_tree[j],
        jobs.seed_key[j],
        jobs.chain[j],
        jobs.trials[j],
        jobs.layout[jobs.arena[j]],
        jobs.food_scale[jobs.arena[j]],
        params,
        out.values[a:b],
        out.poses[a:b],
        -1,
        new_recording(0, params.n_robots, params.regions),
        jobs.faults[j],
    )


@numba.njit(cache=True, error_model="numpy")
def run_jobs(trees: PackedTrees, params: Params, jobs: Jobs, out: Outputs) -> None:
    """Run every job ``j`` of ``jobs`` (the robots' trees of ``trees``, seed key, chain, trials, arena) in
    world ``params`` into its rows of ``out``."""
    for j in range(jobs.robot_tree.shape[0]):
        _run_job(j, trees, params, jobs, out)


@numba.njit(cache=True, parallel=True)
def run_jobs_parallel(trees: PackedTrees, params: Params, jobs: Jobs, out: Outputs) -> None:
    """``run_jobs`` with the jobs spread over numba's threads; every job still writes only its own rows."""
    for j in numba.prange(jobs.robot_tree.shape[0]):
        _run_job(j, trees, params, jobs, out)


@numba.njit(cache=True, error_model="numpy")
def record_chain(
    trees: PackedTrees,
    robot_tree: np.ndarray,
    seed_key: np.uint64,
    chain: int,
    recorded: int,
    layout: np.ndarray,
    food_scale: np.ndarray,
    p: Params,
    rec: Recording,
    faults: np.ndarray,
) -> np.ndarray:
    """Run trials 0 .. ``recorded`` of chain ``chain``, robot ``i`` running tree ``robot_tree[i]`` of
    ``trees`` (``simulate_chain``) with fault ``faults[i]``, recording trial ``recorded`` into ``rec``
    (``new_recording(trial_steps, n_robots, regions)``); its ``world.N_VALUES`` values."""
    values = np.zeros((recorded + 1, world.N_VALUES))
    poses = np.zeros((recorded + 1, 2, p.n_robots, 3))
    simulate_chain(
        trees, robot_tree, seed_key, chain, recorded + 1, layout, food_scale, p, values, poses, recorded, rec,
        faults,
    )  # fmt: skip
    return values[recorded]
