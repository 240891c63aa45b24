"""The world model as compiled pure functions, split the way the ROS 2 node graph splits it.

(a) physics: ``start_poses``, ``wheel_gains``, ``move_robot``, ``resolve_collisions``, ``physics_step``;
(b) message delivery and ground sensing: ``ground``, ``sense_step``, ``bearing``, ``initial_broadcast``;
(c) one robot's view from its own readings: ``estimate``, ``push_sample``, ``smoothed``, ``blackboard``
(from ``bt_controller.perception``, inlined);
(d) objectives and descriptors: ``robot_objectives``, ``robot_descriptors``, ``trial_values``,
``mean_values``.

Every function is an ``njit`` function: the batch kernels call them inline and the reference road and the
nodes call the very same compiled code from Python, robot by robot, so both roads compute every number with
the same operations in the same order. Arguments ``p`` are ``config.Params``.

Conventions: a robot's readings of one sensing step are the messages it received, ordered by sender id;
estimates broadcast at step ``s`` are the raw estimates its sender computed at step ``s - 1``.
"""

from __future__ import annotations

import math

import numba
import numpy as np

from bt_controller import perception
from bt_controller.draws import uniform
from bt_controller.vocabulary import ACTION_WHEELS, ACTIONS
from swarm_sim._numba_cache import drop_stale_cache
from swarm_sim.config import Params

drop_stale_cache(
    __file__,
    ("bt_controller.draws", "bt_controller.perception", "bt_controller.vocabulary", "swarm_sim.config"),
)

WHEELS = np.array(ACTION_WHEELS, dtype=np.float64)
"""(left, right) wheel settings of each action, in units of the nominal wheel speed."""

FORWARD = ACTIONS.index("forward")
REVERSE = ACTIONS.index("reverse")
ANTICLOCKWISE = np.array([ACTIONS.index("forward_left"), ACTIONS.index("reverse_right")], dtype=np.int64)
CLOCKWISE = np.array([ACTIONS.index("forward_right"), ACTIONS.index("reverse_left")], dtype=np.int64)

N_VALUES = 6
"""Per-trial values: density, nest, food objectives, then movement, rotation, conditionality descriptors."""

TWO_PI = 2.0 * math.pi


# ---------------------------------------------------------------------------------------------------- (a)


@numba.njit(cache=True, inline="always")
def wrap_angle(a: float) -> float:
    """``a`` mapped into [-pi, pi) (one turn of correction at most on each side, as steps are small)."""
    if a >= math.pi:
        a -= TWO_PI
    elif a < -math.pi:
        a += TWO_PI
    return a


@numba.njit(cache=True)
def start_poses(position_keys: np.ndarray, heading_keys: np.ndarray, p: Params) -> np.ndarray:
    """Start poses (n_robots x 3: x, y, heading): uniform in the start disc, no overlaps, uniform headings.

    Robots are placed in id order; robot ``i``'s attempt ``a`` draws counters ``2a`` and ``2a + 1`` of its
    position stream and is rejected when it overlaps a robot already placed.
    """
    n = p.n_robots
    poses = np.empty((n, 3))
    min_d2 = (2.0 * p.robot_radius) ** 2
    for i in range(n):
        placed = False
        for attempt in range(p.max_start_attempts):
            r = p.start_radius * math.sqrt(uniform(position_keys[i], 2 * attempt))
            phi = TWO_PI * uniform(position_keys[i], 2 * attempt + 1)
            x = r * math.cos(phi)
            y = r * math.sin(phi)
            ok = True
            for k in range(i):
                dx = poses[k, 0] - x
                dy = poses[k, 1] - y
                if dx * dx + dy * dy < min_d2:
                    ok = False
                    break
            if ok:
                poses[i, 0] = x
                poses[i, 1] = y
                placed = True
                break
        if not placed:
            raise ValueError("start_poses: could not place a robot without overlap")
        poses[i, 2] = TWO_PI * uniform(heading_keys[i], 0) - math.pi
    return poses


@numba.njit(cache=True)
def wheel_gains(gain_keys: np.ndarray, p: Params) -> np.ndarray:
    """Each robot's (left, right) wheel gains, uniform in [gain_low, gain_high) (n_robots x 2).

    Damage acts here, on what a trial starts from (``swarm_sim.conditions``): robots below ``dead_robots``
    get gains 0 (they never drive or turn, though others can still push them), and the left wheel of the last
    ``weak_robots`` robots is scaled by ``weak_gain``. Every draw is made either way, so the undamaged robots'
    gains do not depend on the damage.
    """
    n = p.n_robots
    gains = np.empty((n, 2))
    span = p.gain_high - p.gain_low
    for i in range(n):
        gains[i, 0] = p.gain_low + span * uniform(gain_keys[i], 0)
        gains[i, 1] = p.gain_low + span * uniform(gain_keys[i], 1)
        if i >= n - p.weak_robots:
            gains[i, 0] *= p.weak_gain
        if i < p.dead_robots:
            gains[i, 0] = 0.0
            gains[i, 1] = 0.0
    return gains


@numba.njit(cache=True, inline="always")
def move_robot(
    x: float, y: float, heading: float, action: int, gain_left: float, gain_right: float, p: Params
) -> tuple:
    """One robot's pose after one step of ``action``, by exact arc integration, ignoring obstacles."""
    v_left = WHEELS[action, 0] * p.wheel_speed * gain_left
    v_right = WHEELS[action, 1] * p.wheel_speed * gain_right
    if v_left == 0.0 and v_right == 0.0:
        return x, y, heading
    v = 0.5 * (v_left + v_right)
    omega = (v_right - v_left) / p.wheel_separation
    if omega == 0.0:
        return x + v * p.step_dt * math.cos(heading), y + v * p.step_dt * math.sin(heading), heading
    # The exact arc, written as its chord: length 2 (v / omega) sin(turn / 2), along the mean heading.
    half_turn = 0.5 * omega * p.step_dt
    chord = 2.0 * (v / omega) * math.sin(half_turn)
    middle = heading + half_turn
    return x + chord * math.cos(middle), y + chord * math.sin(middle), wrap_angle(heading + omega * p.step_dt)


@numba.njit(cache=True, inline="always")
def _clamp_to_walls(x: np.ndarray, y: np.ndarray, p: Params) -> None:
    limit = p.arena_half - p.robot_radius
    for i in range(x.shape[0]):
        x[i] = min(max(x[i], -limit), limit)
        y[i] = min(max(y[i], -limit), limit)


@numba.njit(cache=True, inline="always")
def resolve_collisions(
    x: np.ndarray, y: np.ndarray, x_before: np.ndarray, y_before: np.ndarray, p: Params
) -> None:
    """Positional correction after a step, in place: no robot overlaps another or a wall afterwards.

    Robots are clamped inside the walls, then overlapping pairs (in (i, j) order) are pushed apart equally
    along the line of their centres, up to ``collision_iterations`` passes. Should overlaps remain, robots
    involved go back to their positions before the step (``x_before``, ``y_before``, assumed overlap-free)
    until none remain.
    """
    n = x.shape[0]
    min_d = 2.0 * p.robot_radius
    min_d2 = min_d * min_d
    _clamp_to_walls(x, y, p)
    for _ in range(p.collision_iterations + 1):
        overlapped = False
        for i in range(n):
            for j in range(i + 1, n):
                dx = x[j] - x[i]
                dy = y[j] - y[i]
                d2 = dx * dx + dy * dy
                if d2 < min_d2:
                    overlapped = True
                    d = math.sqrt(d2)
                    if d > 0.0:
                        ux = dx / d
                        uy = dy / d
                    else:
                        ux = 1.0
                        uy = 0.0
                    push = 0.5 * (min_d - d) + p.collision_slack
                    x[i] -= ux * push
                    y[i] -= uy * push
                    x[j] += ux * push
                    y[j] += uy * push
        if not overlapped:
            return
        _clamp_to_walls(x, y, p)
    # Fallback: undo the move of every robot involved in an overlap until none remains.
    changed = True
    while changed:
        changed = False
        for i in range(n):
            for j in range(i + 1, n):
                dx = x[j] - x[i]
                dy = y[j] - y[i]
                if dx * dx + dy * dy < min_d2:
                    for k in (i, j):
                        if x[k] != x_before[k] or y[k] != y_before[k]:
                            x[k] = x_before[k]
                            y[k] = y_before[k]
                            changed = True


@numba.njit(cache=True, inline="always")
def physics_step(
    x: np.ndarray,
    y: np.ndarray,
    heading: np.ndarray,
    actions: np.ndarray,
    gains: np.ndarray,
    p: Params,
    x_before: np.ndarray,
    y_before: np.ndarray,
) -> None:
    """Advance the swarm one step in place: every robot moves by its action, then collisions are resolved.

    ``x_before`` and ``y_before`` are workspace arrays (n_robots) that receive the positions before the move.
    """
    for i in range(x.shape[0]):
        x_before[i] = x[i]
        y_before[i] = y[i]
        x[i], y[i], heading[i] = move_robot(x[i], y[i], heading[i], actions[i], gains[i, 0], gains[i, 1], p)
    resolve_collisions(x, y, x_before, y_before, p)


# ---------------------------------------------------------------------------------------------------- (b)


@numba.njit(cache=True, inline="always")
def ground(x: float, y: float, gap: float, p: Params) -> tuple:
    """The ground sensor: (in_nest, on_food) for a robot centred at (x, y) in an arena with ``gap``."""
    d2 = x * x + y * y
    food_radius = p.nest_radius + gap
    return d2 <= p.nest_radius * p.nest_radius, d2 >= food_radius * food_radius


@numba.njit(cache=True, inline="always")
def initial_broadcast(in_nest: bool, on_food: bool, p: Params) -> tuple:
    """What a robot broadcasts before it has any estimate: (nest, food), 0 for a region it is in, else
    the cap."""
    return (0.0 if in_nest else p.estimate_cap), (0.0 if on_food else p.estimate_cap)


@numba.njit(cache=True, inline="always")
def sense_step(
    x: np.ndarray,
    y: np.ndarray,
    broadcast_nest: np.ndarray,
    broadcast_food: np.ndarray,
    drop_keys: np.ndarray,
    step: int,
    p: Params,
    counts: np.ndarray,
    senders: np.ndarray,
    ranges: np.ndarray,
    nest_values: np.ndarray,
    food_values: np.ndarray,
) -> None:
    """The messages every robot receives at sensing step ``step``.

    Robot ``j``'s message reaches robot ``i`` when their centres are within ``message_range`` and draw
    ``step * n + j`` of ``i``'s drop stream (``drop_keys[i]``) is below ``delivery_probability``. Robot
    ``i``'s messages fill the first ``counts[i]`` entries of row ``i`` of ``senders``, ``ranges``,
    ``nest_values`` and ``food_values`` (n x n), in sender order. Each pair's range is computed once for both
    directions (the same bits either way: ``(-d) * (-d) == d * d``).
    """
    n = x.shape[0]
    range2 = p.message_range * p.message_range
    for i in range(n):
        counts[i] = 0
    # Row i receives from k < i while k's row is scanned (k increasing), then from j > i: sender order.
    for i in range(n):
        for j in range(i + 1, n):
            dx = x[j] - x[i]
            dy = y[j] - y[i]
            d2 = dx * dx + dy * dy
            if d2 > range2:
                continue
            d = math.sqrt(d2)
            if uniform(drop_keys[i], step * n + j) < p.delivery_probability:
                c = counts[i]
                senders[i, c] = j
                ranges[i, c] = d
                nest_values[i, c] = broadcast_nest[j]
                food_values[i, c] = broadcast_food[j]
                counts[i] = c + 1
            if uniform(drop_keys[j], step * n + i) < p.delivery_probability:
                c = counts[j]
                senders[j, c] = i
                ranges[j, c] = d
                nest_values[j, c] = broadcast_nest[i]
                food_values[j, c] = broadcast_food[i]
                counts[j] = c + 1


@numba.njit(cache=True, inline="always")
def bearing(x: float, y: float, heading: float, x_other: float, y_other: float) -> float:
    """Bearing of (x_other, y_other) from a robot at (x, y) facing ``heading``, in [-pi, pi)."""
    return wrap_angle(math.atan2(y_other - y, x_other - x) - heading)


# ---------------------------------------------------------------------------------------------------- (c)
# A robot's perception is robot-side software, defined once in ``bt_controller.perception`` (what the
# controller node runs, and the reference road through its ``RobotView``). The batch kernels inline the very
# same source: numba does not inline calls between separately compiled functions, and inlining these saves
# ~15 %. These wrappers are compiled only where a kernel inlines them (or on a first call from Python); no
# disk cache, as their source file is not this one.

estimate = numba.njit(inline="always")(perception.estimate.py_func)
push_sample = numba.njit(inline="always")(perception.push_sample.py_func)
smoothed = numba.njit(inline="always")(perception.smoothed.py_func)
blackboard = numba.njit(inline="always")(perception.blackboard.py_func)
is_left = perception.is_left
is_right = perception.is_right


# ---------------------------------------------------------------------------------------------------- (d)


@numba.njit(cache=True)
def robot_objectives(
    initial: np.ndarray, final: np.ndarray, in_nest_end: bool, on_food_end: bool, p: Params
) -> tuple:
    """(density, nest, food) objectives of one robot in one trial, each in [0, 1].

    ``initial`` and ``final`` are smoothed (nest, food, density). Density: (final - initial + 1) / 2, clipped
    to [0, 1]; nest and food: ((initial - final) / cap + 1) / 2, or 1 for a robot that ends in the region.
    """
    density = min(max(0.5 * (final[2] - initial[2] + 1.0), 0.0), 1.0)
    nest = 1.0 if in_nest_end else 0.5 * ((initial[0] - final[0]) / p.estimate_cap + 1.0)
    food = 1.0 if on_food_end else 0.5 * ((initial[1] - final[1]) / p.estimate_cap + 1.0)
    return density, nest, food


@numba.njit(cache=True)
def robot_descriptors(counts: np.ndarray, p: Params) -> tuple:
    """(movement, rotation, conditionality) of one robot in one trial, each in [0, 1].

    ``counts`` as the tree interpreter keeps them: ``counts[0]`` condition ticks, ``counts[1 + a]`` starts
    of action ``a`` (at most one start per tick).
    """
    ticks = float(p.ticks)
    movement = float(counts[1 + FORWARD] - counts[1 + REVERSE])
    rotation = float(
        counts[1 + ANTICLOCKWISE[0]]
        + counts[1 + ANTICLOCKWISE[1]]
        - counts[1 + CLOCKWISE[0]]
        - counts[1 + CLOCKWISE[1]]
    )
    conditions = counts[0]
    starts = 0
    for a in range(1, counts.shape[0]):
        starts += counts[a]
    conditionality = 1.0 if conditions + starts == 0 else conditions / float(conditions + starts)
    return (movement + ticks) / (2.0 * ticks), (rotation + ticks) / (2.0 * ticks), conditionality


@numba.njit(cache=True)
def trial_values(
    initial: np.ndarray, final: np.ndarray, end_ground: np.ndarray, counts: np.ndarray, p: Params
) -> np.ndarray:
    """A trial's six values (``N_VALUES``): each robot's objectives and descriptors, averaged over robots in
    id order. ``initial``/``final``: n x 3 smoothed values; ``end_ground``: n x 2 (in_nest, on_food) at the
    end; ``counts``: n x 8 tick counts."""
    n = initial.shape[0]
    out = np.zeros(N_VALUES)
    for i in range(n):
        o = robot_objectives(initial[i], final[i], end_ground[i, 0], end_ground[i, 1], p)
        d = robot_descriptors(counts[i], p)
        out[0] += o[0]
        out[1] += o[1]
        out[2] += o[2]
        out[3] += d[0]
        out[4] += d[1]
        out[5] += d[2]
    for k in range(N_VALUES):
        out[k] /= n
    return out


@numba.njit(cache=True)
def mean_values(per_trial: np.ndarray) -> np.ndarray:
    """An evaluation's six values: per-trial values (trials x ``N_VALUES``) averaged in trial order."""
    out = np.zeros(N_VALUES)
    for t in range(per_trial.shape[0]):
        for k in range(N_VALUES):
            out[k] += per_trial[t, k]
    for k in range(N_VALUES):
        out[k] /= per_trial.shape[0]
    return out
