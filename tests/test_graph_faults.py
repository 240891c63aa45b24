"""Per-robot faults travel through the node graph: the simulator node publishes the faulty robots' readings
and moves their faulty wheels (the controllers are unchanged), so a faulty trial in the graph is the batch
road's faulty trial, value for value, and its bag replays it. A changed food region (``gap``, ``food-disc``)
holds there alike."""

import json
from dataclasses import replace

import numpy as np
from builtin_interfaces.msg import Time

from bt_controller.nodes.footbot_controller import footing_of, ground_of, readings_of
from evolution_manager.graph.nodes.trial import TrialGraph
from evolution_manager.recording.reproduce import verify_trial_bag
from swarm_sim.evaluation import BatchEvaluator, EvaluationRequest
from swarm_sim.model import apply_conditions
from swarm_sim.nodes.simulator import reading_messages
from swarm_sim.roads.lockstep import LockstepChain
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
    named = {"0": "disruptive", "1": "ground-inverted", "2": "rab-mirrored", "3": "wheel-reversed"}
    faults.write_text(json.dumps(named))
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


def test_a_faulty_ground_sensor_reaches_the_controller_with_where_the_robot_stands():
    """The simulator node's ground message carries a faulty robot's false reading and, in ``footing``, where
    it stands; the controller node reads both back as the simulator made them (a sound robot's footing is
    empty, read as none)."""
    config, _ = apply_conditions(["faults=1:ground-inverted"], SHORT.config("paper"))
    sim = LockstepChain(2, 0, 1, config)
    sensed = sim.readings()
    frames = [f"footbot_{i}/base_link" for i in range(len(sensed))]
    ground, rab = reading_messages(sensed, Time(), 1, frames)
    for want, g, r in zip(sensed, ground, rab, strict=True):
        got = readings_of(ground_of(g), r, footing_of(g))
        assert want.footing is not None and np.array_equal(got.footing, want.footing)
        assert np.array_equal(got.ground, want.ground) and not np.array_equal(got.ground, got.footing)
    plain = LockstepChain(2, 0, 1, SHORT.config("paper")).readings()
    ground, rab = reading_messages(plain, Time(), 1, frames)
    assert all(list(g.footing) == [] and footing_of(g) is None for g in ground)


def test_a_smaller_food_region_holds_in_the_graph_as_on_the_batch_road(tmp_path):
    """The resource changes (issue 39): the food moved away and shrunk to a disc, a trial of the graph is
    the batch road's trial under the same conditions, and its bag replays it."""
    conditions = ["gap=650", "food-disc=250"]
    config, _ = apply_conditions(conditions, SHORT.config("paper"))
    seed, trial, bag = 6, 0, tmp_path / "bag"
    with TrialGraph(timeout=120.0, task=SHORT, conditions=conditions) as graph:
        record = graph.run(TREE, seed, trial, bag)
    ((_, changed),) = BatchEvaluator(config).evaluate_trials([EvaluationRequest(TREE, seed, 1)])
    assert record.values == changed[0].values
    assert np.array_equal(record.end_poses, changed[0].end_poses)
    replay = verify_trial_bag(bag)
    assert replay.reproduced, replay
