"""Per-robot faults travel through the node graph: the simulator node publishes the faulty robots' readings
and moves their faulty wheels (the controllers are unchanged), so a faulty trial in the graph is the batch
road's faulty trial, value for value, and its bag replays it."""

import json
from dataclasses import replace

import numpy as np

from evolution_manager.graph.nodes.trial import TrialGraph
from evolution_manager.recording.reproduce import verify_trial_bag
from swarm_sim.evaluation import BatchEvaluator, EvaluationRequest
from swarm_sim.model import apply_conditions
from swarm_sim.tasks import FORAGING, Robots, Trials

SHORT = replace(
    FORAGING,
    name="short-foraging",
    trials=Trials(ticks=14, chain_trials=1),
    robots=Robots(count=5),
)
TREE = "sel(seq(got_food, nest_left, forward_left), seq(food_right, forward_right), seq(robot_left, forward))"


def test_faults_change_a_trial_in_the_graph_as_on_the_batch_road(tmp_path):
    faults = tmp_path / "faults.json"
    faults.write_text(json.dumps({"0": "disruptive", "2": "rab-mirrored", "3": "wheel-reversed"}))
    conditions = [f"faults={faults}"]
    config, _ = apply_conditions(conditions, SHORT.config("paper"))
    seed, trial, bag = 4, 0, tmp_path / "bag"
    with TrialGraph(timeout=120.0, task=SHORT, conditions=conditions) as graph:
        record = graph.run(TREE, seed, trial, bag)
    ((_, faulty),) = BatchEvaluator(config).evaluate_trials([EvaluationRequest(TREE, seed, 1)])
    ((_, plain),) = BatchEvaluator(SHORT.config("paper")).evaluate_trials([EvaluationRequest(TREE, seed, 1)])
    assert record.values == faulty[0].values
    assert np.array_equal(record.end_poses, faulty[0].end_poses)
    assert not np.array_equal(record.end_poses, plain[0].end_poses)
    replay = verify_trial_bag(bag)
    assert replay.reproduced, replay
