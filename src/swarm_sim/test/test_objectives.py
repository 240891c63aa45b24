"""Objectives and descriptors on hand-worked trees, with the expected values worked out here."""

import math

import numpy as np
import pytest

from bt_controller.tree import parse
from swarm_sim import reference_road, world
from swarm_sim.config import DEFAULT, Config
from swarm_sim.evaluation import BatchEvaluator, EvaluationRequest
from swarm_sim.trial_data import setup_trial

TRIALS = 4


def both_roads(tree, seed, config, trials=TRIALS):
    """The reference road's values and records; the batch road must agree exactly."""
    values, records = reference_road.evaluate(parse(tree), seed, trials, config)
    result = BatchEvaluator(config).evaluate([EvaluationRequest(tree, seed, trials)])[0]
    assert result.fitness + result.descriptors == values
    return values, records


def test_objective_formulas():
    p = DEFAULT.params()
    initial, final = np.array([3000.0, 4000.0, 0.2]), np.array([2000.0, 4500.0, 0.5])
    density, nest, food = world.robot_objectives(initial, final, False, False, p)
    assert density == pytest.approx((0.5 - 0.2 + 1) / 2)
    assert nest == pytest.approx(((3000 - 2000) / 5000 + 1) / 2)
    assert food == pytest.approx(((4000 - 4500) / 5000 + 1) / 2)
    assert world.robot_objectives(initial, final, True, True, p)[1:] == (1.0, 1.0)
    # density differences beyond [-1, 1] are clipped into [0, 1]
    assert world.robot_objectives(np.array([0, 0, 0.0]), np.array([0, 0, 1.2]), False, False, p)[0] == 1.0
    assert world.robot_objectives(np.array([0, 0, 1.2]), np.array([0, 0, 0.0]), False, False, p)[0] == 0.0


def test_descriptor_formulas():
    p = DEFAULT.params()
    # counts: conditions, then starts of stop, f, fl, fr, r, rl, rr
    counts = np.array([10, 2, 8, 3, 1, 4, 1, 2])
    movement, rotation, conditionality = world.robot_descriptors(counts, p)
    assert movement == (8 - 4 + 40) / 80
    assert rotation == ((3 + 2) - (1 + 1) + 40) / 80
    assert conditionality == 10 / (10 + 21)
    assert world.robot_descriptors(np.zeros(8, np.int64), p)[2] == 1.0


def test_stop_with_lossless_messages():
    # Nobody moves and every message arrives: the estimates settle within 8 steps (9 robots, at most 8
    # hops), so the 7 samples before the first tick equal the last 7: density and estimates do not change.
    # Per robot: density (0 + 1) / 2; nest 1 in the nest, else (0 + 1) / 2; food likewise.
    # stop starts on every other tick and nothing else happens: movement 0, rotation 0, conditionality 0.
    config = Config(delivery_probability=1.0)
    values, records = both_roads("stop", 21, config)
    per_trial = []
    for k, record in enumerate(records):
        s = setup_trial(21, k, config)
        assert (record.end_poses == s.poses).all()
        r = np.hypot(s.poses[:, 0], s.poses[:, 1])
        nest = np.mean(np.where(r <= 500.0, 1.0, 0.5))
        food = np.mean(np.where(r >= 500.0 + s.gap, 1.0, 0.5))
        per_trial.append((0.5, nest, food, 0.5, 0.5, 0.0))
        assert record.values == pytest.approx(per_trial[-1], abs=1e-15)
    assert values == pytest.approx(tuple(np.mean(per_trial, axis=0)), abs=1e-15)


LONE = Config(n_robots=1, gain_low=1.0, gain_high=1.0, delivery_probability=1.0)
"""One robot with perfect wheels: no messages, so its estimates are 0 in a region and 5000 elsewhere."""


def _lone_expectation(start, end, gap):
    """(density, nest, food) objectives of the lone robot, worked from its start and end positions."""
    r0, r1 = math.hypot(*start), math.hypot(*end)

    def region(inside_start, inside_end):
        if inside_end:
            return 1.0
        initial = 0.0 if inside_start else 5000.0
        return ((initial - 5000.0) / 5000.0 + 1.0) / 2.0

    return 0.5, region(r0 <= 500, r1 <= 500), region(r0 >= 500 + gap, r1 >= 500 + gap)


@pytest.mark.parametrize(
    ("tree", "distance", "movement"),
    [
        # forward: started on ticks 0, 2, ..., 38 (20 starts), each drives 0.5 s: 20 x 0.5 s x 50 mm/s.
        ("forward", 500.0, (20 + 40) / 80),
        # seq(forward, reverse): a 3-tick cycle F, R, (sequence done, wheels still): F on ticks 0, 3, .., 39
        # (14), R on 1, 4, .., 37 (13); net one forward half-second: 25 mm.
        ("seq(forward, reverse)", 25.0, (14 - 13 + 40) / 80),
    ],
)
def test_lone_robot_drives_as_worked_out(tree, distance, movement):
    values, records = both_roads(tree, 8, LONE, trials=8)
    expected = []
    for record in records:
        (x0, y0, h0), (x1, y1, h1) = record.start_poses[0], record.end_poses[0]
        assert h1 == h0
        assert (x1, y1) == (
            pytest.approx(x0 + distance * math.cos(h0), abs=1e-9),
            pytest.approx(y0 + distance * math.sin(h0), abs=1e-9),
        )
        objectives = _lone_expectation((x0, y0), (x1, y1), record.gap)
        expected.append((*objectives, movement, 0.5, 0.0))
        assert record.values == pytest.approx(expected[-1], abs=1e-15)
    assert values == pytest.approx(tuple(np.mean(expected, axis=0)), abs=1e-15)


FAR_FOOD = Config(gaps=(1900.0,))
"""Food beyond 2400 mm: out of reach in 20 s from within 1000 mm of the centre, so on_food stays false."""


def test_condition_that_never_holds():
    # seq(on_food, stop): every tick ticks the condition, which fails, and starts nothing.
    values, _ = both_roads("seq(on_food, stop)", 4, FAR_FOOD)
    assert values[3:] == (0.5, 0.5, 1.0)


def test_selector_with_a_turn():
    # sel(on_food, forward_left): tick 0 the condition fails and forward_left starts (running); tick 1
    # forward_left succeeds, so does the selector; repeat. 20 conditions, 20 anticlockwise starts.
    values, _ = both_roads("sel(on_food, forward_left)", 4, FAR_FOOD)
    assert values[3:] == (0.5, (20 + 40) / 80, 20 / (20 + 20))


def test_values_stay_in_the_unit_interval():
    for tree in ["forward", "prob(forward_left, reverse, sel(robot_left, forward_right))", "reverse_left"]:
        values, records = both_roads(tree, 2, DEFAULT)
        for v in [values, *(r.values for r in records)]:
            assert all(0.0 <= x <= 1.0 for x in v)
