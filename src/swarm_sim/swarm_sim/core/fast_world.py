"""``world.physics_step`` for the batch kernels: the same operations on the same numbers, with less work.

``world.physics_step`` is the readable statement of the physics, which the reference road runs; this
``physics_step`` gives the very same bits (``test_fast_world.py`` compares the two on crowded swarms step by
step, and the roads' parity tests compare whole trials) while skipping work whose result is known:

- A substep's solver passes stop at a fixed point: once a whole pass over the contacts and the drives of the
  robots in contact leaves every velocity and impulse bit for bit as it was, the passes left would compute
  the same again. (Bits, not values, compared as integers without branches: a zero that changes its sign
  counts as a change.)
- The commonest contact, one pair of robots and no wall, is solved in locals (``_solve_pair``) with the very
  expressions of ``world._contact_pass`` and ``world._drive_pass`` (``world._contact_solve``,
  ``world._contact_push``, ``world._drive_solve``).
- A stopped robot's target velocity (its speed, a zero, times the cosine and sine of its heading) is a zero
  whose sign follows from the heading's, without calling the cosine and sine.

Robots not in contact take their one drive pass of a substep as there; passes of different robots' drives
touch different numbers, so their order among themselves does not matter.
"""

from __future__ import annotations

import math
from typing import Any

import numba
import numpy as np
from llvmlite import ir as llvm_ir
from numba import types
from numba.extending import intrinsic

from swarm_sim.core import world
from swarm_sim.core._numba_cache import drop_stale_cache
from swarm_sim.model import Params

drop_stale_cache(
    __file__,
    (
        "bt_controller.draws",
        "bt_controller.robot.perception",
        "bt_controller.robot.timeline",
        "bt_controller.language.vocabulary",
        "swarm_sim.model.config",
        "swarm_sim.core.world",
    ),
)

HALF_PI = 0.5 * math.pi


@intrinsic
def _bits(typingctx: object, x: types.Type) -> tuple[object, object] | None:
    """The 64 bits of a float, as an int (a bit cast: no instruction of its own)."""
    if x != types.float64:
        return None

    def codegen(context: Any, builder: Any, signature: object, args: Any) -> Any:  # numba's code generator
        return builder.bitcast(args[0], llvm_ir.IntType(64))

    return types.int64(types.float64), codegen


@numba.njit(cache=True, error_model="numpy", inline="always")
def _change(a: float, b: float) -> int:
    """Nonzero when two floats differ in a bit (a zero that changes its sign, or a NaN for another NaN,
    counts as a change). Changes are OR-ed together without branches; bits rather than values, as a pass
    that leaves every bit of the state as it was leaves it so in every later pass too."""
    return _bits(a) ^ _bits(b)  # type: ignore[call-arg]  # an intrinsic: numba passes the typing context


@numba.njit(cache=True, error_model="numpy", inline="always")
def _differs(a: float, b: float) -> bool:
    """Whether two floats differ in a bit."""
    return _change(a, b) != 0


@numba.njit(cache=True, error_model="numpy", inline="always")
def _solve_pair(motion: np.ndarray, contacts: np.ndarray, i: int, j: int, linear: float, angular: float,
                p: Params) -> None:  # fmt: skip
    """The solver passes of a substep whose only contact is robots i < j: each pass the contact
    (``world._contact_pass``), then i's drive and j's drive (``world._drive_pass``), held in locals and
    written back at the end; stopped early at a fixed point."""
    vix, viy, wi = motion[i, 0], motion[i, 1], motion[i, 2]  # velocity
    jix, jiy, jiw = motion[i, 3], motion[i, 4], motion[i, 5]  # the drive's accumulated impulse
    tix, tiy, tiw = motion[i, 6], motion[i, 7], motion[i, 8]  # target
    vjx, vjy, wj = motion[j, 0], motion[j, 1], motion[j, 2]
    jjx, jjy, jjw = motion[j, 3], motion[j, 4], motion[j, 5]
    tjx, tjy, tjw = motion[j, 6], motion[j, 7], motion[j, 8]
    cn = contacts[i, j, 0]
    ct = contacts[i, j, 1]
    nx = contacts[i, j, 3]
    ny = contacts[i, j, 4]
    r = contacts[i, j, 5]
    for _ in range(p.solver_iterations):
        new_n, new_t = world._contact_solve(vjx - vix, vjy - viy, wi + wj, cn, ct, nx, ny, r, p)
        px, py, turn = world._contact_push(nx, ny, r, new_n - cn, new_t - ct, p)
        i0, i1, i2, i3, i4, i5 = world._drive_solve(
            vix - px, viy - py, wi - turn, jix, jiy, jiw, tix, tiy, tiw, linear, angular
        )
        j0, j1, j2, j3, j4, j5 = world._drive_solve(
            vjx + px, vjy + py, wj - turn, jjx, jjy, jjw, tjx, tjy, tjw, linear, angular
        )
        moved = (
            _change(new_n, cn)
            | _change(new_t, ct)
            | _change(i0, vix)
            | _change(i1, viy)
            | _change(i2, wi)
            | _change(i3, jix)
            | _change(i4, jiy)
            | _change(i5, jiw)
            | _change(j0, vjx)
            | _change(j1, vjy)
            | _change(j2, wj)
            | _change(j3, jjx)
            | _change(j4, jjy)
            | _change(j5, jjw)
        ) != 0
        cn, ct = new_n, new_t
        vix, viy, wi, jix, jiy, jiw = i0, i1, i2, i3, i4, i5
        vjx, vjy, wj, jjx, jjy, jjw = j0, j1, j2, j3, j4, j5
        if not moved:
            break
    motion[i, 0], motion[i, 1], motion[i, 2] = vix, viy, wi
    motion[i, 3], motion[i, 4], motion[i, 5] = jix, jiy, jiw
    motion[j, 0], motion[j, 1], motion[j, 2] = vjx, vjy, wj
    motion[j, 3], motion[j, 4], motion[j, 5] = jjx, jjy, jjw
    contacts[i, j, 0] = cn
    contacts[i, j, 1] = ct


@numba.njit(cache=True, error_model="numpy", inline="always")
def _robot_moved(motion: np.ndarray, i: int, before: np.ndarray) -> bool:
    """Whether robot i's velocity, drive impulse or wall impulses differ from ``before`` (10 values)."""
    moved = False
    for k in range(6):
        moved = moved or _differs(motion[i, k], before[k])
    for k in range(4):
        moved = moved or _differs(motion[i, 11 + k + k // 2], before[6 + k])
    return moved


@numba.njit(cache=True, error_model="numpy", inline="always")
def _solve_all(x: np.ndarray, y: np.ndarray, motion: np.ndarray, contacts: np.ndarray, pairs: np.ndarray,
               before: np.ndarray, near: int, at_walls: int, linear: float, angular: float,
               p: Params) -> None:  # fmt: skip
    """The solver passes of a substep with contacts, as ``world.physics_step`` runs them, stopped early once
    a pass moves no number of the robots in contact and their contacts (``before``: n x 10 workspace)."""
    n = x.shape[0]
    for iteration in range(p.solver_iterations):
        for i in range(n):
            if motion[i, 9] == 1.0:
                for k in range(6):
                    before[i, k] = motion[i, k]
                for k in range(4):
                    before[i, 6 + k] = motion[i, 11 + k + k // 2]
        moved = False
        for k in range(near):
            i = pairs[k, 0]
            j = pairs[k, 1]
            if contacts[i, j, 2] == 1.0:
                old_n = contacts[i, j, 0]
                old_t = contacts[i, j, 1]
                world._contact_pass(motion, contacts, i, j, p)
                moved = moved or _differs(contacts[i, j, 0], old_n) or _differs(contacts[i, j, 1], old_t)
        for i in range(n if at_walls > 0 else 0):
            if motion[i, 13] != 0.0:
                world._wall_pass(motion, i, 0, world._wall_lever(x[i], p), p)
            if motion[i, 16] != 0.0:
                world._wall_pass(motion, i, 1, world._wall_lever(y[i], p), p)
        for i in range(n):
            if motion[i, 9] == 1.0:
                world._drive_pass(motion, i, linear, angular)
                moved = moved or _robot_moved(motion, i, before[i])
            elif iteration == 0 and motion[i, 10] == 1.0:
                world._drive_pass(motion, i, linear, angular)
        if not moved:
            return


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
    before: np.ndarray,
) -> None:
    """``world.physics_step``, to the same bits, faster (see the module); ``before`` (n x 10) is the
    solver's workspace. Allocates nothing, so that a kernel without reference counting can inline it."""
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
        if speed == 0.0 and abs(heading[i]) <= math.pi:
            # speed * cos(heading) and speed * sin(heading) are zeros signed by the product of the signs: the
            # cosine of a double within pi / 2 (as a double) is positive, beyond it negative (never 0), and
            # the sine of a heading in [-pi, pi] has the heading's sign (sin(-0.0) is -0.0).
            motion[i, 6] = speed * (1.0 if abs(heading[i]) <= HALF_PI else -1.0)
            motion[i, 7] = speed * math.copysign(1.0, heading[i])
        else:
            motion[i, 6] = speed * math.cos(heading[i])
            motion[i, 7] = speed * math.sin(heading[i])
        motion[i, 8] = robot_drive[i, a, 1]
    near = world._near_pairs(x, y, motion, contacts, pairs, p)
    active = 0
    for i in range(n):
        if motion[i, 10] == 0.0:
            ax = motion[i, 6] - motion[i, 0]
            ay = motion[i, 7] - motion[i, 1]
            if ax * ax + ay * ay <= linear * linear and abs(motion[i, 8] - motion[i, 2]) <= angular:
                x[i] += motion[i, 0] * h + motion[i, 6] * rest
                y[i] += motion[i, 1] * h + motion[i, 7] * rest
                heading[i] = world.wrap_angle(heading[i] + motion[i, 2] * h + motion[i, 8] * rest)
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
        last = -1
        for i in range(n):
            if motion[i, 10] == 1.0:
                x[i] += motion[i, 0] * h
                y[i] += motion[i, 1] * h
                heading[i] = world.wrap_angle(heading[i] + motion[i, 2] * h)
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
            if contacts[i, j, 2] == 1.0:
                world._apply_contact(motion, contacts, i, j, contacts[i, j, 0], contacts[i, j, 1], p)
            else:
                contacts[i, j, 0] = 0.0
                contacts[i, j, 1] = 0.0
                contacts[i, j, 2] = 1.0
            motion[i, 9] = 1.0
            motion[j, 9] = 1.0
            touching += 1
            last = k
        for i in range(n):
            if motion[i, 10] == 1.0:
                across_x = world._find_wall(motion, i, x[i], 0, p)
                across_y = world._find_wall(motion, i, y[i], 1, p)
                if across_x > 0.0 or across_y > 0.0:
                    motion[i, 9] = 1.0
                    touching += 1
                    at_walls += 1
                motion[i, 0] += motion[i, 3]
                motion[i, 1] += motion[i, 4]
                motion[i, 2] += motion[i, 5]
        if touching == 0:
            for i in range(n):
                if motion[i, 10] == 1.0:
                    world._drive_pass(motion, i, linear, angular)
        elif touching == 1 and at_walls == 0:
            i = pairs[last, 0]
            j = pairs[last, 1]
            _solve_pair(motion, contacts, i, j, linear, angular, p)
            for k in range(n):
                if motion[k, 10] == 1.0 and k != i and k != j:
                    world._drive_pass(motion, k, linear, angular)
        else:
            _solve_all(x, y, motion, contacts, pairs, before, near, at_walls, linear, angular, p)
