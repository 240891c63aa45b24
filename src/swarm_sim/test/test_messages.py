"""Message delivery, ground sensing, estimates, smoothing and the blackboard against brute force."""

import math

import numpy as np
import pytest

from bt_controller.draws import DROPS, stream_key, uniform
from bt_controller.perception import Readings, RobotView
from swarm_sim.core import sense_swarm, setup_chain, world
from swarm_sim.model import DEFAULT, Config

P = DEFAULT.params()
OPEN = Config(occlusion=False).params()
"""No occlusion: for tests of delivery and drops alone."""


def _buffers(n):
    return (
        np.zeros(n, np.int64),
        np.zeros((n, n), np.int64),
        np.zeros((n, n)),
        np.zeros((n, n)),
        np.zeros((n, n)),
    )


def _range(x, y, i, j):
    """The range as the simulator computes it (products, not ``**``, which numpy rounds differently)."""
    dx, dy = x[j] - x[i], y[j] - y[i]
    return math.sqrt(dx * dx + dy * dy)


def _keys(seed, n):
    return np.array([stream_key(seed, 0, i, DROPS) for i in range(n)], dtype=np.uint64)


def test_delivery_rate_within_range_is_095_and_nothing_comes_from_beyond():
    # Robot 0 at the centre; the others at ranges straddling 1 m (so they are far from each other too).
    ranges = np.array([0.0, 200.0, 600.0, 999.0, 1000.0, 1000.001, 1200.0, 3000.0, 170.0])
    angles = np.linspace(0.0, 2 * np.pi, 9, endpoint=False)
    x, y = ranges * np.cos(angles), ranges * np.sin(angles)
    heard = np.zeros((9, 9), np.int64)
    nest, food = np.zeros(9), np.zeros(9)
    counts, senders, r, nv, fv = _buffers(9)
    keys = _keys(3, 9)
    distance = np.array([[_range(x, y, i, j) for j in range(9)] for i in range(9)])
    steps = 4000
    for step in range(steps):
        world.sense_step(x, y, nest, food, keys, step, OPEN, counts, senders, r, nv, fv)
        for i in range(9):
            heard[i, senders[i, : counts[i]]] += 1
            np.testing.assert_array_equal(r[i, : counts[i]], distance[i, senders[i, : counts[i]]])
    within = (distance <= 1000.0) & ~np.eye(9, dtype=bool)
    assert within.sum() > 20 and (~within).sum() > 20
    assert (heard[~within] == 0).all()  # nothing from beyond 1 m, nothing from oneself
    assert heard[0, 4] > 0  # exactly 1 m is within
    n = within.sum() * steps
    rate = heard[within].sum() / n
    assert abs(rate - 0.95) < 4 * math.sqrt(0.95 * 0.05 / n)  # 4 sigma
    for count in heard[within]:  # each ordered pair alone, too
        assert abs(count / steps - 0.95) < 5 * math.sqrt(0.95 * 0.05 / steps)


def test_drops_are_independent_per_ordered_pair():
    x, y = np.array([0.0, 500.0]), np.array([0.0, 0.0])
    z = np.zeros(2)
    counts, senders, r, nv, fv = _buffers(2)
    keys = _keys(9, 2)
    both_dropped = 0
    for step in range(2000):
        world.sense_step(x, y, z, z, keys, step, OPEN, counts, senders, r, nv, fv)
        both_dropped += counts[0] == 0 and counts[1] == 0
    assert both_dropped / 2000 < 0.01  # independent: 0.0025 expected; one shared draw would give 0.05


def _blocked(x, y, i, j) -> bool:
    """Whether a third robot's disc, its centre projecting strictly inside the segment i-j, lies closer
    than its radius to it (plain geometry; the rule of ``world.occluded``)."""
    a, b = np.array([x[i], y[i]]), np.array([x[j], y[j]])
    for m in range(len(x)):
        if m in (i, j):
            continue
        c = np.array([x[m], y[m]])
        t = np.dot(c - a, b - a) / np.dot(b - a, b - a)
        if 0.0 < t < 1.0 and np.linalg.norm(a + t * (b - a) - c) < P.robot_radius:
            return True
    return False


def test_sense_step_matches_a_plain_per_pair_computation():
    rng = np.random.default_rng(4)
    n = 9
    counts, senders, r, nv, fv = _buffers(n)
    keys = _keys(17, n)
    for step in range(200):
        x, y = rng.uniform(-900, 900, n), rng.uniform(-900, 900, n)
        bn, bf = rng.uniform(0, 5000, n), rng.uniform(0, 5000, n)
        world.sense_step(x, y, bn, bf, keys, step, P, counts, senders, r, nv, fv)
        for i in range(n):
            expected = [
                j
                for j in range(n)
                if j != i
                and _range(x, y, i, j) <= 1000.0
                and not _blocked(x, y, i, j)
                and uniform(keys[i], step * n + j) < 0.95
            ]
            assert senders[i, : counts[i]].tolist() == expected
            got = slice(0, counts[i])
            assert (r[i, got] == [_range(x, y, i, j) for j in expected]).all()
            assert (nv[i, got] == bn[expected]).all() and (fv[i, got] == bf[expected]).all()


def _entry(gap: float) -> np.ndarray:
    """The 2023 arena's regions for ``gap`` as compiled code reads them."""
    return Config(gaps=(gap,)).arena_arrays(0)[0]


def test_ground_sensor():
    assert world.ground(0.0, 499.999, _entry(500.0)) == (True, False)
    assert world.ground(0.0, 500.0, _entry(500.0)) == (False, False)  # strictly inside (footbot_bt.cpp:247)
    assert world.ground(999.999, 0.0, _entry(500.0)) == (False, False)
    assert world.ground(600.0, 800.0, _entry(500.0)) == (False, True)
    assert world.ground(600.0, 800.0, _entry(700.0)) == (False, False)
    assert world.ground(0.0, -1200.0, _entry(700.0)) == (False, True)


def test_estimate_matches_brute_force_on_hand_built_readings():
    ranges = np.array([400.0, 250.0, 900.0, 170.0])
    nest = np.array([300.0, 700.0, 0.0, 5000.0])
    food = np.array([5000.0, 5000.0, 4500.0, 4900.0])
    got = world.estimate(False, False, 4, ranges, nest, food, P)
    # nest: 700, 950, 900, 5170 -> 700 from message 0; food: 5400, 5250, 5400, 5070 -> all capped.
    assert got[0] == 700.0 and got[3] == 0
    assert got[1] == 5000.0 and got[4] == -1
    assert got[2] == pytest.approx(
        sum(1.0 / (math.pi * (r / 10000.0) ** 2) for r in ranges) / 6642.0, rel=1e-14
    )
    assert got[5] == 3
    inside = world.estimate(True, True, 4, ranges, nest, food, P)
    assert inside[:2] == (0.0, 0.0) and inside[3:5] == (-1, -1)
    nothing = world.estimate(False, False, 0, ranges, nest, food, P)
    assert nothing == (5000.0, 5000.0, 0.0, -1, -1, -1)
    # ties go to the first message
    tie = world.estimate(False, False, 2, np.array([300.0, 300.0]), np.array([100.0, 100.0]), food, P)
    assert tie[3] == 0 and tie[5] == 0


def _shortest(x, y, sources, cap, max_range):
    """Bellman-Ford from every source robot over links of at most max_range: the converged estimates."""
    n = len(x)
    best = np.where(sources, 0.0, np.inf)
    for _ in range(n):
        for i in range(n):
            if sources[i]:
                continue
            for j in range(n):
                d = math.hypot(x[j] - x[i], y[j] - y[i])
                if j != i and d <= max_range and best[j] + d < best[i]:
                    best[i] = best[j] + d
    return np.minimum(best, cap)


@pytest.mark.parametrize("seed", range(8))
def test_converged_estimates_equal_shortest_hop_paths(seed):
    config = Config(delivery_probability=1.0, occlusion=False)
    p = config.params()
    rng = np.random.default_rng(seed)
    n = 9
    x, y = rng.uniform(-2000, 2000, n), rng.uniform(-2000, 2000, n)
    x[0], y[0] = 100.0, 0.0  # one robot in the nest
    h = rng.uniform(-np.pi, np.pi, n)
    entry = _entry(500.0)
    views = [RobotView(p) for _ in range(n)]
    ground = [world.ground(x[i], y[i], entry) for i in range(n)]
    bn = np.array([world.region_value(g[0], p) for g in ground])
    bf = np.array([world.region_value(g[1], p) for g in ground])
    keys = np.array([stream_key(seed, 0, i, DROPS) for i in range(n)], dtype=np.uint64)
    for step in range(n + 1):
        for i, reading in enumerate(sense_swarm(x, y, h, bn, bf, keys, step, entry, p)):
            views[i].sense(reading)
        bn = np.array([v.nest for v in views])
        bf = np.array([v.food for v in views])
    in_nest = np.array([g[0] for g in ground])
    on_food = np.array([g[1] for g in ground])
    np.testing.assert_allclose(bn, _shortest(x, y, in_nest, 5000.0, 1000.0), rtol=1e-12)
    np.testing.assert_allclose(bf, _shortest(x, y, on_food, 5000.0, 1000.0), rtol=1e-12)
    for i, v in enumerate(views):
        d = np.hypot(x - x[i], y - y[i])
        near = (d <= 1000.0) & (np.arange(n) != i)
        assert v.density == pytest.approx(
            np.sum(1.0 / (np.pi * (d[near] / 10000.0) ** 2)) / 6642.0, rel=1e-12
        )


def test_smoothing_is_the_mean_of_the_last_seven_samples():
    window = np.zeros((7, 3))
    count = 0
    samples = [(float(k), 2.0 * k, 0.5 * k) for k in range(12)]
    for k, s in enumerate(samples):
        count = world.push_sample(window, count, *s)
        last = np.array(samples[max(0, k - 6) : k + 1])
        np.testing.assert_allclose(world.smoothed(window, count), last.mean(axis=0), rtol=1e-15)


def test_blackboard_sides_from_bearings():
    # A robot at the origin facing +y: a neighbour at (-300, 10) is on its left, (300, 10) on its right.
    heading = math.pi / 2
    left = world.bearing(0.0, 0.0, heading, -300.0, 10.0)
    right = world.bearing(0.0, 0.0, heading, 300.0, 10.0)
    assert 0 < left < math.pi and -math.pi < right < 0
    assert world.bearing(0.0, 0.0, 0.0, 100.0, 0.0) == 0.0  # dead ahead: a robot there counts as left
    out = np.zeros(9, np.bool_)
    world.blackboard(False, True, 3000.0, 3000.0, left, right, True, math.nan, True, P, out)
    # on_food, in_nest, food_left, food_right, nest_left, nest_right, robot_left, robot_right, got_food
    assert out.tolist() == [True, False, False, True, True, False, False, False, True]


def test_robot_view_blackboard_uses_the_estimate_sources():
    p = DEFAULT.params()
    view = RobotView(p)
    # Sender 4 gives the best nest estimate and lies left; sender 7 is nearest and lies right; food capped.
    readings = Readings(
        in_nest=False,
        on_food=False,
        senders=np.array([4, 7]),
        ranges=np.array([600.0, 200.0]),
        bearings=np.array([1.0, -2.0]),
        nest=np.array([100.0, 900.0]),
        food=np.array([5000.0, 4900.0]),
    )
    view.sense(readings)
    assert (view.nest, view.food) == (700.0, 5000.0)
    assert view.blackboard().tolist() == [False, False, False, False, True, False, False, True, False]


def test_start_of_trial_broadcasts_and_readings_are_in_sender_order():
    s = setup_chain(2, 0)
    p = DEFAULT.params()
    x, y, h = np.zeros(9), np.zeros(9), np.zeros(9)
    world.place_robots(x, y, h, s.position_keys, s.heading_keys, 0, p, DEFAULT.arena_arrays(0)[0])
    z = np.full(9, 5000.0)
    for reading in sense_swarm(x, y, h, z, z, s.drop_keys, 2, DEFAULT.arena_arrays(0)[0], p):
        assert (np.diff(reading.senders) > 0).all()
        assert len(reading.senders) == len(reading.ranges) == len(reading.bearings)
    assert (world.region_value(True, p), world.region_value(False, p)) == (0.0, 5000.0)
