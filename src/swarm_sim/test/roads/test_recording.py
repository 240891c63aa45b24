"""A trial recorded through the batch road's kernels equals, array for array, the trial recorded through the
reference road (the node graph's own code); and the recording agrees with the batch evaluator."""

import math

import numpy as np
import pytest

from bt_controller.errors import TreeError
from bt_controller.language import random_trees
from swarm_sim.core import world
from swarm_sim.evaluation import BatchEvaluator, EvaluationRequest
from swarm_sim.model import DEFAULT, apply_conditions, default_config
from swarm_sim.roads import RecordedTrial, record_trial, record_trial_reference
from swarm_sim.tasks import FORAGING

ARRAYS = ("steps", "poses", "actions", "ticks", "smoothed", "ground", "initial", "carrying", "deliveries")


def assert_same(a: RecordedTrial, b: RecordedTrial) -> None:
    for name in ARRAYS:
        x, y = getattr(a, name), getattr(b, name)
        assert x.dtype == y.dtype and x.shape == y.shape, name
        assert (x == y).all(), name
    assert a.fitness.shape == b.fitness.shape and np.array_equal(a.fitness, b.fitness, equal_nan=True)
    assert len(a.links) == len(b.links) == len(a.steps)
    for x, y in zip(a.links, b.links, strict=True):
        assert x.dtype == y.dtype == np.int64 and x.shape == y.shape and (x == y).all()
    assert (a.tree, a.seed, a.trial, a.gap, a.values) == (b.tree, b.seed, b.trial, b.gap, b.values)


@pytest.mark.parametrize("profile", ["paper", "clean"])
@pytest.mark.parametrize("trial", [0, 3, 5, 7])
def test_both_roads_record_the_same_trial(profile, trial):
    config = default_config(profile)
    for k, tree in enumerate(random_trees(40 + trial, 2)):
        assert_same(
            record_trial(tree, 100 + k, trial, config), record_trial_reference(tree, 100 + k, trial, config)
        )


@pytest.mark.parametrize(
    ("profile", "conditions", "trial"),
    [
        ("paper", ["dead-robots=2", "weak-wheel=3:0.5"], 6),
        ("clean", ["message-loss=0.5", "robots=6", "gap=600"], 2),
    ],
)
def test_both_roads_record_the_same_trial_in_a_changed_world(profile, conditions, trial):
    config, _ = apply_conditions(conditions, default_config(profile))
    for k, tree in enumerate(random_trees(7, 2)):
        recorded = record_trial(tree, k, trial, config)
        assert recorded.poses.shape == (config.trial_steps, config.n_robots, 3)
        assert_same(recorded, record_trial_reference(tree, k, trial, config))


def test_a_recording_is_the_trial_the_batch_evaluator_scores():
    tree = "sel(seq(on_food, stop), prob(forward, forward_left), reverse_right)"
    for config in (DEFAULT, default_config("clean")):
        ((_, records),) = BatchEvaluator(config).evaluate_trials([EvaluationRequest(tree, 5, trials=4)])
        for trial in (0, 3):
            recorded = record_trial(tree, 5, trial, config)
            assert recorded.values == records[trial].values and recorded.gap == records[trial].gap
            assert (recorded.poses[-1] == records[trial].end_poses).all()
            # the fitness so far at the trial's last step is its fitness
            assert tuple(recorded.fitness[-1]) == records[trial].values[: world.N_OBJECTIVES]


@pytest.mark.parametrize("profile", ["paper", "clean"])
def test_both_roads_record_the_same_foraging_trial(profile):
    # 100 s trials of a forager: carrying flags and deliveries step by step, and the fitness so far.
    config = FORAGING.config(profile)
    forager = (
        "sel(seq(got_food, success(sel(seq(nest_left, forward_left), seq(nest_right, forward_right), "
        "forward))), sel(seq(food_left, forward_left), seq(food_right, forward_right), forward))"
    )
    recorded = record_trial(forager, 1, 1, config)  # two deliveries in this trial, under either profile
    assert_same(recorded, record_trial_reference(forager, 1, 1, config))
    assert recorded.carrying.any() and recorded.deliveries[-1].sum() > 0
    assert (np.diff(recorded.deliveries, axis=0) >= 0).all()  # counted up within the trial
    foraging = world.OBJECTIVES.index("foraging")
    assert recorded.fitness[-1, foraging] == recorded.deliveries[-1].mean() == recorded.values[foraging]


def test_what_a_recording_holds():
    config = DEFAULT
    steps, n = config.trial_steps, config.n_robots
    first = record_trial("sel(seq(in_nest, stop), forward)", 3, 0, config)
    later = record_trial("sel(seq(in_nest, stop), forward)", 3, 2, config)
    assert list(first.steps) == list(range(1, steps + 1))
    assert list(later.steps) == list(range(2 * steps + 1, 3 * steps + 1))  # the chain's third trial
    assert first.poses.shape == (steps, n, 3) and first.smoothed.shape == (steps, n, 3)
    assert first.ground.shape == (steps, n, 2) and first.actions.shape == (steps, n)
    # no tick before the chain's first (step 4 under paper); later trials show the last tick before them
    assert (first.ticks[:3] == -1).all() and (first.actions[:3] == -1).all() and first.ticks[3] == 0
    assert later.ticks[0] == 2 * config.ticks - 1 and (later.actions >= 0).all()
    before = config.initial_step - 1
    assert np.isnan(first.fitness[:before]).all() and not np.isnan(first.fitness[before:]).any()
    assert all(
        ((links[:, 0] >= 0) & (links[:, 1] < n) & (links[:, 0] != links[:, 1])).all() for links in first.links
    )
    assert sum(len(links) for links in first.links) > steps  # the robots talk
    assert all(math.isfinite(v) for v in first.values)


def test_bad_input_is_refused():
    with pytest.raises(TreeError):
        record_trial("sel(in_nest", 1)
    with pytest.raises(ValueError, match="seed"):
        record_trial("forward", -1)
    with pytest.raises(ValueError, match="trial"):
        record_trial("forward", 1, -1)
