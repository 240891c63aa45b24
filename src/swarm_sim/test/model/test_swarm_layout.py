"""Heterogeneous swarms (``swarm_sim.model.swarm_layout``): a tree per robot, in both roads, bit for bit."""

import json

import numpy as np
import pytest

from bt_controller.language import parse
from swarm_sim.evaluation import BatchEvaluator, EvaluationRequest, SwarmRequest
from swarm_sim.model import Config, LayoutError, SwarmLayout, layout_from_json, load_layout, of_trees
from swarm_sim.roads import record_trial, record_trial_reference, reference_road
from swarm_sim.tasks import FORAGING

NEST = "sel(seq(in_nest, stop), seq(nest_left, forward_left), seq(nest_right, forward_right), forward)"
FOOD = (
    "sel(seq(on_food, stop), seq(food_left, forward_left), seq(food_right, forward_right), "
    "prob(forward, reverse_left))"
)
FLOCK = "sel(seq(robot_left, forward_left), seq(robot_right, forward_right), prob(forward, reverse_right))"
MIXED = (NEST, NEST, FOOD, FLOCK, FOOD, NEST, FLOCK, FLOCK, FOOD)
"""Three different trees over nine robots, each reading other sides of the blackboard."""


def _records_equal(a, b):
    return len(a) == len(b) and all(
        x.values == y.values and (x.start_poses == y.start_poses).all() and (x.end_poses == y.end_poses).all()
        for x, y in zip(a, b, strict=True)
    )


CONFIGS = pytest.mark.parametrize(
    "config",
    [Config(), Config(profile="clean"), FORAGING.config("paper")],
    ids=["paper", "clean", "foraging"],
)


@CONFIGS
def test_nine_equal_trees_give_the_homogeneous_bits_on_both_roads(config):
    trials = 6 if config.ticks < 100 else 2
    [(expected, expected_records)] = BatchEvaluator(config).evaluate_trials(
        [EvaluationRequest(NEST, 4, trials)]
    )
    # the same tree spelled twice: two packed trees, so the per-robot path runs, with the homogeneous bits
    spelled = tuple(NEST if i % 2 else NEST.replace(", ", ",") for i in range(9))
    for layout in (SwarmLayout.uniform(NEST, 9), SwarmLayout(spelled)):
        [(result, records)] = BatchEvaluator(config).evaluate_trials([SwarmRequest(layout, 4, trials)])
        assert result == expected
        assert _records_equal(records, expected_records)
    values, ref_records = reference_road.evaluate(SwarmLayout(spelled).parsed(), 4, trials, config)
    assert values == expected.fitness + expected.descriptors
    assert _records_equal(ref_records, expected_records)


@CONFIGS
def test_roads_agree_on_a_heterogeneous_swarm(config):
    trials = 6 if config.ticks < 100 else 2
    layout = of_trees(MIXED, 9)
    [(result, records)] = BatchEvaluator(config).evaluate_trials([SwarmRequest(layout, 11, trials)])
    assert result.ok, result.error
    values, ref_records = reference_road.evaluate(layout.parsed(), 11, trials, config)
    assert result.fitness + result.descriptors == values
    assert _records_equal(records, ref_records)


def test_roads_agree_step_by_step_on_a_heterogeneous_swarm():
    # the recording's per-step poses, actions and messages, trial 1 of a chain (trial 0 sets its state)
    config = Config()
    layout = of_trees(MIXED, 9)
    fast = record_trial(layout, 8, 1, config)
    slow = record_trial_reference(layout, 8, 1, config)
    assert fast.trees == slow.trees == MIXED and json.loads(fast.tree) == list(MIXED)
    for name in ("poses", "actions", "ticks", "smoothed", "ground", "fitness", "carrying", "deliveries"):
        np.testing.assert_array_equal(getattr(fast, name), getattr(slow, name), err_msg=name)
    assert all((a == b).all() for a, b in zip(fast.links, slow.links, strict=True))
    assert fast.values == slow.values


def test_which_robot_runs_which_tree_matters():
    swapped = (FOOD, *MIXED[1:2], NEST, *MIXED[3:])  # robots 0 and 2 exchange their (different) trees
    assert swapped != MIXED and sorted(swapped) == sorted(MIXED)
    evaluator = BatchEvaluator()
    a, b, same = evaluator.evaluate(
        [SwarmRequest(of_trees(MIXED, 9), 3, 4), SwarmRequest(of_trees(swapped, 9), 3, 4),
         SwarmRequest(of_trees(MIXED, 9), 3, 4)]
    )  # fmt: skip
    assert a.ok and b.ok
    assert a.fitness + a.descriptors != b.fitness + b.descriptors
    assert same == a
    # and a swarm is not any of its trees alone
    alone = evaluator.evaluate([EvaluationRequest(t, 3, 4) for t in (NEST, FOOD, FLOCK)])
    assert all(r.fitness != a.fitness for r in alone)


def test_a_swarm_beside_other_requests_keeps_its_result():
    evaluator = BatchEvaluator()
    swarm = SwarmRequest(of_trees(MIXED, 9), 5, 3)
    [alone] = evaluator.evaluate([swarm])
    mixed = evaluator.evaluate([EvaluationRequest(FOOD, 1, 2), swarm, EvaluationRequest("forward", 2, 3)])
    assert mixed[1] == alone
    assert mixed[0] == evaluator.evaluate([EvaluationRequest(FOOD, 1, 2)])[0]
    assert BatchEvaluator(threads=2).evaluate([swarm])[0] == alone


def test_bad_swarm_requests_give_error_results():
    evaluator = BatchEvaluator()
    eight = SwarmRequest(SwarmLayout(MIXED[:8]), 1, 2)
    bad_tree = SwarmRequest(SwarmLayout((*MIXED[:4], "sel(forward", *MIXED[5:])), 1, 2)
    bad_seed = SwarmRequest(of_trees(MIXED, 9), -1, 2)
    results = evaluator.evaluate([eight, bad_tree, bad_seed])
    assert "8 trees for 9 robots" in results[0].error
    assert "robot 4" in results[1].error and "bad tree" in results[1].error
    assert "seed" in results[2].error


@pytest.mark.parametrize(
    ("document", "message"),
    [
        ({"trees": list(MIXED[:8])}, "expected 9 trees (one per robot), got 8"),
        ({"trees": [*MIXED[:3], "seq(stop", *MIXED[4:]]}, "the tree of robot 3 does not parse"),
        ({"trees": [*MIXED[:5], 7, *MIXED[6:]]}, "the tree of robot 5 is not tree text but int"),
        ({"trees": NEST}, '"trees" must be a list of 9 tree texts, got str'),
        ({"tree": ["forward"]}, '"tree" must be tree text, got list'),
        ({"tree": "dance"}, "the tree of robot 0 does not parse"),
        ({"tree": "forward", "trees": list(MIXED)}, "got ['tree', 'trees']"),
        ({"robots": list(MIXED)}, "got ['robots']"),
        ([NEST] * 9, "got list"),
        ({}, "got []"),
    ],
)
def test_bad_layouts_are_refused_naming_the_problem_and_the_shape(document, message):
    with pytest.raises(LayoutError) as caught:
        layout_from_json(document, 9)
    assert message in str(caught.value)
    if "robot" not in message or "expected" in message:
        assert '{"trees": ["tree text", ...]' in str(caught.value)


def test_layout_files(tmp_path):
    path = tmp_path / "swarm.json"
    path.write_text(json.dumps({"trees": list(MIXED)}))
    layout = load_layout(path, 9)
    assert layout.trees == MIXED and not layout.homogeneous
    assert layout.distinct == (NEST, FOOD, FLOCK) and layout.robot_tree == (0, 0, 1, 2, 1, 0, 2, 2, 1)
    assert layout.parsed()[3] == parse(FLOCK)
    assert load_layout(path, 9) == of_trees(MIXED, 9) and layout.as_json() == {"trees": list(MIXED)}
    path.write_text(json.dumps({"tree": FOOD}))
    assert load_layout(path, 9) == SwarmLayout.uniform(FOOD, 9) and load_layout(path, 9).homogeneous
    assert load_layout(path, 4).n_robots == 4
    path.write_text("{not json")
    with pytest.raises(LayoutError, match=r"swarm layout .*swarm\.json: not JSON"):
        load_layout(path, 9)
    with pytest.raises(LayoutError, match="cannot read"):
        load_layout(tmp_path / "missing.json", 9)


@pytest.mark.parametrize(
    ("text", "message"),
    [
        ('{"tree": "stop", "tree": "forward"}', "the key 'tree' appears twice"),
        ('{"trees": ["stop"], "trees": ["forward"]}', "the key 'trees' appears twice"),
        ('{"tree": "stop", "n": NaN}', "NaN is not a JSON number"),
        ('{"tree": "stop", "n": 1e400}', "1e400 is out of range"),
    ],
)
def test_a_layout_with_a_key_twice_or_nan_is_refused_naming_it(tmp_path, text, message):
    """JSON keeps the last of two keys without a word, and Python reads NaN: both refused, in one line."""
    path = tmp_path / "swarm.json"
    path.write_text(text)
    with pytest.raises(LayoutError, match=message) as caught:
        load_layout(path, 9)
    assert "\n" not in str(caught.value) and str(path) in str(caught.value)
