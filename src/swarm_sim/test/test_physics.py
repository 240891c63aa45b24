"""Physics: differential drive, exact arcs, collisions and walls."""

import math

import numpy as np
import pytest

from bt_controller.vocabulary import ACTION_INDEX
from swarm_sim import world
from swarm_sim.config import DEFAULT, Config
from swarm_sim.trial_data import setup_chain

P = DEFAULT.params()
STEPS_PER_SECOND = round(1 / DEFAULT.step_dt)


def drive(action, gains, seconds=1.0, pose=(0.0, 0.0, 0.0), p=P):
    x, y, h = pose
    for _ in range(round(seconds * STEPS_PER_SECOND)):
        x, y, h = world.move_robot(x, y, h, ACTION_INDEX[action], gains[0], gains[1], p)
    return x, y, h


@pytest.mark.parametrize("gain", [0.9, 1.0, 1.07])
def test_forward_covers_wheel_speed_times_gain(gain):
    x, y, h = drive("forward", (gain, gain), pose=(10.0, -20.0, 0.3))
    assert math.hypot(x - 10.0, y + 20.0) == pytest.approx(50.0 * gain, rel=1e-12)
    assert math.atan2(y + 20.0, x - 10.0) == pytest.approx(0.3)
    assert h == 0.3


def test_reverse_goes_backwards():
    x, y, h = drive("reverse", (1.0, 1.0), seconds=2.0, pose=(0.0, 0.0, math.pi / 2))
    assert (x, y, h) == (pytest.approx(0.0, abs=1e-9), pytest.approx(-100.0), math.pi / 2)


@pytest.mark.parametrize(
    ("action", "wheel", "sign"),
    [("forward_left", 1, 1), ("forward_right", 0, -1), ("reverse_left", 1, -1), ("reverse_right", 0, 1)],
)
def test_one_wheel_turn_rotates_at_the_expected_rate(action, wheel, sign):
    gains = [0.95, 1.05]
    omega = sign * 50.0 * gains[wheel] / 140.0  # rad/s: one wheel at 50 mm/s times its gain
    x, y, h = drive(action, gains, seconds=1.0)
    assert h == pytest.approx(omega, rel=1e-12)
    # The still wheel is the centre of the arc: the robot's centre stays 70 mm from it.
    still_side = 1 if wheel == 1 else -1  # the still wheel lies left (+y) when the right wheel drives
    pivot = (0.0, still_side * 70.0)
    assert math.hypot(x - pivot[0], y - pivot[1]) == pytest.approx(70.0, rel=1e-12)


def test_half_turn_takes_about_72_steps():
    steps = 0
    x, y, h = 0.0, 0.0, 0.0
    while h >= 0.0:  # heading wraps from +pi to -pi once the half turn is done
        x, y, h = world.move_robot(x, y, h, ACTION_INDEX["forward_left"], 1.0, 1.0, P)
        steps += 1
    assert steps == math.ceil(math.pi / (50.0 / 140.0 * 0.125))  # 71 steps at nominal speed


def test_stop_does_not_move():
    assert drive("stop", (1.1, 0.9), pose=(1.0, 2.0, 3.0)) == (1.0, 2.0, 3.0)


def _assert_valid(x, y, p):
    limit = p.arena_half - p.robot_radius
    assert (np.abs(x) <= limit).all() and (np.abs(y) <= limit).all()
    d2 = (x[:, None] - x[None, :]) ** 2 + (y[:, None] - y[None, :]) ** 2
    iu = np.triu_indices(len(x), 1)
    assert (d2[iu] >= (2 * p.robot_radius) ** 2).all(), np.sqrt(d2[iu].min())


@pytest.mark.parametrize("config", [DEFAULT, Config(collision_iterations=0), Config(collision_iterations=1)])
def test_no_overlap_and_no_escape_over_thousands_of_random_steps(config):
    p = config.params()
    rng = np.random.default_rng(5)
    x_before, y_before = np.empty(p.n_robots), np.empty(p.n_robots)
    checked = 0
    for trial in range(6):
        s = setup_chain(trial, trial % 2, config)
        x, y, h = np.zeros(p.n_robots), np.zeros(p.n_robots), np.zeros(p.n_robots)
        world.place_robots(x, y, h, s.position_keys, s.heading_keys, 0, p)
        # Some trials drive mostly forward so that robots pile into walls and each other.
        weights = np.full(7, 1 / 7) if trial % 2 else np.array([0.0, 0.7, 0.1, 0.1, 0.0, 0.05, 0.05])
        for step in range(1500):
            if step % 4 == 0:
                actions = rng.choice(7, size=p.n_robots, p=weights).astype(np.int64)
            world.physics_step(x, y, h, actions, world.arcs(s.gains, p), p, x_before, y_before)
            _assert_valid(x, y, p)
            checked += 1
    assert checked == 9000


def test_crowd_pushed_against_a_corner_stays_valid():
    # Nine robots packed near a corner all drive towards it: pushes and the walls must keep them apart.
    p = DEFAULT.params()
    limit = p.arena_half - p.robot_radius
    xs, ys = np.meshgrid(np.arange(3) * 171.0, np.arange(3) * 171.0)
    x, y = limit - xs.ravel(), limit - ys.ravel()
    h = np.full(9, math.pi / 4)
    gains = np.ones((9, 2))
    actions = np.full(9, ACTION_INDEX["forward"], dtype=np.int64)
    xb, yb = np.empty(9), np.empty(9)
    for _ in range(400):
        world.physics_step(x, y, h, actions, world.arcs(gains, p), p, xb, yb)
        _assert_valid(x, y, p)


def test_head_on_pair_is_pushed_apart_symmetrically():
    p = DEFAULT.params()
    x, y, h = np.array([-86.0, 86.0]), np.array([0.0, 0.0]), np.array([0.0, math.pi])
    actions = np.full(2, ACTION_INDEX["forward"], dtype=np.int64)
    world.physics_step(x, y, h, actions, world.arcs(np.ones((2, 2)), p), p, np.empty(2), np.empty(2))
    assert x[0] == pytest.approx(-x[1]) and x[1] - x[0] >= 170.0
    assert np.abs(y).max() < 1e-9


@pytest.mark.parametrize("friction", [0.0, 0.49])
def test_friction_drags_a_touching_robot_along(friction):
    # Robot 0 moves 6.25 mm along x and 1 mm towards robot 1, which stood still touching it: the overlap
    # d = hypot(6.25, 169) < 170 is corrected along the centres, and with friction robot 1 is also dragged
    # along robot 0's slide by half of 0.49 x the overlap (the slide, about 6.3 mm, is larger).
    p = Config(friction=friction).params()._replace(collision_slack=0.0)
    x_before, y_before = np.array([0.0, 0.0]), np.array([0.0, 170.0])
    x, y = np.array([6.25, 0.0]), np.array([1.0, 170.0])
    overlap = 170.0 - math.hypot(6.25, 169.0)
    world.resolve_collisions(x, y, x_before, y_before, p)
    normal_only = -0.5 * overlap * 6.25 / math.hypot(6.25, 169.0)  # robot 1's x from the normal push alone
    drag = x[1] - normal_only
    assert drag == pytest.approx(0.5 * friction * overlap, rel=0.05, abs=1e-12)
    assert math.hypot(x[1] - x[0], y[1] - y[0]) >= 170.0 - 1e-9
