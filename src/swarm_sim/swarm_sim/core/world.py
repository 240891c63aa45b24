"""The world model as compiled pure functions, split the way the ROS 2 node graph splits it
(``docs/model.md``).

(a) physics: ``place_robots``, ``wheel_gains``, ``drive``, ``new_dynamics``, ``physics_step``;
(b) message delivery and ground sensing: ``ground``, ``occluded``, ``sense_step``, ``bearing``; the robot
types that swap the nest and food kind 1 for odd robots (``Config.robot_types``): ``swaps_regions``,
``swap_ground``, ``swap_sent``, ``swap_received``; the robot groups that pick up only some food kinds
(``Config.carries``): ``can_carry``, ``clear_uncarried``; and the per-robot faults that change them
(``swarm_sim.model.faults``): ``faulty_wheels``, ``faulty_ground``, ``deafen``, ``faulty_bearing``,
``disrupt``;
(c) one robot's view from its own readings (from ``bt_controller.robot.perception``, inlined): ``estimate``,
``push_sample``, ``smoothed``, ``broadcast_value``, ``region_value``, ``blackboard``, ``carry``,
``start_carrying``;
(d) objectives and descriptors: ``region_distance``, ``neighbour_distance``, ``take_probes``,
``take_all_probes``, ``swarm_deliveries``, ``robot_objectives``, ``robot_descriptors``, ``trial_values``,
``mean_values``.

Every function but ``new_dynamics`` (which makes a swarm's physics arrays) is an ``njit`` function: the batch
kernels call them inline and the reference road and the nodes call the very same compiled code from Python,
robot by robot, so both roads compute every number with the same operations in the same order. Arguments
``p`` are ``config.Params``. They, and every function the kernels inline, are compiled with numba's
``error_model="numpy"``: a division by zero gives IEEE's infinity or NaN (as the authors' C++ does) rather
than raising, so no division pays for a test of its divisor (none of the model's divisors is zero).

Conventions: a robot's readings of one sensing step are the messages it received, ordered by sender id;
what a robot broadcasts at step ``k`` reaches the others at step ``k + 1``.
"""

from __future__ import annotations

import math

import numba
import numpy as np

from bt_controller.draws import uniform
from bt_controller.language import ACTION_WHEELS
from bt_controller.robot import perception
from swarm_sim.core._numba_cache import drop_stale_cache
from swarm_sim.model import N_OBJECTIVES, N_VALUES, Params
from swarm_sim.model import (
    OBJECTIVES as OBJECTIVES,
)  # re-exported: the values' order, for world.X readers
from swarm_sim.model import VALUE_NAMES as VALUE_NAMES
from swarm_sim.model.config import (
    CARRY_KIND_BITS,
    FORMATION_LATTICE,
    FORMATION_LOCALISED,
    FORMATION_MARGIN,
    FORMATION_RANDOM,
    FORMATION_TWO_ROBOTS,
)
from swarm_sim.model.faults import (
    BEARING_NOISE,
    DISRUPTIVE,
    DISRUPTIVE_VALUE,
    GROUND_INVERTED,
    GROUND_STUCK,
    RAB_DEAF,
    RAB_MIRRORED,
    RAB_NOISY,
    WEAK_WHEEL_GAIN,
    WHEEL_DEAD,
    WHEEL_REVERSED,
    WHEEL_WEAK,
)

drop_stale_cache(
    __file__,
    (
        "bt_controller.draws",
        "bt_controller.robot.perception",
        "bt_controller.robot.timeline",
        "bt_controller.language.vocabulary",
        "swarm_sim.model.config",
        "swarm_sim.model.faults",
        "swarm_sim.model.objectives",
        "swarm_sim.model.regions",
    ),
)

WHEELS = np.array(ACTION_WHEELS, dtype=np.float64)
"""(left, right) wheel settings of each action, in units of the nominal wheel speed."""

TWO_PI = 2.0 * math.pi


# ---------------------------------------------------------------------------------------------------- (a)


@numba.njit(cache=True, error_model="numpy", inline="always")
def wrap_angle(a: float) -> float:
    """``a`` mapped into [-pi, pi) (one turn of correction at most on each side, as steps are small)."""
    if a >= math.pi:
        a -= TWO_PI
    elif a < -math.pi:
        a += TWO_PI
    return a


@numba.njit(cache=True, error_model="numpy", inline="always")
def _free(x: np.ndarray, y: np.ndarray, i: int, cx: float, cy: float, everyone: bool, p: Params) -> bool:
    """Whether robot ``i`` centred at (cx, cy) overlaps no other robot standing in the arena where that one
    stands now: every robot when ``everyone``, else (at a chain's start) the robots placed before ``i``."""
    min_d2 = (2.0 * p.robot_radius) ** 2
    for j in range(x.shape[0]):
        if j != i and (everyone or j < i):
            dx = x[j] - cx
            dy = y[j] - cy
            if dx * dx + dy * dy < min_d2:
                return False
    return True


@numba.njit(cache=True, error_model="numpy", inline="always")
def _first_disc(entry: np.ndarray, kind: float) -> tuple:
    """(x, y, radius) of the first disc of region ``kind`` in ``entry`` (the formations' target points: the
    authors' nest point and food point 1); the arena's centre and 500 mm when there is none (their default
    target, ``bt_loop_functions.cpp:1247-1250``; ``Config`` refuses a formation whose target is missing)."""
    for m in range(entry.shape[0]):
        if entry[m, 0] == kind and entry[m, 1] == 0.0:
            return entry[m, 2], entry[m, 3], entry[m, 4]
    return 0.0, 0.0, 500.0


@numba.njit(cache=True, error_model="numpy", inline="always")
def start_area(i: int, entry: np.ndarray, p: Params) -> tuple:
    """(x low, x high, y low, y high) of robot ``i``'s start positions (mm): the start square under the
    ``random`` formation; under ``nest`` a square around the nest's point, and under ``localised`` around
    food point 1 for even robots and the nest's point for odd ones, of half side max(r / sqrt 2, 500 mm),
    clipped to ``FORMATION_MARGIN`` inside the walls (``bt_loop_functions.cpp:1202-1292``)."""
    if p.formation == FORMATION_RANDOM:
        return -p.start_half, p.start_half, -p.start_half, p.start_half
    kind = 1.0 if p.formation == FORMATION_LOCALISED and i % 2 == 0 else 0.0
    cx, cy, r = _first_disc(entry, kind)
    half = max(math.sqrt(r * r / 2.0), 500.0)
    limit = p.arena_half - FORMATION_MARGIN
    return max(cx - half, -limit), min(cx + half, limit), max(cy - half, -limit), min(cy + half, limit)


@numba.njit(cache=True, error_model="numpy")
def place_robots(
    x: np.ndarray,
    y: np.ndarray,
    heading: np.ndarray,
    position_keys: np.ndarray,
    heading_keys: np.ndarray,
    position: int,
    p: Params,
    entry: np.ndarray,
) -> None:
    """Place every robot for the ``position``-th trial of a chain, in place, in the start formation
    ``p.formation`` on the regions of ``entry`` (``bt_loop_functions.cpp:176-213`` at a chain's start,
    ``:254-287`` at a teleport, at 6c65001; the formations ``:1093-1314`` at 1cd2358).

    ``random``, ``nest`` and ``localised``: robots are placed one after another in id order: a heading
    uniform in [-pi, pi) (draw ``position`` of the robot's heading stream), then up to ``max_start_attempts``
    positions uniform in its start area (``start_area``; attempt ``a``: draws ``2 (position *
    max_start_attempts + a)`` and the next of its position stream), the first that overlaps no robot where it
    stands now being taken. At a chain's start (``position`` 0) only robots already placed stand in the
    arena, and a robot that finds no place stays where it was created: the origin, heading 0. At a teleport
    every robot stands somewhere, and one that finds no place keeps its pose. ``lattice``: robot ``k`` at
    (k div s - floor(s / 2), k mod s - floor(s / 2)) m for s x s robots (plus 0.5 m each for an even s) with
    a drawn heading; ``two_robots``: robot 0 at (300, 250) mm heading -pi/2, robot 1 at (-300, -250) mm
    heading pi/2.
    """
    n = x.shape[0]
    if position == 0:
        for i in range(n):
            x[i] = 0.0
            y[i] = 0.0
            heading[i] = 0.0
    if p.formation == FORMATION_TWO_ROBOTS:
        for i in range(n):
            x[i] = 300.0 if i == 0 else -300.0
            y[i] = 250.0 if i == 0 else -250.0
            heading[i] = -0.5 * math.pi if i == 0 else 0.5 * math.pi
        return
    side = int(math.sqrt(n) + 0.5)  # the lattice's side (Config checks n is a square)
    for i in range(n):
        h = TWO_PI * uniform(heading_keys[i], position) - math.pi
        if p.formation == FORMATION_LATTICE:
            offset = (side // 2) - (0.5 if side % 2 == 0 else 0.0)
            x[i] = 1000.0 * ((i // side) - offset)
            y[i] = 1000.0 * ((i % side) - offset)
            heading[i] = h
            continue
        x_low, x_high, y_low, y_high = start_area(i, entry, p)
        base = 2 * position * p.max_start_attempts
        for attempt in range(p.max_start_attempts):
            cx = x_low + (x_high - x_low) * uniform(position_keys[i], base + 2 * attempt)
            cy = y_low + (y_high - y_low) * uniform(position_keys[i], base + 2 * attempt + 1)
            if _free(x, y, i, cx, cy, position > 0, p):
                x[i] = cx
                y[i] = cy
                heading[i] = h
                break


@numba.njit(cache=True, error_model="numpy")
def wheel_gains(gain_keys: np.ndarray, p: Params) -> np.ndarray:
    """Each robot's (left, right) wheel gains, drawn once per chain: gain_low + gain_step * U{0 ..
    gain_levels - 1} (``footbot_bt.cpp:73-80``: (90 + rand() % 20) / 100, the right wheel first: draw 0 of
    the robot's gain stream is the right wheel's, draw 1 the left's) (n_robots x 2).

    Damage acts here, on what a trial starts from (``swarm_sim.model.conditions``): robots below
    ``dead_robots`` get gains 0 (they never drive or turn, though others can still push them), and the left
    wheel of the last ``weak_robots`` robots is scaled by ``weak_gain``. Every draw is made either way, so the
    undamaged robots' gains do not depend on the damage.
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


MOTION_FIELDS = 17
"""Columns of a swarm's ``motion`` array, one row per robot (mm/s, rad/s): 0-2 its velocity (vx, vy, w) at
the end of the last substep; 3-5 its drive's accumulated impulse of the last substep, per unit mass (jx, jy)
and per unit moment of inertia (jw); 6-8 this step's target velocity; 9 whether it touches another robot in
the current substep and 10 whether it moves through the substeps in this step (1.0 or 0.0); 11-13 its contact
with the wall across x (normal and tangential impulses per unit mass; the side, +1 or -1, when touching at
the last substep, else 0) and 14-16 with the wall across y."""
CONTACT_FIELDS = 6
"""Entries of a swarm's ``contacts`` array per pair i < j: accumulated normal and tangential impulses per
unit mass (mm/s), 1.0 when the pair touched at the last substep (else 0.0), the unit normal from i to j and
half the centre distance (mm)."""


def new_dynamics(n_robots: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """A swarm at rest with no contacts: the ``motion``, ``contacts`` and ``pairs`` arrays of
    ``physics_step``."""
    return (
        np.zeros((n_robots, MOTION_FIELDS)),
        np.zeros((n_robots, n_robots, CONTACT_FIELDS)),
        np.zeros((n_robots * (n_robots - 1) // 2, 2), dtype=np.int64),
    )


@numba.njit(cache=True, error_model="numpy")
def drive(gains: np.ndarray, p: Params) -> np.ndarray:
    """Every robot's target (speed along its heading, turn rate) for every action (n_robots x actions x 2),
    from its wheel gains: each wheel at (action's setting) x wheel speed x gain (``footbot_bt.h:41-47``), and
    the differential drive's v = (v_left + v_right) / 2, w = (v_right - v_left) / wheel separation (ARGoS's
    ``dynamics2d_differentialsteering_control.cpp``, ``SetWheelVelocity``). Computed once per chain."""
    n = gains.shape[0]
    out = np.empty((n, WHEELS.shape[0], 2))
    for i in range(n):
        for action in range(WHEELS.shape[0]):
            v_left = WHEELS[action, 0] * p.wheel_speed * gains[i, 0]
            v_right = WHEELS[action, 1] * p.wheel_speed * gains[i, 1]
            out[i, action, 0] = 0.5 * (v_left + v_right)
            out[i, action, 1] = (v_right - v_left) / p.wheel_separation
    return out


@numba.njit(cache=True, error_model="numpy", inline="always")
def _drive_solve(
    vx: float,
    vy: float,
    w: float,
    jx: float,
    jy: float,
    jw: float,
    tx: float,
    ty: float,
    tw: float,
    linear: float,
    angular: float,
) -> tuple:
    """One pass of a robot's drive (ARGoS's pivot and gear joints to a kinematic control body, max force 15 N
    and torque 150 N m, ``dynamics2d_velocity_control.cpp``): from its velocity (vx, vy, w), the impulse
    (jx, jy, jw) its drive accumulated in the substep and its target (tx, ty, tw), the new velocity and
    accumulated impulse. The velocity is set to its target unless the accumulated impulse would exceed
    ``linear`` (a vector length) or ``angular``, in which case it is pulled towards it by what is left."""
    ax = jx + (tx - vx)
    ay = jy + (ty - vy)
    length2 = ax * ax + ay * ay
    if length2 <= linear * linear:
        vx = tx
        vy = ty
    else:
        scale = linear / math.sqrt(length2)
        ax *= scale
        ay *= scale
        vx += ax - jx
        vy += ay - jy
    aw = jw + (tw - w)
    if -angular <= aw <= angular:
        w = tw
    else:
        aw = min(max(aw, -angular), angular)
        w += aw - jw
    return vx, vy, w, ax, ay, aw


@numba.njit(cache=True, error_model="numpy", inline="always")
def _drive_pass(motion: np.ndarray, i: int, linear: float, angular: float) -> None:
    """One pass of robot i's drive (``_drive_solve``), in place. (Here and below ``motion`` and ``contacts``
    are indexed whole: a row view would cost a reference count.)"""
    motion[i, 0], motion[i, 1], motion[i, 2], motion[i, 3], motion[i, 4], motion[i, 5] = _drive_solve(
        motion[i, 0],
        motion[i, 1],
        motion[i, 2],
        motion[i, 3],
        motion[i, 4],
        motion[i, 5],
        motion[i, 6],
        motion[i, 7],
        motion[i, 8],
        linear,
        angular,
    )


@numba.njit(cache=True, error_model="numpy", inline="always")
def _contact_push(nx: float, ny: float, r: float, dn: float, dt: float, p: Params) -> tuple:
    """What a normal impulse ``dn`` and a tangential one ``dt`` (per unit mass) at the contact of robots
    i < j (unit normal (nx, ny) from i to j, ``r`` from each centre) do to them: (jx, jy, turn), jx and jy
    added to j's velocity and taken from i's, ``turn`` taken from both spins (moment of inertia per unit mass
    2 R^2: ARGoS gives the footbot ``cpMomentForCircle(m, 0, 2 R)``, ``dynamics2d_footbot_model.cpp``)."""
    jx = nx * dn - ny * dt
    jy = ny * dn + nx * dt
    turn = r * dt / (2.0 * p.robot_radius * p.robot_radius)
    return jx, jy, turn


@numba.njit(cache=True, error_model="numpy", inline="always")
def _apply_contact(
    motion: np.ndarray, contacts: np.ndarray, i: int, j: int, dn: float, dt: float, p: Params
) -> None:
    """Apply a normal impulse ``dn`` and a tangential one ``dt`` (per unit mass) at the contact of robots
    i < j (``_contact_push``): equal and opposite on their centres, and the tangential one turns both."""
    jx, jy, turn = _contact_push(contacts[i, j, 3], contacts[i, j, 4], contacts[i, j, 5], dn, dt, p)
    motion[i, 0] -= jx
    motion[i, 1] -= jy
    motion[j, 0] += jx
    motion[j, 1] += jy
    motion[i, 2] -= turn
    motion[j, 2] -= turn


@numba.njit(cache=True, error_model="numpy", inline="always")
def _contact_solve(
    dvx: float, dvy: float, spin: float, old_n: float, old_t: float, nx: float, ny: float, r: float, p: Params
) -> tuple:
    """One pass of the contact of robots i < j (Chipmunk's ``cpArbiterApplyImpulse``, as ARGoS's dynamics2d
    runs it with no elasticity), from their relative velocity (dvx, dvy) = v_j - v_i, the sum of their spins
    and the normal and tangential impulses accumulated so far: the new accumulated impulses. The normal
    impulse stops any approach of the centres (it never pulls); the tangential impulse stops the sliding of
    the two surfaces at the contact point, each surface moving with its robot's centre and spin, up to
    ``friction`` times the normal impulse (Coulomb)."""
    new_n = max(old_n - 0.5 * (dvx * nx + dvy * ny), 0.0)
    slide = -dvx * ny + dvy * nx - r * spin
    bound = p.friction * new_n
    new_t = min(max(old_t - slide / (2.0 + r * r / (p.robot_radius * p.robot_radius)), -bound), bound)
    return new_n, new_t


@numba.njit(cache=True, error_model="numpy", inline="always")
def _contact_pass(motion: np.ndarray, contacts: np.ndarray, i: int, j: int, p: Params) -> None:
    """One pass of the contact of robots i < j (``_contact_solve``), in place."""
    old_n = contacts[i, j, 0]
    old_t = contacts[i, j, 1]
    new_n, new_t = _contact_solve(
        motion[j, 0] - motion[i, 0],
        motion[j, 1] - motion[i, 1],
        motion[i, 2] + motion[j, 2],
        old_n,
        old_t,
        contacts[i, j, 3],
        contacts[i, j, 4],
        contacts[i, j, 5],
        p,
    )
    contacts[i, j, 0] = new_n
    contacts[i, j, 1] = new_t
    _apply_contact(motion, contacts, i, j, new_n - old_n, new_t - old_t, p)


@numba.njit(cache=True, error_model="numpy", inline="always")
def _apply_wall(motion: np.ndarray, i: int, axis: int, r: float, dn: float, dt: float, p: Params) -> None:
    """Apply a normal impulse ``dn`` (into the wall) and a tangential one ``dt`` (per unit mass) to robot i at
    its contact, ``r`` from its centre, with the wall across ``axis``."""
    side = motion[i, 13 + 3 * axis]
    # normal n: ``side`` along the axis; tangent t = perp(n)
    if axis == 0:
        motion[i, 0] -= side * dn
        motion[i, 1] -= side * dt
    else:
        motion[i, 1] -= side * dn
        motion[i, 0] += side * dt
    motion[i, 2] -= r * dt / (2.0 * p.robot_radius * p.robot_radius)


@numba.njit(cache=True, error_model="numpy", inline="always")
def _wall_pass(motion: np.ndarray, i: int, axis: int, r: float, p: Params) -> None:
    """One pass of robot i's contact with the wall across ``axis`` (0: x, 1: y), the wall a static body: no
    motion into it, and Coulomb friction (``wall_friction``) against the sliding of the robot's surface
    along it."""
    w = 11 + 3 * axis
    side = motion[i, w + 2]
    if axis == 0:
        into = side * motion[i, 0]
        along = side * motion[i, 1]
    else:
        into = side * motion[i, 1]
        along = -side * motion[i, 0]
    old_n = motion[i, w]
    new_n = max(old_n + into, 0.0)
    slide = -(along + r * motion[i, 2])
    old_t = motion[i, w + 1]
    bound = p.wall_friction * new_n
    new_t = min(max(old_t - slide / (1.0 + r * r / (2.0 * p.robot_radius * p.robot_radius)), -bound), bound)
    motion[i, w] = new_n
    motion[i, w + 1] = new_t
    _apply_wall(motion, i, axis, r, new_n - old_n, new_t - old_t, p)


@numba.njit(cache=True, error_model="numpy", inline="always")
def _near_pairs(x: np.ndarray, y: np.ndarray, motion: np.ndarray, contacts: np.ndarray, pairs: np.ndarray,
                p: Params) -> int:  # fmt: skip
    """The pairs i < j that could touch during this step, into ``pairs`` (both robots flagged to move through
    the substeps, as is a robot that could reach a wall); returns how many. The others are farther apart
    than twice the reach of the fastest robot in one step (three times the largest speed, last or target,
    plus the largest spin times the diameter, with 1 mm to spare: contacts redirect speeds but do not add to
    them), and their contact records are cleared, as are the wall contacts of robots far from the walls."""
    n = x.shape[0]
    fastest = 0.0
    spin = 0.0
    for i in range(n):
        fastest = max(
            fastest,
            motion[i, 0] * motion[i, 0] + motion[i, 1] * motion[i, 1],
            motion[i, 6] * motion[i, 6] + motion[i, 7] * motion[i, 7],
        )
        spin = max(spin, abs(motion[i, 2]), abs(motion[i, 8]))
    reach = p.step_dt * (3.0 * math.sqrt(fastest) + 2.0 * p.robot_radius * spin) + 1.0
    wall = p.arena_half - p.robot_radius - reach
    for i in range(n):
        if abs(x[i]) > wall or abs(y[i]) > wall:
            motion[i, 10] = 1.0
        else:
            motion[i, 10] = 0.0
            for k in range(11, MOTION_FIELDS):
                motion[i, k] = 0.0
    limit = 2.0 * p.robot_radius + 2.0 * reach
    limit2 = limit * limit
    count = 0
    for i in range(n):
        for j in range(i + 1, n):
            dx = x[j] - x[i]
            dy = y[j] - y[i]
            if dx * dx + dy * dy <= limit2:
                pairs[count, 0] = i
                pairs[count, 1] = j
                motion[i, 10] = 1.0
                motion[j, 10] = 1.0
                count += 1
            else:
                contacts[i, j, 0] = 0.0
                contacts[i, j, 1] = 0.0
                contacts[i, j, 2] = 0.0
    return count


@numba.njit(cache=True, error_model="numpy", inline="always")
def _find_wall(motion: np.ndarray, i: int, position: float, axis: int, p: Params) -> float:
    """Whether robot i (centre at ``position`` along ``axis``) overlaps the wall across that axis: its lever
    to the contact point, its cached impulses applied first when it touched at the last substep too; 0.0
    when free (the contact cleared)."""
    w = 11 + 3 * axis
    depth = abs(position) + p.robot_radius - p.arena_half
    if depth <= 0.0:
        motion[i, w] = 0.0
        motion[i, w + 1] = 0.0
        motion[i, w + 2] = 0.0
        return 0.0
    side = 1.0 if position > 0.0 else -1.0
    r = p.robot_radius - 0.5 * depth
    if motion[i, w + 2] == side:
        _apply_wall(motion, i, axis, r, motion[i, w], motion[i, w + 1], p)
    else:
        motion[i, w] = 0.0
        motion[i, w + 1] = 0.0
        motion[i, w + 2] = side
    return r


@numba.njit(cache=True, error_model="numpy", inline="always")
def _wall_lever(position: float, p: Params) -> float:
    """The lever of a robot's contact with a wall it overlaps: to the middle of the overlap."""
    return p.robot_radius - 0.5 * (abs(position) + p.robot_radius - p.arena_half)


@numba.njit(cache=True, error_model="numpy", inline="always")
def physics_step(
    x: np.ndarray,
    y: np.ndarray,
    heading: np.ndarray,
    actions: np.ndarray,
    robot_drive: np.ndarray,
    p: Params,
    motion: np.ndarray,
    contacts: np.ndarray,
    pairs: np.ndarray,
) -> None:
    """Advance the swarm one control step in place, as ARGoS's dynamics2d engine (Chipmunk 6) moves footbots.

    Each robot's target velocity is set once, at the step's start: its action's speed along its heading
    then, and its turn rate (``drive``; ``dynamics2d_footbot_model.cpp``, ``UpdateFromEntityStatus``). The
    step is ``physics_substeps`` substeps (``cpSpaceStep``); in each, every robot first moves with the
    velocity it ended the last substep with (so a new action takes effect one substep late), then the
    velocities are solved: the contacts (robots whose discs overlap each other or a wall) and the drives start
    from the impulses they accumulated in the substep before (warm start), then ``solver_iterations`` passes
    go over the contacts and the drives (``_contact_pass``, ``_wall_pass``, ``_drive_pass``); after the first
    pass, only the drives of robots in a contact (a free robot's drive meets its target in one pass, and more
    would not change it). A substep without a contact needs one pass of the drives. A robot that cannot touch
    another robot or a wall during the step (``_near_pairs``) moves in one go: one substep at its last
    velocity and the rest at its target. ``motion``, ``contacts`` (and the workspace ``pairs``) are
    ``new_dynamics``'s arrays; they carry velocities and impulses from step to step, as ARGoS keeps them
    across teleports too.

    This is the readable statement of the physics, which the reference road runs; the batch kernels run
    ``swarm_sim.core.fast_world.physics_step``, which gives the same bits with less work.
    """
    n = x.shape[0]
    substeps = p.physics_substeps
    h = p.step_dt / substeps
    rest = h * (substeps - 1)
    linear = p.max_drive_accel * h
    angular = p.max_turn_accel * h
    touch2 = 4.0 * p.robot_radius * p.robot_radius
    for i in range(n):
        a = actions[i]
        speed = robot_drive[i, a, 0]
        motion[i, 6] = speed * math.cos(heading[i])
        motion[i, 7] = speed * math.sin(heading[i])
        motion[i, 8] = robot_drive[i, a, 1]
    near = _near_pairs(x, y, motion, contacts, pairs, p)
    active = 0
    for i in range(n):
        if motion[i, 10] == 0.0:
            # Near nothing: the first substep at the last velocity, the others at the target, reached in one
            # pass of the drive (unless that pass would be limited: then through the substeps below).
            ax = motion[i, 6] - motion[i, 0]
            ay = motion[i, 7] - motion[i, 1]
            if ax * ax + ay * ay <= linear * linear and abs(motion[i, 8] - motion[i, 2]) <= angular:
                x[i] += motion[i, 0] * h + motion[i, 6] * rest
                y[i] += motion[i, 1] * h + motion[i, 7] * rest
                heading[i] = wrap_angle(heading[i] + motion[i, 2] * h + motion[i, 8] * rest)
                for k in range(3):
                    motion[i, k] = motion[i, 6 + k]
                    motion[i, 3 + k] = 0.0
                continue
            motion[i, 10] = 1.0
        active += 1
    if active == 0:
        return
    for _ in range(substeps):
        touching = 0
        at_walls = 0
        for i in range(n):
            if motion[i, 10] == 1.0:
                x[i] += motion[i, 0] * h
                y[i] += motion[i, 1] * h
                heading[i] = wrap_angle(heading[i] + motion[i, 2] * h)
                motion[i, 9] = 0.0
        for k in range(near):
            i = pairs[k, 0]
            j = pairs[k, 1]
            dx = x[j] - x[i]
            dy = y[j] - y[i]
            d2 = dx * dx + dy * dy
            if d2 >= touch2:
                contacts[i, j, 0] = 0.0
                contacts[i, j, 1] = 0.0
                contacts[i, j, 2] = 0.0
                continue
            d = math.sqrt(d2)
            contacts[i, j, 3] = dx / d if d > 0.0 else 1.0
            contacts[i, j, 4] = dy / d if d > 0.0 else 0.0
            contacts[i, j, 5] = 0.5 * d
            if contacts[i, j, 2] == 1.0:  # touching at the last substep too: its impulses again first
                _apply_contact(motion, contacts, i, j, contacts[i, j, 0], contacts[i, j, 1], p)
            else:
                contacts[i, j, 0] = 0.0
                contacts[i, j, 1] = 0.0
                contacts[i, j, 2] = 1.0
            motion[i, 9] = 1.0
            motion[j, 9] = 1.0
            touching += 1
        for i in range(n):
            if motion[i, 10] == 1.0:
                across_x = _find_wall(motion, i, x[i], 0, p)
                across_y = _find_wall(motion, i, y[i], 1, p)
                if across_x > 0.0 or across_y > 0.0:
                    motion[i, 9] = 1.0
                    touching += 1
                    at_walls += 1
                motion[i, 0] += motion[i, 3]
                motion[i, 1] += motion[i, 4]
                motion[i, 2] += motion[i, 5]
        for iteration in range(p.solver_iterations if touching > 0 else 1):
            if touching > 0:
                for k in range(near):
                    i = pairs[k, 0]
                    j = pairs[k, 1]
                    if contacts[i, j, 2] == 1.0:
                        _contact_pass(motion, contacts, i, j, p)
                for i in range(n if at_walls > 0 else 0):
                    if motion[i, 13] != 0.0:
                        _wall_pass(motion, i, 0, _wall_lever(x[i], p), p)
                    if motion[i, 16] != 0.0:
                        _wall_pass(motion, i, 1, _wall_lever(y[i], p), p)
            for i in range(n):
                if motion[i, 9] == 1.0 or (iteration == 0 and motion[i, 10] == 1.0):
                    _drive_pass(motion, i, linear, angular)


# ---------------------------------------------------------------------------------------------------- (b)


@numba.njit(cache=True, error_model="numpy", inline="always")
def _piece_inside(shape: float, cx: float, cy: float, r: float, x: float, y: float) -> bool:
    """Whether (x, y) lies in a piece (``regions.PIECE_SHAPES`` order: disc, beyond, above, below). A disc
    holds the points strictly closer than its radius (``footbot_bt.cpp:240-247`` at 6c65001: r < 0.5 m),
    beyond its circle those at least its radius away (r >= 0.5 m + gap)."""
    if shape < 2.0:
        dx = x - cx
        dy = y - cy
        d2 = dx * dx + dy * dy
        return d2 < r * r if shape == 0.0 else d2 >= r * r
    return y >= r if shape == 2.0 else y <= -r


@numba.njit(cache=True, error_model="numpy", inline="always")
def _piece_distance(shape: float, cx: float, cy: float, r: float, x: float, y: float) -> float:
    """The distance of (x, y) from a piece, 0 inside (``regions.Piece.distance``)."""
    if shape < 2.0:
        d = math.sqrt((x - cx) * (x - cx) + (y - cy) * (y - cy))
        if shape == 0.0:
            return 0.0 if d <= r else d - r
        return 0.0 if d >= r else r - d
    return max(0.0, r - y) if shape == 2.0 else max(0.0, y + r)


@numba.njit(cache=True, error_model="numpy", inline="always")
def ground(x: float, y: float, entry: np.ndarray, inside: np.ndarray) -> None:
    """The ground sensor: write into ``inside`` (one bool per region the robots perceive, ``REGION_KINDS``
    order: nest, food, food2, food3) whether a robot centred at (x, y) stands in each region of ``entry``
    (pieces x ``regions.PIECE_FIELDS``, ``regions.layout_table``): in a region when in any of its pieces."""
    for r in range(inside.shape[0]):
        inside[r] = False
    for m in range(entry.shape[0]):
        kind = entry[m, 0]
        if kind >= 0.0 and _piece_inside(entry[m, 1], entry[m, 2], entry[m, 3], entry[m, 4], x, y):
            inside[int(kind)] = True


@numba.njit(cache=True, error_model="numpy", inline="always")
def occluded(x: np.ndarray, y: np.ndarray, i: int, j: int, p: Params) -> bool:
    """Whether a third robot's body cuts the segment between the centres of robots ``i`` and ``j``.

    Robot ``m`` occludes when the foot of its centre on the segment's line falls strictly between the ends and
    its distance from the line is below the body radius. (The ends themselves need no test: ``m``'s centre is
    at least two radii from theirs, as robots do not overlap.) Written without divisions: the dot product
    ``d`` against the squared length ``L2`` locates the foot, and the cross product ``c`` gives the distance
    ``|c| / sqrt(L2)``. Every robot is tested, without branching (so the loop runs on vector instructions):
    ``not c * c >= limit`` rather than ``c * c < limit`` keeps what a NaN would do.
    """
    sx = x[j] - x[i]
    sy = y[j] - y[i]
    length2 = sx * sx + sy * sy
    limit = p.robot_radius * p.robot_radius * length2
    hit = False
    for m in range(x.shape[0]):
        mx = x[m] - x[i]
        my = y[m] - y[i]
        c = mx * sy - my * sx
        d = mx * sx + my * sy
        hit |= (not c * c >= limit) & (d > 0.0) & (d < length2) & (m != j)
    return hit


@numba.njit(cache=True, error_model="numpy", inline="always")
def sense_step(
    x: np.ndarray,
    y: np.ndarray,
    broadcast: np.ndarray,
    drop_keys: np.ndarray,
    step: int,
    p: Params,
    counts: np.ndarray,
    senders: np.ndarray,
    ranges: np.ndarray,
    values: np.ndarray,
) -> None:
    """The messages every robot receives at control step ``step`` of a chain.

    Robot ``j``'s message reaches robot ``i`` when their centres are within ``message_range``, no third
    robot's body cuts the segment between them (with ``occlusion``), and draw ``step * n + j`` of ``i``'s
    drop stream (``drop_keys[i]``) is below ``delivery_probability``. It carries what ``j`` broadcast at the
    step before (``broadcast``: n x regions). Robot ``i``'s messages fill the first ``counts[i]`` entries of
    row ``i`` of ``senders`` and ``ranges`` (n x n) and of ``values`` (n x n x regions), in sender order.
    Each pair's range is computed once for both directions (the same bits either way: ``(-d) * (-d) ==
    d * d``).
    """
    n = x.shape[0]
    regions = broadcast.shape[1]
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
                for r in range(regions):
                    values[i, c, r] = broadcast[j, r]
                counts[i] = c + 1
            if uniform(drop_keys[j], step * n + i) < p.delivery_probability:
                c = counts[j]
                senders[j, c] = i
                ranges[j, c] = d
                for r in range(regions):
                    values[j, c, r] = broadcast[i, r]
                counts[j] = c + 1


@numba.njit(cache=True, error_model="numpy", inline="always")
def bearing(x: float, y: float, heading: float, x_other: float, y_other: float) -> float:
    """Bearing of (x_other, y_other) from a robot at (x, y) facing ``heading``, in [-pi, pi)."""
    return wrap_angle(math.atan2(y_other - y, x_other - x) - heading)


# The authors' two robot types (``Config.robot_types`` 2; ``docs/model.md``, "Robot types"): a robot's type
# is its id mod 2 (``bt_loop_functions.cpp:598`` at 1cd2358), and a type-1 (odd) robot perceives the nest and
# food kind 1 the other way round. The world, and the messages on the air, keep the even robots' sense: the
# swap happens where an odd robot reads the ground, receives and sends (``footbot_bt.cpp:242-254, 269,
# 482-488, 527-533``), so its software (perception, tree) is that of an even robot. Region 0 is the nest and
# region 1 food kind 1 (``vocabulary.REGIONS``).


@numba.njit(cache=True, error_model="numpy", inline="always")
def swaps_regions(i: int, p: Params) -> bool:
    """Whether robot ``i`` perceives the nest and food kind 1 swapped: with two robot types, the odd ones."""
    return p.robot_types == 2 and i % 2 == 1


@numba.njit(cache=True, error_model="numpy", inline="always")
def swap_ground(i: int, p: Params, inside: np.ndarray) -> None:
    """What robot ``i``'s ground sensor reads, from where it is (``inside``, written by ``ground``), in
    place: in the nest where food kind 1 is and on food kind 1 where the nest is, if it ``swaps_regions``."""
    if swaps_regions(i, p):
        nest = inside[0]
        inside[0] = inside[1]
        inside[1] = nest


@numba.njit(cache=True, error_model="numpy", inline="always")
def swap_sent(broadcast: np.ndarray, p: Params) -> None:
    """What each robot's message carries on the air, from what it broadcast in its own sense
    (``broadcast``, n x regions), in place: an odd robot's nest and food-1 values exchanged when there are
    two types (``footbot_bt.cpp:482-488``), so that the air carries the even robots' sense."""
    for i in range(broadcast.shape[0]):
        if swaps_regions(i, p):
            nest = broadcast[i, 0]
            broadcast[i, 0] = broadcast[i, 1]
            broadcast[i, 1] = nest


@numba.njit(cache=True, error_model="numpy", inline="always")
def swap_received(counts: np.ndarray, values: np.ndarray, p: Params) -> None:
    """What each robot reads in the messages it received (``sense_step``'s ``counts`` and ``values``), in
    place: the nest and food-1 values of an odd robot's messages exchanged when there are two types
    (``footbot_bt.cpp:527-533``). An odd robot thus hears another odd one in their common sense, and an even
    one swapped."""
    for i in range(counts.shape[0]):
        if swaps_regions(i, p):
            for c in range(counts[i]):
                nest = values[i, c, 0]
                values[i, c, 0] = values[i, c, 1]
                values[i, c, 1] = nest


# Per-robot faults (``swarm_sim.model.faults``): ``faults`` holds each robot's fault code (0: none). Each
# function changes only the faulty robots' values, after the fault-free computation, so every other robot's
# values are those of a world without faults.


# Robot groups that pick up only some food kinds (``Config.carries``; ``docs/model.md``, "Robot types"): robot
# i is in group i mod groups, and a group's kinds are bits of ``Params.carry_masks``. A pick-up rule, not a
# perception one: a robot on a kind it cannot carry senses it as any other, and does not pick it up.


@numba.njit(cache=True, error_model="numpy", inline="always")
def can_carry(i: int, f: int, p: Params) -> bool:
    """Whether robot ``i`` picks up food kind ``f + 1`` (region ``f + 1``): always without groups; else as
    its group ``i mod carry_groups`` may (the groups a team's trees take: robot i runs tree i mod K)."""
    if p.carry_groups == 0:
        return True
    group = i % p.carry_groups
    return (p.carry_masks >> (CARRY_KIND_BITS * group + f)) & 1 == 1


@numba.njit(cache=True, error_model="numpy", inline="always")
def clear_uncarried(i: int, p: Params, standing: np.ndarray) -> None:
    """Where robot ``i`` stands for picking up food (``standing``, regions), in place: the food kinds it
    cannot carry cleared (``can_carry``)."""
    for f in range(standing.shape[0] - 1):
        if not can_carry(i, f, p):
            standing[f + 1] = False


@numba.njit(cache=True, error_model="numpy")
def faulty_wheels(gains: np.ndarray, faults: np.ndarray) -> None:
    """Apply the wheel faults to a chain's wheel gains (``wheel_gains``, n x (left, right)), in place: a
    ``wheel-dead`` left wheel gets gain 0, a ``wheel-weak`` one ``WEAK_WHEEL_GAIN`` times its own, a
    ``wheel-reversed`` one its gain negated."""
    for i in range(gains.shape[0]):
        if faults[i] == WHEEL_DEAD:
            gains[i, 0] = 0.0
        elif faults[i] == WHEEL_WEAK:
            gains[i, 0] *= WEAK_WHEEL_GAIN
        elif faults[i] == WHEEL_REVERSED:
            gains[i, 0] = -gains[i, 0]


@numba.njit(cache=True, error_model="numpy", inline="always")
def faulty_ground(fault: int, inside: np.ndarray) -> None:
    """What a robot with fault ``fault`` reads on its ground sensor, from where it is (``inside``, written
    by ``ground``), in place: in no region when ``ground-stuck``, every region the other way round when
    ``ground-inverted``."""
    if fault == GROUND_STUCK:
        for r in range(inside.shape[0]):
            inside[r] = False
    elif fault == GROUND_INVERTED:
        for r in range(inside.shape[0]):
            inside[r] = not inside[r]


@numba.njit(cache=True, error_model="numpy", inline="always")
def deafen(faults: np.ndarray, counts: np.ndarray) -> None:
    """A ``rab-deaf`` robot receives nothing: its count of messages of ``sense_step`` set to 0."""
    for i in range(counts.shape[0]):
        if faults[i] == RAB_DEAF:
            counts[i] = 0


@numba.njit(cache=True, error_model="numpy", inline="always")
def faulty_bearing(fault: int, value: float, noise_key: np.uint64, step: int, sender: int, n: int) -> float:
    """The bearing ``value`` (``bearing``) of robot ``sender``'s message at chain step ``step`` as a robot
    with fault ``fault`` measures it: its sign flipped when ``rab-mirrored``; when ``rab-noisy``, off by
    ``BEARING_NOISE`` times a uniform draw in [-1, 1) (draw ``step * n + sender`` of the robot's
    ``BEARINGS`` stream ``noise_key``), wrapped into [-pi, pi)."""
    if fault == RAB_MIRRORED:
        return wrap_angle(-value)
    if fault == RAB_NOISY:
        return wrap_angle(value + BEARING_NOISE * (2.0 * uniform(noise_key, step * n + sender) - 1.0))
    return value


@numba.njit(cache=True, error_model="numpy", inline="always")
def disrupt(faults: np.ndarray, broadcast: np.ndarray) -> None:
    """A ``disruptive`` robot's messages carry ``DISRUPTIVE_VALUE`` for every region: its row of
    ``broadcast`` (what ``sense_step`` delivers) overwritten."""
    for i in range(broadcast.shape[0]):
        if faults[i] == DISRUPTIVE:
            for r in range(broadcast.shape[1]):
                broadcast[i, r] = DISRUPTIVE_VALUE


# ---------------------------------------------------------------------------------------------------- (c)
# A robot's perception is robot-side software, defined once in ``bt_controller.robot.perception`` (what the
# controller node runs, and the reference road through its ``RobotView``). The batch kernels inline the very
# same source: numba does not inline calls between separately compiled functions, and inlining these saves
# ~15 %. These wrappers are compiled only where a kernel inlines them (or on a first call from Python); no
# disk cache, as their source file is not this one.

estimate = numba.njit(error_model="numpy", inline="always")(perception.estimate.py_func)
push_sample = numba.njit(error_model="numpy", inline="always")(perception.push_sample.py_func)
smoothed = numba.njit(error_model="numpy", inline="always")(perception.smoothed.py_func)
broadcast_value = numba.njit(error_model="numpy", inline="always")(perception.broadcast_value.py_func)
region_value = numba.njit(error_model="numpy", inline="always")(perception.region_value.py_func)
blackboard = numba.njit(error_model="numpy", inline="always")(perception.blackboard.py_func)
carry = numba.njit(error_model="numpy", inline="always")(perception.carry.py_func)
start_carrying = numba.njit(error_model="numpy", inline="always")(perception.start_carrying.py_func)


# ---------------------------------------------------------------------------------------------------- (d)


@numba.njit(cache=True, error_model="numpy", inline="always")
def region_distance(x: float, y: float, entry: np.ndarray, kind: int) -> float:
    """A robot's true distance from region ``kind`` (``regions.REGION_KINDS`` order) of ``entry``: from its
    nearest piece, 0 inside. In the 2023 arena, the food distance is max(0, R - r) with R = nest_radius + gap
    (``CBlackBoard.cpp:185-201, 276-292`` at a73e4af; the inverse food objective's positions)."""
    nearest = math.inf
    for m in range(entry.shape[0]):
        if entry[m, 0] == kind:
            nearest = min(nearest, _piece_distance(entry[m, 1], entry[m, 2], entry[m, 3], entry[m, 4], x, y))
    return nearest


@numba.njit(cache=True, error_model="numpy", inline="always")
def neighbour_distance(x: np.ndarray, y: np.ndarray, i: int) -> float:
    """Robot ``i``'s mean true distance from the other robots (0 when it is alone)."""
    n = x.shape[0]
    if n < 2:
        return 0.0
    total = 0.0
    for j in range(n):
        if j != i:
            total += math.sqrt((x[j] - x[i]) ** 2 + (y[j] - y[i]) ** 2)
    return total / (n - 1)


@numba.njit(cache=True, error_model="numpy", inline="always")
def take_probes(
    x: np.ndarray, y: np.ndarray, i: int, entry: np.ndarray, probes: np.ndarray, when: int, p: Params
) -> None:
    """Write robot ``i``'s probes (``objectives.PROBES``, true quantities of the world) into
    ``probes[i, when]``, ``when`` 0 at a trial's first step and 1 at its last (or the step being scored).
    Every road calls this at those steps, so a probe added here reaches every road's objectives. The food
    distance is from the robot's own food kind 1: the nest for a robot that ``swaps_regions`` (the
    authors' odd robots measure their food distance to the other region, ``footbot_bt.cpp:242-260``)."""
    probes[i, when, 0] = region_distance(x[i], y[i], entry, 0 if swaps_regions(i, p) else 1)
    probes[i, when, 1] = neighbour_distance(x, y, i)


@numba.njit(cache=True, error_model="numpy", inline="always")
def take_all_probes(
    x: np.ndarray, y: np.ndarray, entry: np.ndarray, probes: np.ndarray, when: int, p: Params
) -> None:
    """``take_probes`` for every robot."""
    for i in range(x.shape[0]):
        take_probes(x, y, i, entry, probes, when, p)


@numba.njit(cache=True, error_model="numpy")
def robot_objectives(
    initial: np.ndarray,
    final: np.ndarray,
    first: np.ndarray,
    last: np.ndarray,
    deliveries: np.ndarray,
    swarm: np.ndarray,
    food_radius: float,
    p: Params,
) -> tuple:
    """The objectives of one robot in one trial, ``OBJECTIVES`` order (``CBlackBoard.cpp:85-96, 224-235,
    343-347`` at 6c65001; the inverse ones and foraging ``CBlackBoard.cpp:98-104, 247-261, 355-359`` and
    ``footbot_bt.cpp:563-566`` at a73e4af; per kind and biased ``footbot_bt.cpp:977-986`` and
    ``utilities.py:307-312, 329-348`` at 1cd2358). The mapping column of ``objectives.OBJECTIVE_TABLE``, row
    by row.

    ``initial`` and ``final`` are the smoothed (nest, food, density) at the trial's initial and last steps;
    ``first`` and ``last`` the robot's probes (``take_probes``) at the trial's first and last steps;
    ``deliveries`` its deliveries per food kind; ``swarm`` the swarm's deliveries per food kind per robot
    (``swarm_deliveries``), for the objectives that are the swarm's.
    Density: (final - initial + 1) / 2, clipped to [0, 1]; nest and food: distances normalised by the cap,
    ((initial - final) / cap + 1) / 2, or 1 when the final smoothed value is 0. Inverse density: (initial -
    final + 1) / 2, clipped; inverse nest: ((final - initial) / cap + 1) / 2, with no rule for the nest;
    inverse food: from the true distances from the food region at the trial's first and last steps
    (``region_distance``), (final - initial + R) / (2 R) with R = ``food_radius`` (the nest's food distance,
    ``regions.food_scale``: nest_radius + gap in the 2023 arena). Foraging: the deliveries of every kind;
    foraging1-3 those of one kind (0 for a kind the world lacks); foraging_biased those of
    ``p.preferred_food`` plus ``p.other_food_weight`` times the others' (all of them when none is
    preferred); foraging_balanced the swarm's: K times the least over the arena's K food kinds of ``swarm``
    (every robot gets it, so the mean over robots is the swarm's value; ``foraging``'s mean for one kind).
    Aggregation: from the mean true distances from the other robots (``neighbour_distance``),
    ((first - last) / first + 1) / 2, clipped to [0, 1]; 0.5 for a robot alone.
    """
    density = min(max(0.5 * (final[2] - initial[2] + 1.0), 0.0), 1.0)
    nest = 1.0 if final[0] == 0.0 else 0.5 * ((initial[0] - final[0]) / p.estimate_cap + 1.0)
    food = 1.0 if final[1] == 0.0 else 0.5 * ((initial[1] - final[1]) / p.estimate_cap + 1.0)
    idensity = min(max(0.5 * (initial[2] - final[2] + 1.0), 0.0), 1.0)
    inest = 0.5 * ((final[0] - initial[0]) / p.estimate_cap + 1.0)
    ifood = (last[0] - first[0] + food_radius) / (2.0 * food_radius)
    spread = first[1]
    aggregation = 0.5 if spread == 0.0 else min(max(0.5 * ((spread - last[1]) / spread + 1.0), 0.0), 1.0)
    kinds = deliveries.shape[0]
    kind1 = float(deliveries[0])
    kind2 = float(deliveries[1]) if kinds > 1 else 0.0
    kind3 = float(deliveries[2]) if kinds > 2 else 0.0
    total = kind1 + kind2 + kind3
    biased = total
    if p.preferred_food > 0:
        preferred = float(deliveries[p.preferred_food - 1])
        biased = preferred + p.other_food_weight * (total - preferred)
    least = swarm[0]
    for k in range(1, swarm.shape[0]):
        least = min(least, swarm[k])
    balanced = swarm.shape[0] * least
    return (
        density, nest, food, idensity, inest, ifood, total, aggregation,
        kind1, kind2, kind3, biased, balanced,
    )  # fmt: skip


@numba.njit(cache=True, error_model="numpy")
def swarm_deliveries(deliveries: np.ndarray) -> np.ndarray:
    """The swarm's deliveries of each food kind per robot: ``deliveries`` (robots x food kinds) summed over
    the robots, in id order, and divided by their number (the ``swarm`` of ``robot_objectives``)."""
    n, kinds = deliveries.shape
    out = np.zeros(kinds)
    for i in range(n):
        for f in range(kinds):
            out[f] += deliveries[i, f]
    for f in range(kinds):
        out[f] /= n
    return out


@numba.njit(cache=True, error_model="numpy")
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


@numba.njit(cache=True, error_model="numpy")
def trial_values(
    initial: np.ndarray,
    final: np.ndarray,
    counts: np.ndarray,
    motion: np.ndarray,
    probes: np.ndarray,
    deliveries: np.ndarray,
    food_scale: float,
    p: Params,
) -> np.ndarray:
    """A trial's values (``N_VALUES``): each robot's objectives and descriptors, averaged over robots in id
    order. ``initial``/``final``: n x (regions + 1) smoothed values; ``counts``: n x ``N_COUNTS`` tick counts;
    ``motion``: n x 2 (movement, rotation) sums; ``probes``: n x 2 x ``objectives.N_PROBES``, each robot's
    probes at the trial's first and last steps (``take_probes``); ``deliveries``: n x food kinds;
    ``food_scale``: the unit of the inverse food objective (``regions.food_scale`` of the trial's entry)."""
    n = initial.shape[0]
    radius = food_scale
    out = np.zeros(N_VALUES)
    swarm = swarm_deliveries(deliveries)
    for i in range(n):
        o = robot_objectives(
            initial[i], final[i], probes[i, 0], probes[i, 1], deliveries[i], swarm, radius, p
        )
        d = robot_descriptors(counts[i], motion[i, 0], motion[i, 1], p)
        for k in range(N_OBJECTIVES):
            out[k] += o[k]
        for k in range(3):
            out[N_OBJECTIVES + k] += d[k]
    for k in range(N_VALUES):
        out[k] /= n
    return out


@numba.njit(cache=True, error_model="numpy")
def mean_values(per_trial: np.ndarray) -> np.ndarray:
    """An evaluation's values: per-trial values (trials x ``N_VALUES``) averaged in trial order."""
    out = np.zeros(N_VALUES)
    for t in range(per_trial.shape[0]):
        for k in range(N_VALUES):
            out[k] += per_trial[t, k]
    for k in range(N_VALUES):
        out[k] /= per_trial.shape[0]
    return out
