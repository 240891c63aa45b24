"""Message delivery, ground sensing, estimates, smoothing and the blackboard against brute force."""

import math

import numpy as np
import pytest

from bt_controller.draws import DROPS, stream_key, uniform
from bt_controller.language import CONDITIONS, N_CONDITIONS
from bt_controller.robot import Readings, RobotView
from swarm_sim.core import sense_swarm, setup_chain, world
from swarm_sim.model import DEFAULT, Config, Piece

P = DEFAULT.params()
OPEN = Config(occlusion=False).params()
"""No occlusion: for tests of delivery and drops alone."""


def _buffers(n, regions=2):
    return np.zeros(n, np.int64), np.zeros((n, n), np.int64), np.zeros((n, n)), np.zeros((n, n, regions))


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
    broadcast = np.zeros((9, 2))
    counts, senders, r, values = _buffers(9)
    keys = _keys(3, 9)
    distance = np.array([[_range(x, y, i, j) for j in range(9)] for i in range(9)])
    steps = 4000
    for step in range(steps):
        world.sense_step(x, y, broadcast, keys, step, OPEN, counts, senders, r, values)
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
    z = np.zeros((2, 2))
    counts, senders, r, values = _buffers(2)
    keys = _keys(9, 2)
    both_dropped = 0
    for step in range(2000):
        world.sense_step(x, y, z, keys, step, OPEN, counts, senders, r, values)
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


@pytest.mark.parametrize("regions", [2, 4])
def test_sense_step_matches_a_plain_per_pair_computation(regions):
    rng = np.random.default_rng(4)
    n = 9
    counts, senders, r, values = _buffers(n, regions)
    keys = _keys(17, n)
    for step in range(200):
        x, y = rng.uniform(-900, 900, n), rng.uniform(-900, 900, n)
        broadcast = rng.uniform(0, 5000, (n, regions))
        world.sense_step(x, y, broadcast, keys, step, P, counts, senders, r, values)
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
            assert (values[i, got] == broadcast[expected]).all()


def _entry(gap: float) -> np.ndarray:
    """The 2023 arena's regions for ``gap`` as compiled code reads them."""
    return Config(gaps=(gap,)).arena_arrays(0)[0]


def _ground(x, y, entry, regions=2):
    inside = np.zeros(regions, np.bool_)
    world.ground(x, y, entry, inside)
    return tuple(bool(g) for g in inside)


def test_ground_sensor():
    assert _ground(0.0, 499.999, _entry(500.0)) == (True, False)
    assert _ground(0.0, 500.0, _entry(500.0)) == (False, False)  # strictly inside (footbot_bt.cpp:247)
    assert _ground(999.999, 0.0, _entry(500.0)) == (False, False)
    assert _ground(600.0, 800.0, _entry(500.0)) == (False, True)
    assert _ground(600.0, 800.0, _entry(700.0)) == (False, False)
    assert _ground(0.0, -1200.0, _entry(700.0)) == (False, True)


def test_ground_sensor_reads_each_food_kind():
    layout = ((
        (Piece("nest", "disc", 0.0, 0.0, 400.0), Piece("food", "disc", 1000.0, 0.0, 300.0),
         Piece("food2", "disc", -1000.0, 0.0, 300.0), Piece("food3", "disc", 0.0, 1000.0, 300.0),
         Piece("food3", "disc", 0.0, -1000.0, 300.0)),
    ),)  # fmt: skip
    entry = Config(layout=layout).arena_arrays(0)[0]
    assert _ground(0.0, 0.0, entry, 4) == (True, False, False, False)
    assert _ground(1100.0, 0.0, entry, 4) == (False, True, False, False)
    assert _ground(-1100.0, 0.0, entry, 4) == (False, False, True, False)
    assert _ground(0.0, -1100.0, entry, 4) == (False, False, False, True)  # either piece of kind 3
    assert _ground(0.0, 1100.0, entry, 4) == (False, False, False, True)
    assert _ground(700.0, 700.0, entry, 4) == (False, False, False, False)


def _estimate(inside, count, ranges, values):
    raw, sources = np.zeros(len(inside)), np.zeros(len(inside), np.int64)
    density, nearest = world.estimate(np.array(inside), count, ranges, values, P, raw, sources)
    return raw.tolist(), sources.tolist(), density, nearest


def test_estimate_matches_brute_force_on_hand_built_readings():
    ranges = np.array([400.0, 250.0, 900.0, 170.0])
    values = np.array([[300.0, 5000.0], [700.0, 5000.0], [0.0, 4500.0], [5000.0, 4900.0]])
    raw, sources, density, nearest = _estimate([False, False], 4, ranges, values)
    # nest: 700, 950, 900, 5170 -> 700 from message 0; food: 5400, 5250, 5400, 5070 -> all capped.
    assert raw == [700.0, 5000.0] and sources == [0, -1]
    assert density == pytest.approx(
        sum(1.0 / (math.pi * (r / 10000.0) ** 2) for r in ranges) / 6642.0, rel=1e-14
    )
    assert nearest == 3
    raw, sources, _, _ = _estimate([True, True], 4, ranges, values)
    assert raw == [0.0, 0.0] and sources == [-1, -1]
    assert _estimate([False, False], 0, ranges, values) == ([5000.0, 5000.0], [-1, -1], 0.0, -1)
    # ties go to the first message
    raw, sources, _, nearest = _estimate(
        [False, False], 2, np.array([300.0, 300.0]), np.array([[100.0, 0], [100.0, 0]])
    )
    assert sources[0] == 0 and nearest == 0


def test_estimate_keeps_each_food_kind_apart():
    ranges = np.array([400.0, 250.0])
    values = np.array([[300.0, 5000.0, 100.0, 5000.0], [700.0, 5000.0, 4000.0, 200.0]])
    raw, sources, _, _ = _estimate([False, False, False, True], 2, ranges, values)
    assert raw == [700.0, 5000.0, 500.0, 0.0] and sources == [0, -1, 0, -1]


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
    ground = [_ground(x[i], y[i], entry) for i in range(n)]
    broadcast = np.array([[world.region_value(g, p) for g in inside] for inside in ground])
    keys = np.array([stream_key(seed, 0, i, DROPS) for i in range(n)], dtype=np.uint64)
    for step in range(n + 1):
        for i, reading in enumerate(sense_swarm(x, y, h, broadcast, keys, step, entry, p)):
            views[i].sense(reading)
        broadcast = np.array([v.raw for v in views])
    in_nest = np.array([g[0] for g in ground])
    on_food = np.array([g[1] for g in ground])
    np.testing.assert_allclose(broadcast[:, 0], _shortest(x, y, in_nest, 5000.0, 1000.0), rtol=1e-12)
    np.testing.assert_allclose(broadcast[:, 1], _shortest(x, y, on_food, 5000.0, 1000.0), rtol=1e-12)
    for i, v in enumerate(views):
        d = np.hypot(x - x[i], y - y[i])
        near = (d <= 1000.0) & (np.arange(n) != i)
        assert v.density == pytest.approx(
            np.sum(1.0 / (np.pi * (d[near] / 10000.0) ** 2)) / 6642.0, rel=1e-12
        )


@pytest.mark.parametrize("regions", [2, 3, 4])
def test_smoothing_is_the_mean_of_the_last_seven_samples(regions):
    window = np.zeros((7, regions + 1))
    count = 0
    # columns: nest, food, density, food2, food3 (the density keeps its 2023 column)
    samples = [[float(k), 2.0 * k, 0.5 * k, 3.0 * k, 4.0 * k][: regions + 1] for k in range(12)]
    out = np.zeros(regions + 1)
    for k, s in enumerate(samples):
        raw = np.array([s[c] for c in (0, 1, 3, 4)[:regions]])
        count = world.push_sample(window, count, raw, s[2])
        last = np.array(samples[max(0, k - 6) : k + 1])
        world.smoothed(window, count, count, out)
        np.testing.assert_allclose(out, last.mean(axis=0), rtol=1e-15)


def test_emptied_region_windows_average_only_what_came_since():
    # The 2026 code empties the region windows at a trial's end and keeps the density's: after 10 samples
    # and an emptying, the regions average the 2 new samples, the density the last 7 of all 12.
    window, out = np.zeros((7, 3)), np.zeros(3)
    count = 0
    for k in range(12):
        count = world.push_sample(window, count, np.array([float(k), 2.0 * k]), 0.5 * k)
    world.smoothed(window, count, 2, out)
    np.testing.assert_allclose(out, [10.5, 21.0, 0.5 * np.mean(range(5, 12))], rtol=1e-15)
    world.smoothed(window, count, 0, out)
    assert out[0] == out[1] == 0.0 and out[2] == pytest.approx(0.5 * np.mean(range(5, 12)))


def test_blackboard_sides_from_bearings():
    # A robot at the origin facing +y: a neighbour at (-300, 10) is on its left, (300, 10) on its right.
    heading = math.pi / 2
    left = world.bearing(0.0, 0.0, heading, -300.0, 10.0)
    right = world.bearing(0.0, 0.0, heading, 300.0, 10.0)
    assert 0 < left < math.pi and -math.pi < right < 0
    assert world.bearing(0.0, 0.0, 0.0, 100.0, 0.0) == 0.0  # dead ahead: a robot there counts as left
    out = np.zeros(N_CONDITIONS, np.bool_)
    bearings = np.array([left, right, math.nan, math.nan, math.nan])  # nest, food, robot, food2, food3
    world.blackboard(
        np.array([False, True]), np.array([3000.0, 3000.0]), bearings, True, np.array([True]), P, out
    )
    # on_food, in_nest, food_left, food_right, nest_left, nest_right, robot_left, robot_right, got_food
    assert out[:9].tolist() == [True, False, False, True, True, False, False, False, True]
    # kind 1's numbered conditions repeat the unnumbered ones; the kinds the world lacks are false
    assert out[9:13].tolist() == [True, True, False, True] and not out[13:].any()


def test_blackboard_reads_each_food_kind():
    # kind 2 under the robot and carried, kind 3's source on the left, kind 1 known nowhere
    out = np.zeros(N_CONDITIONS, np.bool_)
    bearings = np.array([math.nan, math.nan, -1.0, math.nan, 0.5])
    raw = np.array([5000.0, 5000.0, 0.0, 800.0])
    world.blackboard(
        np.array([False, False, True, False]), raw, bearings, True, np.array([False, True, False]), P, out
    )
    named = dict(zip(CONDITIONS, out.tolist(), strict=True))
    assert named["robot_right"] and not named["robot_left"]
    assert [named[f"on_food{k}"] for k in (1, 2, 3)] == [False, True, False]
    assert [named[f"got_food{k}"] for k in (1, 2, 3)] == [False, True, False]
    assert [named[f"food_left{k}"] for k in (1, 2, 3)] == [False, False, True]
    assert not any(named[f"food_right{k}"] for k in (1, 2, 3))
    assert (named["on_food"], named["got_food"]) == (False, False)


def test_robot_view_blackboard_uses_the_estimate_sources():
    p = DEFAULT.params()
    view = RobotView(p)
    # Sender 4 gives the best nest estimate and lies left; sender 7 is nearest and lies right; food capped.
    readings = Readings(
        ground=np.array([False, False]),
        senders=np.array([4, 7]),
        ranges=np.array([600.0, 200.0]),
        bearings=np.array([1.0, -2.0]),
        values=np.array([[100.0, 5000.0], [900.0, 4900.0]]),
    )
    view.sense(readings)
    assert view.raw.tolist() == [700.0, 5000.0]
    assert view.blackboard()[:9].tolist() == [False, False, False, False, True, False, False, True, False]


def test_start_of_trial_broadcasts_and_readings_are_in_sender_order():
    s = setup_chain(2, 0)
    p = DEFAULT.params()
    x, y, h = np.zeros(9), np.zeros(9), np.zeros(9)
    world.place_robots(x, y, h, s.position_keys, s.heading_keys, 0, p, DEFAULT.arena_arrays(0)[0])
    z = np.full((9, 2), 5000.0)
    for reading in sense_swarm(x, y, h, z, s.drop_keys, 2, DEFAULT.arena_arrays(0)[0], p):
        assert (np.diff(reading.senders) > 0).all()
        assert len(reading.senders) == len(reading.ranges) == len(reading.bearings)
    assert (world.region_value(True, p), world.region_value(False, p)) == (0.0, 5000.0)
