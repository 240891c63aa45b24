"""Physics: the differential drive, the one-substep lag of a new action, contacts with friction, walls.

The model is ARGoS's dynamics2d (Chipmunk) as it moves footbots (``docs/model.md``, "World and robots");
the numbers below are worked from its rules, not read off the code."""

import math

import numpy as np
import pytest

from bt_controller.language import ACTION_INDEX
from swarm_sim.core import setup_chain, world
from swarm_sim.model import DEFAULT, Config

P = DEFAULT.params()
STEPS_PER_SECOND = round(1 / DEFAULT.step_dt)
H = DEFAULT.step_dt / DEFAULT.physics_substeps
"""One physics substep (s)."""
R = DEFAULT.robot_radius


class Swarm:
    """Robots and the physics state they carry from step to step."""

    def __init__(self, poses, gains=None, p=P):
        poses = np.array(poses, dtype=np.float64)
        self.x, self.y, self.h = poses[:, 0].copy(), poses[:, 1].copy(), poses[:, 2].copy()
        n = len(self.x)
        self.p = p
        self.drive = world.drive(np.ones((n, 2)) if gains is None else np.array(gains, dtype=np.float64), p)
        self.state = world.new_dynamics(n)

    def step(self, actions, steps=1):
        acts = np.array([ACTION_INDEX[a] for a in actions], dtype=np.int64)
        for _ in range(steps):
            world.physics_step(self.x, self.y, self.h, acts, self.drive, self.p, *self.state)

    def velocity(self, i):
        return self.state[0][i, :3].copy()

    def distance(self, i, j):
        return math.hypot(self.x[j] - self.x[i], self.y[j] - self.y[i])


@pytest.mark.parametrize("gain", [0.9, 1.0, 1.07])
def test_forward_from_rest_covers_wheel_speed_times_gain_less_one_substep(gain):
    s = Swarm([(10.0, -20.0, 0.3)], gains=[(gain, gain)])
    s.step(["forward"], STEPS_PER_SECOND)
    # the first substep still moves at the velocity before (rest): 1 s less one substep at 50 gain mm/s
    assert math.hypot(s.x[0] - 10.0, s.y[0] + 20.0) == pytest.approx(50.0 * gain * (1.0 - H), rel=1e-12)
    assert math.atan2(s.y[0] + 20.0, s.x[0] - 10.0) == pytest.approx(0.3)
    assert s.h[0] == 0.3
    assert s.velocity(0)[:2] == pytest.approx([50.0 * gain * math.cos(0.3), 50.0 * gain * math.sin(0.3)])


def test_a_new_action_takes_effect_one_substep_late():
    s = Swarm([(0.0, 0.0, math.pi / 2)])
    s.step(["forward"], 4)
    y = s.y[0]
    s.step(["reverse"])  # one substep at +50 mm/s, the other nine at -50 mm/s
    assert s.y[0] - y == pytest.approx(50.0 * H - 9 * 50.0 * H, rel=1e-12)
    s.step(["stop"])
    assert s.y[0] - (y - 8 * 50.0 * H) == pytest.approx(-50.0 * H, rel=1e-12)
    y = s.y[0]
    s.step(["stop"], 3)
    assert s.y[0] == y and abs(s.x[0]) < 1e-12


@pytest.mark.parametrize(
    ("action", "wheel", "sign"),
    [("forward_left", 1, 1), ("forward_right", 0, -1), ("reverse_left", 1, -1), ("reverse_right", 0, 1)],
)
def test_one_wheel_turn_rotates_at_the_expected_rate(action, wheel, sign):
    gains = [(0.95, 1.05)]
    omega = sign * 50.0 * gains[0][wheel] / 140.0  # rad/s: one wheel at 50 mm/s times its gain
    s = Swarm([(0.0, 0.0, 0.0)], gains=gains)
    s.step([action], STEPS_PER_SECOND)
    assert s.h[0] == pytest.approx(omega * (1.0 - H), rel=1e-12)
    # Each step goes straight along the heading it started with (ARGoS sets the target velocity once per
    # step), so the centre stays within a fraction of a millimetre of the arc around the still wheel.
    still_side = 1 if wheel == 1 else -1  # the still wheel lies left (+y) when the right wheel drives
    assert math.hypot(s.x[0], s.y[0] - still_side * 70.0) == pytest.approx(70.0, abs=1.0)


def test_stop_does_not_move():
    s = Swarm([(1.0, 2.0, 3.0)], gains=[(1.1, 0.9)])
    s.step(["stop"], 8)
    assert (s.x[0], s.y[0], s.h[0]) == (1.0, 2.0, 3.0)


def test_a_robot_moves_the_same_whether_or_not_others_are_near():
    # Far from everyone a robot moves in one go; near another it goes through the substeps: the same motion.
    alone = Swarm([(0.0, 0.0, 0.4), (2000.0, 0.0, 0.0)])
    near = Swarm([(0.0, 0.0, 0.4), (-200.0, 0.0, 0.0)])
    for actions in (["forward_left", "stop"], ["reverse", "stop"], ["forward_right", "stop"]):
        alone.step(actions, 3)
        near.step(actions, 3)
    assert near.distance(0, 1) > 2 * R  # never touched
    assert (near.x[0], near.y[0], near.h[0]) == pytest.approx((alone.x[0], alone.y[0], alone.h[0]), abs=1e-9)


def _max_overlap(x, y):
    d2 = (x[:, None] - x[None, :]) ** 2 + (y[:, None] - y[None, :]) ** 2
    iu = np.triu_indices(len(x), 1)
    return 2 * R - math.sqrt(d2[iu].min())


def test_head_on_pair_stalls_symmetrically_touching():
    s = Swarm([(-86.0, 0.0, 0.0), (86.0, 0.0, math.pi)])
    s.step(["forward", "forward"], 40)
    assert s.x[0] == pytest.approx(-s.x[1]) and np.abs(s.y).max() < 1e-9
    assert 2 * R - 1.0 < s.distance(0, 1) < 2 * R  # in contact, overlapping by less than a millimetre
    assert abs(s.velocity(0)[0]) < 1e-6  # the drives push equally: neither moves


def test_a_driving_robot_pushes_a_stopped_one_at_half_speed():
    # Equal drives (15 N each in ARGoS): the pusher's forward push and the stopped robot's brake cancel, so
    # the pair keeps the speed the contact left it, half the pusher's.
    s = Swarm([(0.0, 0.0, 0.0), (172.0, 0.0, 0.0)])
    s.step(["forward", "stop"], 8)
    x1 = s.x[1]
    s.step(["forward", "stop"], 8)
    assert s.x[1] - x1 == pytest.approx(25.0, rel=0.02)
    assert 2 * R - 1.0 < s.distance(0, 1) < 2 * R


@pytest.mark.parametrize("friction", [0.0, 0.49])
def test_friction_at_a_pressed_contact_drags_along_the_spinning_surface(friction):
    # Robot 0 turns right on its left wheel (its centre moves +x, its body spins clockwise); robot 1, above
    # it, drives down into it. The surface of robot 0 at the contact moves +x at 25 + 85 x 50/140 mm/s: with
    # friction it drags robot 1 along +x; without, robot 1 is only pushed back along the line of centres.
    p = Config(friction=friction).params()
    s = Swarm([(0.0, 0.0, 0.0), (0.0, 2 * R + 0.5, -math.pi / 2)], p=p)
    s.step(["forward_right", "forward"], 4)
    if friction == 0.0:
        assert abs(s.x[1]) < 2.0  # only the normal push, nearly along y while the pair stays upright
    else:
        assert s.x[1] > 5.0
    assert s.distance(0, 1) > 2 * R - 1.0


@pytest.mark.parametrize("forward_weight", [0.0, 0.7])
def test_overlaps_stay_within_two_millimetres_over_thousands_of_random_steps(forward_weight):
    # Robots overlap each other or a wall only by what one substep's motion brings before the contact stops it
    # (ARGoS pushes overlapping bodies apart only beyond 10 cm, Chipmunk's collision slop).
    rng = np.random.default_rng(5)
    limit = P.arena_half - P.robot_radius
    worst, checked = 0.0, 0
    for trial in range(4):
        chain = setup_chain(trial, trial % 2, DEFAULT)
        x, y, h = np.zeros(P.n_robots), np.zeros(P.n_robots), np.zeros(P.n_robots)
        world.place_robots(x, y, h, chain.position_keys, chain.heading_keys, 0, P, DEFAULT.arena_arrays(0)[0])
        drive = world.drive(chain.gains, P)
        state = world.new_dynamics(P.n_robots)
        # Mostly forward: robots pile into walls and each other.
        weights = np.full(7, (1 - forward_weight) / 7)
        weights[ACTION_INDEX["forward"]] += forward_weight
        for step in range(1500):
            if step % 4 == 0:
                actions = rng.choice(7, size=P.n_robots, p=weights).astype(np.int64)
            world.physics_step(x, y, h, actions, drive, P, *state)
            worst = max(worst, _max_overlap(x, y), np.abs(x).max() - limit, np.abs(y).max() - limit)
            checked += 1
    assert checked == 6000 and worst < 2.0


def test_crowd_pushed_into_a_corner_stays_inside_with_small_overlaps():
    limit = P.arena_half - P.robot_radius
    xs, ys = np.meshgrid(np.arange(3) * 172.0, np.arange(3) * 172.0)
    poses = [(limit - a, limit - b, math.pi / 4) for a, b in zip(xs.ravel(), ys.ravel(), strict=True)]
    s = Swarm(poses)
    for _ in range(400):
        s.step(["forward"] * 9)
        assert (np.abs(s.x) <= limit + 2.0).all() and (np.abs(s.y) <= limit + 2.0).all()
        assert _max_overlap(s.x, s.y) < 2.0
