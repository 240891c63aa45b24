"""The aggregation objective, added as ``docs/tasks.md`` says (a probe in ``world.take_probes``, a row of the
objectives table, its mapping in ``world.robot_objectives``), is scored alike on every road: the batch
kernels, the reference road (the lockstep chain the node graph runs), and both recordings, step by step.
The node graph and its bags are tested in ``tests/test_graph_tasks.py``."""

from dataclasses import replace

import numpy as np
import pytest

from bt_controller.language import parse
from swarm_sim.evaluation import BatchEvaluator, EvaluationRequest
from swarm_sim.model import OBJECTIVES
from swarm_sim.roads import record_trial, record_trial_reference, reference_road
from swarm_sim.tasks import AGGREGATION, Robots, Trials, task_named

# A short aggregation task (five robots, 12-tick trials in chains of two): the registered one, edited.
SHORT = replace(
    AGGREGATION, trials=Trials(ticks=12, chain_trials=2), robots=Robots(count=5, start_half_size=1500)
)
TREE = "sel(seq(robot_left, forward_left), seq(robot_right, forward_right), forward)"
AGGREGATION_INDEX = OBJECTIVES.index("aggregation")


def test_aggregation_is_registered_with_its_objective_and_robot_conditions():
    task = task_named("aggregation")
    assert task.objectives == ("aggregation",)
    assert task.nodes.conditions == ("robot_left", "robot_right")
    assert task.config("paper").ticks == 120


@pytest.mark.parametrize("profile", ["paper", "clean"])
def test_the_batch_and_reference_roads_score_aggregation_alike(profile):
    config = SHORT.config(profile)
    seed, trials = 5, 3
    values, records = reference_road.evaluate(parse(TREE), seed, trials, config)
    result = BatchEvaluator(config).evaluate([EvaluationRequest(TREE, seed, trials)])[0]
    assert result.fitness + result.descriptors == values
    per_trial = [record.values[AGGREGATION_INDEX] for record in records]
    assert all(0.0 <= v <= 1.0 for v in per_trial) and len(set(per_trial)) > 1  # it measures something


def test_both_recordings_score_aggregation_step_by_step_as_the_trial_ends():
    config = SHORT.config("paper")
    seed, trial = 5, 1
    batch = record_trial(TREE, seed, trial, config)
    reference = record_trial_reference(TREE, seed, trial, config)
    assert np.array_equal(batch.fitness, reference.fitness, equal_nan=True)
    assert batch.fitness[-1, AGGREGATION_INDEX] == batch.values[AGGREGATION_INDEX]
    # As if the trial ended at each step: from the start's spread to the spread at that step, not constant.
    scored = batch.fitness[~np.isnan(batch.fitness[:, AGGREGATION_INDEX]), AGGREGATION_INDEX]
    assert len(set(scored.tolist())) > 1
