"""The batch kernels' physics (``fast_world.physics_step``) gives the bits of the reference physics
(``world.physics_step``), step by step, wherever the swarm is: crowds, corners, walls, dead and weak robots,
robots that stop."""

import math

import numpy as np
import pytest

from bt_controller.language import ACTION_INDEX
from swarm_sim.core import fast_world, setup_chain, world
from swarm_sim.model import DEFAULT, Config

P = DEFAULT.params()
STOP = ACTION_INDEX["stop"]


def _bits(*arrays):
    return [np.ascontiguousarray(a).view(np.uint8).copy() for a in arrays]


def _run_both(x, y, h, gains, actions_at, steps, p=P):
    """Run both physics side by side from the same state; return the steps run and how many of them had a
    contact (robots or a wall), failing at the first step whose bits differ."""
    n = len(x)
    drive = world.drive(gains, p)
    ref = [x.copy(), y.copy(), h.copy(), *world.new_dynamics(n)]
    fast = [x.copy(), y.copy(), h.copy(), *world.new_dynamics(n)]
    touched = 0
    for step in range(steps):
        actions = actions_at(step)
        world.physics_step(ref[0], ref[1], ref[2], actions, drive, p, ref[3], ref[4], ref[5])
        solver = np.empty((len(actions), 10))  # the solver's workspace
        fast_world.physics_step(fast[0], fast[1], fast[2], actions, drive, p, *fast[3:6], solver)
        for name, a, b in zip(("x", "y", "heading", "motion", "contacts"), _bits(*ref[:5]), _bits(*fast[:5]),
                              strict=True):  # fmt: skip
            assert (a == b).all(), f"step {step}: {name} differs"
        touched += bool(ref[4][:, :, 2].any() or ref[3][:, [13, 16]].any())
    return touched


@pytest.mark.parametrize("case", range(6))
def test_crowds_pushed_together_and_into_walls(case):
    # Many robots packed near a wall or a corner, mostly driving forward: contacts between several robots at
    # once, against walls, and pairs.
    rng = np.random.default_rng(case)
    n = (9, 16, 25, 9, 12, 30)[case]
    limit = P.arena_half - P.robot_radius
    corner = [(0.0, 0.0), (limit - 700.0, 0.0), (limit - 700.0, limit - 700.0)][case % 3]
    side = math.ceil(math.sqrt(n))
    spacing = 2 * P.robot_radius + 3.0
    k = np.arange(n)
    x = corner[0] + spacing * (k % side) + rng.uniform(-1, 1, n)
    y = corner[1] + spacing * (k // side) + rng.uniform(-1, 1, n)
    h = rng.uniform(-math.pi, math.pi, n)
    gains = rng.uniform(0.9, 1.1, (n, 2))
    if case >= 3:
        gains[: case - 1] = 0.0  # dead robots: zero speeds, some of them negative zeros
    weights = np.full(7, 0.05)
    weights[ACTION_INDEX["forward"]] = 0.7
    plan = rng.choice(7, size=(400, n), p=weights / weights.sum()).astype(np.int64)
    touched = _run_both(x, y, h, gains, lambda s: plan[s // 4], 400)
    assert touched > 100


@pytest.mark.parametrize("trial", range(4))
def test_the_model_swarm_under_random_actions(trial):
    # The nine robots as a trial places them, random actions changed every tick, for a whole trial and more.
    chain = setup_chain(trial, trial % 2, DEFAULT)
    x, y, h = np.zeros(P.n_robots), np.zeros(P.n_robots), np.zeros(P.n_robots)
    world.place_robots(x, y, h, chain.position_keys, chain.heading_keys, 0, P, DEFAULT.arena_arrays(0)[0])
    rng = np.random.default_rng(100 + trial)
    plan = rng.integers(0, 7, size=(300, P.n_robots)).astype(np.int64)
    _run_both(x, y, h, chain.gains, lambda s: plan[s // 4], 1200)


def test_a_stopped_robots_target_without_trigonometry_has_the_signs_of_the_products():
    # A stopped robot's target (a zero) is signed without cos and sin: check headings at the edges where the
    # signs change, for a stopped robot (+0.0 speed) and a dead one reversing (-0.0 speed).
    edges = [0.0, -0.0, math.pi / 2, -math.pi / 2, -math.pi, math.pi, 5e-324, -5e-324, 1.0, -3.0]
    headings = []
    for e in edges:
        headings += [e, np.nextafter(e, 4.0), np.nextafter(e, -4.0)]
    for gains, action in (((1.0, 1.0), STOP), ((0.0, 0.0), ACTION_INDEX["reverse"])):
        for heading in headings:
            x, y = np.array([0.0]), np.array([0.0])
            _run_both(x, y, np.array([heading]), np.array([gains]), lambda s, a=action: np.array([a]), 2)


def test_with_other_physics_settings():
    # Fewer solver passes, more substeps, lower drive limits: the fast path follows the settings too.
    p = Config(solver_iterations=3, physics_substeps=4, max_drive_accel=2000.0, friction=0.9).params()
    rng = np.random.default_rng(9)
    n = 12
    k = np.arange(n)
    x = 175.0 * (k % 4) + rng.uniform(-1, 1, n)
    y = 175.0 * (k // 4) + rng.uniform(-1, 1, n)
    h, gains = rng.uniform(-3, 3, n), rng.uniform(0.9, 1.1, (n, 2))
    plan = rng.integers(0, 7, size=(100, n)).astype(np.int64)
    assert _run_both(x, y, h, gains, lambda s: plan[s // 4], 400, p)
