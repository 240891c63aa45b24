"""Conditions change the world as stated, in every road, and bad ones are refused with a clear message."""

import json

import numpy as np
import pytest

from bt_controller.language import parse
from swarm_sim.core import setup_chain, world
from swarm_sim.errors import ConditionError
from swarm_sim.evaluation import BatchEvaluator, EvaluationRequest
from swarm_sim.evaluation.cli import evaluate_main
from swarm_sim.model import DEFAULT, Config, apply_conditions, condition_texts
from swarm_sim.roads import reference_road, run_with_controllers
from swarm_sim.tasks import resolve_task

SHORT = Config(ticks=12)
"""A short trial keeps the hand-worked checks quick; the conditions do not depend on its length."""


def _poses_per_step(tree, seed, trial, config):
    poses, readings = [], []

    def on_step(world):
        if world.trial != trial:  # an earlier trial of the chain, run first
            return
        poses.append(world.poses())
        readings.append(world.readings())

    run_with_controllers(parse(tree), seed, trial, config, on_step)
    return np.array(poses), readings


def test_a_dead_robot_never_drives_or_turns_and_moves_only_when_pushed():
    config, record = apply_conditions(["dead-robots=3"], SHORT)
    assert record == {"dead-robots": 3}
    poses, _ = _poses_per_step("forward_left", 4, 0, config)
    gap = 2 * config.robot_radius + 1e-3
    for i in range(3):
        assert (poses[:, i, 2] == poses[0, i, 2]).all()  # heading: never turns
        for step in range(1, len(poses)):
            if (poses[step, i, :2] != poses[step - 1, i, :2]).any():
                others = np.delete(poses[step, :, :2], i, axis=0)
                assert np.hypot(*(others - poses[step, i, :2]).T).min() <= gap, (i, step)
    assert (poses[-1, 3:, 2] != poses[0, 3:, 2]).all()  # the live robots do turn


def test_a_swarm_of_dead_robots_keeps_every_pose_in_both_roads():
    config, _ = apply_conditions(["dead-robots=9"], SHORT)
    poses, _ = _poses_per_step("forward", 2, 1, config)
    assert (poses == poses[0]).all()
    ((_, records),) = BatchEvaluator(config).evaluate_trials([EvaluationRequest("forward", 2, 2)])
    for r in records:
        assert (r.end_poses == r.start_poses).all()
        movement = r.values[world.VALUE_NAMES.index("movement")]
        assert movement == 1.0  # still ticking: movement counts the motors the tree sets, not the motion


def test_dead_robots_still_broadcast():
    config, _ = apply_conditions(["dead-robots=9"], SHORT)
    _, readings = _poses_per_step("stop", 0, 0, config)
    assert sum(len(r.senders) for step in readings for r in step) > 0


def test_message_loss_one_means_no_neighbour_is_ever_heard():
    config, record = apply_conditions(["message-loss=1.0"], SHORT)
    assert config.delivery_probability == 0.0 and record == {"message-loss": 1.0}
    _, readings = _poses_per_step("forward_left", 3, 0, config)
    assert all(len(r.senders) == 0 for step in readings for r in step)
    _, heard = _poses_per_step("forward_left", 3, 0, SHORT)
    assert sum(len(r.senders) for step in heard for r in step) > 0


def test_weak_wheel_scales_the_left_wheel_of_the_last_robots_only():
    config, record = apply_conditions(["weak-wheel=2:0.25"], DEFAULT)
    assert record == {"weak-wheel": [2, 0.25]}
    plain, weak = setup_chain(11, 3).gains, setup_chain(11, 3, config).gains
    assert (weak[:7] == plain[:7]).all()
    assert (weak[7:, 1] == plain[7:, 1]).all()
    assert np.allclose(weak[7:, 0], 0.25 * plain[7:, 0])
    assert (weak[7:, 0] == plain[7:, 0] * 0.25).all()


def test_robots_and_gap_set_the_swarm_and_the_arena():
    config, record = apply_conditions(["gap=650", "robots=5"], DEFAULT)
    assert record == {"robots": 5, "gap": 650.0}
    assert config.n_robots == 5 and config.gaps == (650.0,)
    for chain in range(3):
        setup = setup_chain(1, chain, config)
        assert setup.gap == 650.0 and setup.gains.shape == (5, 2) and setup.position_keys.shape == (5,)


FOOD_SEEKER = "sel(seq(food_left, forward_left), seq(food_right, forward_right), forward)"


def _roads_agree(config):
    """The food seeker's fitness under ``config``, after checking that the batch road and the reference road
    give the same values and end poses."""
    ((result, records),) = BatchEvaluator(config).evaluate_trials([EvaluationRequest(FOOD_SEEKER, 9, 2)])
    values, ref_records = reference_road.evaluate(parse(FOOD_SEEKER), 9, 2, config)
    assert result.fitness + result.descriptors == values
    for a, b in zip(records, ref_records, strict=True):
        assert (a.end_poses == b.end_poses).all()
    return result.fitness


def test_roads_agree_under_every_condition_at_once():
    texts = ["robots=7", "dead-robots=2", "weak-wheel=3:0.5", "message-loss=0.3", "gap=600"]
    config, record = apply_conditions(texts, SHORT)
    assert condition_texts(record) == [
        "dead-robots=2",
        "weak-wheel=3:0.5",
        "message-loss=0.3",
        "robots=7",
        "gap=600.0",
    ]
    normal = BatchEvaluator(SHORT).evaluate([EvaluationRequest(FOOD_SEEKER, 9, 2)])[0]
    assert normal.fitness != _roads_agree(config)


def test_food_disc_puts_a_smaller_food_region_where_the_ring_began_on_every_road():
    config, record = apply_conditions(["gap=600", "food-disc=300"], SHORT)
    assert record == {"gap": 600.0, "food-disc": 300.0}
    ((nest, food),) = config.arena_layout[0]
    assert (nest.shape, nest.radius) == ("disc", 500.0)
    assert (food.kind, food.shape, food.x, food.y, food.radius) == ("food", "disc", 1400.0, 0.0, 300.0)
    # A point on the ring's inner edge is food only on the disc's side; the nest stays where it was.
    assert food.distance(1100.0, 0.0) == 0.0 and food.distance(-1100.0, 0.0) > 0.0
    assert nest.distance(0.0, 0.0) == 0.0
    ring, _ = apply_conditions(["gap=600"], SHORT)
    assert BatchEvaluator(ring).evaluate([EvaluationRequest(FOOD_SEEKER, 9, 2)])[0].fitness != _roads_agree(
        config
    )


def test_food_disc_is_refused_where_there_is_no_2023_arena():
    regions = resolve_task("multifood-arena6").config()
    with pytest.raises(ConditionError, match="the task has regions of its own"):
        apply_conditions(["food-disc=200"], regions)


@pytest.mark.parametrize(
    ("texts", "says"),
    [
        (["food-disc=0"], "expected a radius in (0, 582.482] mm"),
        (["food-disc=600"], "expected a radius in (0, 582.482] mm"),
        (["gap=1800", "food-disc=100"], "expected a radius in (0, 32.4816] mm"),
        (["food-disc=inf"], "finite"),
        (["dead_robots=2"], "unknown condition 'dead_robots'"),
        (["dead-robots"], "expected NAME=VALUE"),
        (["dead-robots=two"], "expected an integer"),
        (["dead-robots=10"], "in [0, 9]"),
        (["robots=4", "dead-robots=5"], "in [0, 4]"),
        (["weak-wheel=2"], "expected K:GAIN"),
        (["weak-wheel=2:1.5"], "GAIN in [0, 1]"),
        (["weak-wheel=3:inf"], "condition weak-wheel=3:inf: expected GAIN, a finite number, got 'inf'"),
        (["weak-wheel=x:0.5"], "condition weak-wheel=x:0.5: expected K, an integer, got 'x'"),
        (["message-loss=1.5"], "probability in [0, 1]"),
        (["message-loss=nan"], "finite"),
        (["robots=0"], "at least 1"),
        (["robots=500"], "do not fit"),
        (["gap=0"], "expected a gap in (0, 1864.96]"),
        (["gap=5000"], "expected a gap"),
        (["gap=600", "gap=700"], "given twice"),
        (["gap="], "expected a value"),
    ],
)
def test_bad_conditions_are_refused_naming_the_problem(texts, says):
    with pytest.raises(ConditionError, match=None) as caught:
        apply_conditions(texts)
    assert says in str(caught.value)
    assert "\n" not in str(caught.value)


def test_evaluate_records_the_conditions_and_refuses_bad_ones(capsys):
    args = ["--tree", "forward", "--trials", "2", "--seed", "3"]
    assert evaluate_main([*args, "--condition", "dead-robots=2", "--condition", "message-loss=0.5"]) == 0
    document = json.loads(capsys.readouterr().out)
    assert document["conditions"] == {"dead-robots": 2, "message-loss": 0.5}
    assert evaluate_main([*args, "--condition", "message-loss=2"]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "--condition: condition message-loss=2" in err
