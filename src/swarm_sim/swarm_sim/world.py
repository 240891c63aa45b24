"""The world model as compiled pure functions, split the way the ROS 2 node graph splits it
(``docs/model.md``).

(a) physics: ``place_robots``, ``wheel_gains``, ``arcs``, ``move_robot``, ``resolve_collisions``,
``physics_step``;
(b) message delivery and ground sensing: ``ground``, ``occluded``, ``sense_step``, ``bearing``;
(c) one robot's view from its own readings (from ``bt_controller.perception``, inlined): ``estimate``,
``push_sample``, ``smoothed``, ``broadcast_value``, ``region_value``, ``blackboard``, ``carry``,
``start_carrying``;
(d) objectives and descriptors: ``food_distance``, ``robot_objectives``, ``robot_descriptors``,
``trial_values``, ``mean_values``.

Every function is an ``njit`` function: the batch kernels call them inline and the reference road and the
nodes call the very same compiled code from Python, robot by robot, so both roads compute every number with
the same operations in the same order. Arguments ``p`` are ``config.Params``.

Conventions: a robot's readings of one sensing step are the messages it received, ordered by sender id;
what a robot broadcasts at step ``k`` reaches the others at step ``k + 1``.
"""

from __future__ import annotations

import math

import numba
import numpy as np

from bt_controller import perception
from bt_controller.draws import uniform
from bt_controller.vocabulary import ACTION_WHEELS
from swarm_sim._numba_cache import drop_stale_cache
from swarm_sim.config import Params

drop_stale_cache(
    __file__,
    (
        "bt_controller.draws",
        "bt_controller.perception",
        "bt_controller.timeline",
        "bt_controller.vocabulary",
        "swarm_sim.config",
    ),
)

WHEELS = np.array(ACTION_WHEELS, dtype=np.float64)
"""(left, right) wheel settings of each action, in units of the nominal wheel speed."""

VALUE_NAMES: tuple[str, ...] = (
    "density",
    "nest",
    "food",
    "idensity",
    "inest",
    "ifood",
    "foraging",
    "movement",
    "rotation",
    "conditionality",
)
"""The values of a trial or an evaluation: the objectives (the paper's three, the 2024 follow-up's three
inverse primitives, foraging), then the descriptors (the one home of these names)."""
N_OBJECTIVES = 7
"""How many of the values are objectives (the rest are the three descriptors)."""
OBJECTIVES: tuple[str, ...] = VALUE_NAMES[:N_OBJECTIVES]
"""The objectives, in fitness order."""
PAPER_OBJECTIVES: tuple[str, ...] = ("density", "nest", "food")
"""The three objectives of the 2023 paper (its GP_fnd evolves them together)."""
DESCRIPTORS: tuple[str, ...] = VALUE_NAMES[N_OBJECTIVES:]
"""The three behaviour descriptors, in grid order."""
N_VALUES = len(VALUE_NAMES)

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


@numba.njit(cache=True, inline="always")
def _free(x: np.ndarray, y: np.ndarray, i: int, cx: float, cy: float, present: np.ndarray, p: Params) -> bool:
    """Whether robot ``i`` centred at (cx, cy) overlaps no other present robot where that one stands now."""
    min_d2 = (2.0 * p.robot_radius) ** 2
    for j in range(x.shape[0]):
        if j != i and present[j]:
            dx = x[j] - cx
            dy = y[j] - cy
            if dx * dx + dy * dy < min_d2:
                return False
    return True


@numba.njit(cache=True)
def place_robots(
    x: np.ndarray,
    y: np.ndarray,
    heading: np.ndarray,
    position_keys: np.ndarray,
    heading_keys: np.ndarray,
    position: int,
    p: Params,
) -> None:
    """Place every robot for the ``position``-th trial of a chain, in place (``bt_loop_functions.cpp:176-213``
    at a chain's start, ``:254-287`` at a teleport).

    Robots are placed one after another in id order: a heading uniform in [-pi, pi) (draw ``position`` of
    the robot's heading stream), then up to ``max_start_attempts`` positions uniform in the start square
    (attempt ``a``: draws ``2 (position * max_start_attempts + a)`` and the next of its position stream),
    the first that overlaps no robot where it stands now being taken. At a chain's start (``position`` 0)
    only robots already placed stand in the arena, and a robot that finds no place stays where it was
    created: the origin, heading 0. At a teleport every robot stands somewhere, and one that finds no place
    keeps its pose.
    """
    n = x.shape[0]
    present = np.zeros(n, dtype=np.bool_)
    if position == 0:
        for i in range(n):
            x[i] = 0.0
            y[i] = 0.0
            heading[i] = 0.0
    else:
        present[:] = True
    side = 2.0 * p.start_half
    for i in range(n):
        h = TWO_PI * uniform(heading_keys[i], position) - math.pi
        base = 2 * position * p.max_start_attempts
        for attempt in range(p.max_start_attempts):
            cx = -p.start_half + side * uniform(position_keys[i], base + 2 * attempt)
            cy = -p.start_half + side * uniform(position_keys[i], base + 2 * attempt + 1)
            if _free(x, y, i, cx, cy, present, p):
                x[i] = cx
                y[i] = cy
                heading[i] = h
                break
        present[i] = True


@numba.njit(cache=True)
def wheel_gains(gain_keys: np.ndarray, p: Params) -> np.ndarray:
    """Each robot's (left, right) wheel gains, drawn once per chain: gain_low + gain_step * U{0 ..
    gain_levels - 1} (``footbot_bt.cpp:73-80``: (90 + rand() % 20) / 100, the right wheel first: draw 0 of
    the robot's gain stream is the right wheel's, draw 1 the left's) (n_robots x 2).

    Damage acts here, on what a trial starts from (``swarm_sim.conditions``): robots below ``dead_robots``
    get gains 0 (they never drive or turn, though others can still push them), and the left wheel of the last
    ``weak_robots`` robots is scaled by ``weak_gain``. Every draw is made either way, so the undamaged robots'
    gains do not depend on the damage.
    """
    n = p.n_robots
    gains = np.empty((n, 2))
    for i in range(n):
        right = min(int(uniform(gain_keys[i], 0) * p.gain_levels), p.gain_levels - 1)
        left = min(int(uniform(gain_keys[i], 1) * p.gain_levels), p.gain_levels - 1)
        gains[i, 0] = p.gain_low + p.gain_step * left
        gains[i, 1] = p.gain_low + p.gain_step * right
        if i >= n - p.weak_robots:
            gains[i, 0] *= p.weak_gain
        if i < p.dead_robots:
            gains[i, 0] = 0.0
            gains[i, 1] = 0.0
    return gains


@numba.njit(cache=True, inline="always")
def arc(action: int, gain_left: float, gain_right: float, p: Params) -> tuple:
    """One step of ``action`` with these wheel gains as (chord, half turn, turn): the pose moves by the chord
    along the heading plus the half turn, and turns by the turn (the exact arc, written as its chord)."""
    v_left = WHEELS[action, 0] * p.wheel_speed * gain_left
    v_right = WHEELS[action, 1] * p.wheel_speed * gain_right
    if v_left == 0.0 and v_right == 0.0:
        return 0.0, 0.0, 0.0
    v = 0.5 * (v_left + v_right)
    omega = (v_right - v_left) / p.wheel_separation
    if omega == 0.0:
        return v * p.step_dt, 0.0, 0.0
    # Chord of the arc: length 2 (v / omega) sin(turn / 2), along the mean heading.
    half_turn = 0.5 * omega * p.step_dt
    return 2.0 * (v / omega) * math.sin(half_turn), half_turn, omega * p.step_dt


@numba.njit(cache=True)
def arcs(gains: np.ndarray, p: Params) -> np.ndarray:
    """Every robot's ``arc`` of every action (n_robots x actions x 3), computed once per chain: the gains do
    not change within one."""
    n = gains.shape[0]
    out = np.empty((n, WHEELS.shape[0], 3))
    for i in range(n):
        for action in range(WHEELS.shape[0]):
            out[i, action, 0], out[i, action, 1], out[i, action, 2] = arc(action, gains[i, 0], gains[i, 1], p)
    return out


@numba.njit(cache=True, inline="always")
def follow_arc(x: float, y: float, heading: float, chord: float, half_turn: float, turn: float) -> tuple:
    """The pose after one step along an ``arc``."""
    if chord == 0.0 and turn == 0.0:
        return x, y, heading
    middle = heading + half_turn
    return x + chord * math.cos(middle), y + chord * math.sin(middle), wrap_angle(heading + turn)


@numba.njit(cache=True, inline="always")
def move_robot(
    x: float, y: float, heading: float, action: int, gain_left: float, gain_right: float, p: Params
) -> tuple:
    """One robot's pose after one step of ``action``, by exact arc integration, ignoring obstacles."""
    chord, half_turn, turn = arc(action, gain_left, gain_right, p)
    return follow_arc(x, y, heading, chord, half_turn, turn)


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
    along the line of their centres, and their relative tangential displacement since (``x_before``,
    ``y_before``) is cancelled up to ``friction`` times the overlap, split equally (ARGoS: friction 0.7 per
    footbot body, multiplied at a contact); up to ``collision_iterations`` passes. Should overlaps remain,
    robots involved go back to their positions before the step (assumed overlap-free) until none remain.
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
                    overlap = min_d - d
                    if p.friction > 0.0:
                        # The tangential part of j's displacement relative to i's in this step.
                        rx = (x[j] - x_before[j]) - (x[i] - x_before[i])
                        ry = (y[j] - y_before[j]) - (y[i] - y_before[i])
                        along = rx * ux + ry * uy
                        tx = rx - along * ux
                        ty = ry - along * uy
                        slide = math.sqrt(tx * tx + ty * ty)
                        if slide > 0.0:
                            cancel = 0.5 * min(slide, p.friction * overlap) / slide
                            x[i] += cancel * tx
                            y[i] += cancel * ty
                            x[j] -= cancel * tx
                            y[j] -= cancel * ty
                    push = 0.5 * overlap + p.collision_slack
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
    robot_arcs: np.ndarray,
    p: Params,
    x_before: np.ndarray,
    y_before: np.ndarray,
) -> None:
    """Advance the swarm one step in place: every robot moves by its action along its arc (``arcs`` of its
    gains), then collisions are resolved.

    ``x_before`` and ``y_before`` are workspace arrays (n_robots) that receive the positions before the move.
    """
    for i in range(x.shape[0]):
        x_before[i] = x[i]
        y_before[i] = y[i]
        a = actions[i]
        x[i], y[i], heading[i] = follow_arc(
            x[i], y[i], heading[i], robot_arcs[i, a, 0], robot_arcs[i, a, 1], robot_arcs[i, a, 2]
        )
    resolve_collisions(x, y, x_before, y_before, p)


# ---------------------------------------------------------------------------------------------------- (b)


@numba.njit(cache=True, inline="always")
def ground(x: float, y: float, gap: float, p: Params) -> tuple:
    """The ground sensor: (in_nest, on_food) for a robot centred at (x, y) in an arena with ``gap``
    (``footbot_bt.cpp:240-247``: r < 0.5 m, r >= 0.5 m + gap)."""
    d2 = x * x + y * y
    food_radius = p.nest_radius + gap
    return d2 < p.nest_radius * p.nest_radius, d2 >= food_radius * food_radius


@numba.njit(cache=True, inline="always")
def occluded(x: np.ndarray, y: np.ndarray, i: int, j: int, p: Params) -> bool:
    """Whether a third robot's body cuts the segment between the centres of robots ``i`` and ``j``.

    Robot ``m`` occludes when the foot of its centre on the segment's line falls strictly between the ends and
    its distance from the line is below the body radius. (The ends themselves need no test: ``m``'s centre is
    at least two radii from theirs, as robots do not overlap.) Written without divisions: the dot product
    ``d`` against the squared length ``L2`` locates the foot, and the cross product ``c`` gives the distance
    ``|c| / sqrt(L2)``.
    """
    sx = x[j] - x[i]
    sy = y[j] - y[i]
    length2 = sx * sx + sy * sy
    limit = p.robot_radius * p.robot_radius * length2
    for m in range(x.shape[0]):
        mx = x[m] - x[i]
        my = y[m] - y[i]
        c = mx * sy - my * sx
        if c * c >= limit:
            continue  # far from the line (i and j themselves lie on it, and fail the next test)
        d = mx * sx + my * sy
        if 0.0 < d < length2 and m != j:
            return True
    return False


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
    """The messages every robot receives at control step ``step`` of a chain.

    Robot ``j``'s message reaches robot ``i`` when their centres are within ``message_range``, no third
    robot's body cuts the segment between them (with ``occlusion``), and draw ``step * n + j`` of ``i``'s
    drop stream (``drop_keys[i]``) is below ``delivery_probability``. It carries what ``j`` broadcast at the
    step before (``broadcast_*``). Robot ``i``'s messages fill the first ``counts[i]`` entries of row ``i`` of
    ``senders``, ``ranges``, ``nest_values`` and ``food_values`` (n x n), in sender order. Each pair's range
    is computed once for both directions (the same bits either way: ``(-d) * (-d) == d * d``).
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
            if p.occlusion and occluded(x, y, i, j, p):
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
broadcast_value = numba.njit(inline="always")(perception.broadcast_value.py_func)
region_value = numba.njit(inline="always")(perception.region_value.py_func)
blackboard = numba.njit(inline="always")(perception.blackboard.py_func)
carry = numba.njit(inline="always")(perception.carry.py_func)
start_carrying = numba.njit(inline="always")(perception.start_carrying.py_func)


# ---------------------------------------------------------------------------------------------------- (d)


@numba.njit(cache=True, inline="always")
def food_distance(x: float, y: float, gap: float, p: Params) -> float:
    """A robot's true distance from the food region: max(0, R - r) with R = nest_radius + gap, 0 on food
    (``CBlackBoard.cpp:185-201, 276-292`` at a73e4af; the inverse food objective's positions)."""
    radius = p.nest_radius + gap
    r = math.sqrt(x * x + y * y)
    return 0.0 if r >= radius else radius - r


@numba.njit(cache=True)
def robot_objectives(
    initial: np.ndarray,
    final: np.ndarray,
    food_initial: float,
    food_final: float,
    deliveries: int,
    food_radius: float,
    p: Params,
) -> tuple:
    """The objectives of one robot in one trial, ``OBJECTIVES`` order (``CBlackBoard.cpp:85-96, 224-235,
    343-347`` at 6c65001; the inverse ones and foraging ``CBlackBoard.cpp:98-104, 247-261, 355-359`` and
    ``footbot_bt.cpp:563-566`` at a73e4af).

    ``initial`` and ``final`` are the smoothed (nest, food, density) at the trial's initial and last steps.
    Density: (final - initial + 1) / 2, clipped to [0, 1]; nest and food: distances normalised by the cap,
    ((initial - final) / cap + 1) / 2, or 1 when the final smoothed value is 0. Inverse density: (initial -
    final + 1) / 2, clipped; inverse nest: ((final - initial) / cap + 1) / 2, with no rule for the nest;
    inverse food: from the true distances from the food region at the trial's first and last steps
    (``food_distance``), (final - initial + R) / (2 R) with R = ``food_radius``. Foraging: the deliveries.
    """
    density = min(max(0.5 * (final[2] - initial[2] + 1.0), 0.0), 1.0)
    nest = 1.0 if final[0] == 0.0 else 0.5 * ((initial[0] - final[0]) / p.estimate_cap + 1.0)
    food = 1.0 if final[1] == 0.0 else 0.5 * ((initial[1] - final[1]) / p.estimate_cap + 1.0)
    idensity = min(max(0.5 * (initial[2] - final[2] + 1.0), 0.0), 1.0)
    inest = 0.5 * ((final[0] - initial[0]) / p.estimate_cap + 1.0)
    ifood = (food_final - food_initial + food_radius) / (2.0 * food_radius)
    return density, nest, food, idensity, inest, ifood, float(deliveries)


@numba.njit(cache=True)
def robot_descriptors(counts: np.ndarray, movement: int, rotation: int, p: Params) -> tuple:
    """(movement, rotation, conditionality) of one robot in one trial, each in [0, 1].

    ``movement`` and ``rotation`` are sums over the trial's ticks of ``motors.movement_of`` and
    ``motors.rotation_of`` (each in [-ticks, ticks]), mapped by (x + ticks) / (2 ticks). ``counts`` as the
    tree interpreter keeps them: ``counts[0]`` condition ticks, ``counts[1 + a]`` starts of action ``a``;
    conditionality = conditions / (conditions + starts), 1 when neither happened
    (``CBlackBoard.cpp:518-527``).
    """
    ticks = float(p.ticks)
    conditions = counts[0]
    starts = 0
    for a in range(1, counts.shape[0]):
        starts += counts[a]
    conditionality = 1.0 if conditions + starts == 0 else conditions / float(conditions + starts)
    return (movement + ticks) / (2.0 * ticks), (rotation + ticks) / (2.0 * ticks), conditionality


@numba.njit(cache=True)
def trial_values(
    initial: np.ndarray,
    final: np.ndarray,
    counts: np.ndarray,
    motion: np.ndarray,
    food: np.ndarray,
    deliveries: np.ndarray,
    gap: float,
    p: Params,
) -> np.ndarray:
    """A trial's values (``N_VALUES``): each robot's objectives and descriptors, averaged over robots in id
    order. ``initial``/``final``: n x 3 smoothed values; ``counts``: n x ``N_COUNTS`` tick counts; ``motion``:
    n x 2 (movement, rotation) sums; ``food``: n x 2 true distances from the food region at the trial's first
    and last steps; ``deliveries``: n; ``gap``: the trial's nest-food gap."""
    n = initial.shape[0]
    radius = p.nest_radius + gap
    out = np.zeros(N_VALUES)
    for i in range(n):
        o = robot_objectives(initial[i], final[i], food[i, 0], food[i, 1], deliveries[i], radius, p)
        d = robot_descriptors(counts[i], motion[i, 0], motion[i, 1], p)
        for k in range(N_OBJECTIVES):
            out[k] += o[k]
        for k in range(3):
            out[N_OBJECTIVES + k] += d[k]
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
