"""A heterogeneous swarm through the node graph: each controller node runs its own tree, and the graph gives
exactly the batch evaluator's values and poses for the same layout; `trial --swarm` records which tree each
robot ran, and `replay --verify` re-runs each robot with its own tree."""

import json
import subprocess

import numpy as np

from evolution_manager.graph.nodes.trial import RESULT_TOPIC
from evolution_manager.graph.startup import executable, trial_graph_nodes
from evolution_manager.recording.bags import read_bag
from evolution_manager.recording.reproduce import verify_trial_bag
from evolution_manager.viewing.frames import frames_from_bag, frames_from_tree
from swarm_sim.evaluation import BatchEvaluator, EvaluationRequest, SwarmRequest
from swarm_sim.model import of_trees

NEST = "sel(seq(in_nest, stop), seq(nest_left, forward_left), seq(nest_right, forward_right), forward)"
FOOD = "sel(seq(on_food, stop), seq(food_left, forward_left), seq(food_right, forward_right), reverse)"
FLOCK = "sel(seq(robot_left, forward_left), seq(robot_right, forward_right), prob(forward, reverse_right))"
MIXED = (NEST, FOOD, FLOCK, FOOD, NEST, FLOCK, NEST, FOOD, FLOCK)


def _same(record, expected):
    return (
        record.values == expected.values
        and np.array_equal(record.start_poses, expected.start_poses)
        and np.array_equal(record.end_poses, expected.end_poses)
    )


def test_a_heterogeneous_swarm_through_the_graph_equals_the_batch_evaluator(graph):
    layout = of_trees(MIXED, 9)
    swapped = of_trees((FOOD, NEST, *MIXED[2:]), 9)  # robots 0 and 1 exchange their trees
    evaluator = BatchEvaluator()
    for swarm, seed, trial in ((layout, 31, 0), (layout, 32, 3), (swapped, 32, 3)):
        record = graph.run(swarm, seed, trial)  # trial 3 runs trials 0-2 of its chain first
        [(_, records)] = evaluator.evaluate_trials([SwarmRequest(swarm, seed, trial + 1)])
        assert _same(record, records[trial]), (swarm.trees, seed, trial)
    assert record.values != graph.run(layout, 32, 3).values  # who runs which tree matters in the graph too
    # back to one tree for all: every controller loads it again
    record = graph.run(NEST, 33, 1)
    [(_, records)] = evaluator.evaluate_trials([EvaluationRequest(NEST, 33, 2)])
    assert _same(record, records[1])


def test_each_controller_node_gets_its_own_tree_parameter():
    nodes = trial_graph_nodes(9, "/swarm_a", tree=MIXED)
    assert [n.parameters.get("tree") for n in nodes[1:]] == list(MIXED)
    assert all(n.parameters["tree"] == NEST for n in trial_graph_nodes(9, tree=NEST)[1:])


def test_trial_swarm_records_each_robots_tree_and_replays_per_robot(tmp_path):
    swarm = tmp_path / "swarm.json"
    swarm.write_text(json.dumps({"trees": list(MIXED)}))
    bag = tmp_path / "swarm.bag"
    done = subprocess.run(
        [str(executable("evolution_manager", "trial")), "--swarm", str(swarm), "--seed", "41", "--trial", "1",
         "--bag", str(bag)],
        capture_output=True, text=True, timeout=1800,
    )  # fmt: skip
    assert done.returncode == 0, done.stderr
    document = json.loads(done.stdout)
    assert document["trees"] == list(MIXED) and "tree" not in document
    [(_, records)] = BatchEvaluator().evaluate_trials([SwarmRequest(of_trees(MIXED, 9), 41, 2)])
    assert document["per_trial"] == [records[1].as_dict()]
    [result] = [m.message for m in read_bag(bag) if m.topic == RESULT_TOPIC]
    assert json.loads(result.tree) == list(MIXED)
    verification = verify_trial_bag(bag)
    assert verification.reproduced, verification.summary()
    replay = subprocess.run(
        [str(executable("evolution_manager", "replay")), str(bag), "--verify"], capture_output=True, text=True
    )
    assert replay.returncode == 0 and "reproduced" in replay.stdout
    # the animation of the bag names each robot's tree and shows the in-process twin's frames
    frames = frames_from_bag(bag)
    twin = frames_from_tree(of_trees(MIXED, 9), 41, 1)
    assert frames.trees == twin.trees == MIXED
    np.testing.assert_array_equal(frames.poses, twin.poses)
    np.testing.assert_array_equal(frames.actions, twin.actions)


def test_trial_swarm_refuses_a_bad_layout_before_starting_a_graph(tmp_path):
    swarm = tmp_path / "swarm.json"
    swarm.write_text(json.dumps({"trees": list(MIXED[:8])}))
    trial = str(executable("evolution_manager", "trial"))
    done = subprocess.run(
        [trial, "--swarm", str(swarm), "--bag", str(tmp_path / "t.bag")], capture_output=True, text=True
    )
    assert done.returncode == 2 and not (tmp_path / "t.bag").exists()
    assert "expected 9 trees (one per robot), got 8" in done.stderr and str(swarm) in done.stderr
    both = subprocess.run(
        [trial, "--swarm", str(swarm), "--tree", "forward", "--bag", str(tmp_path / "t.bag")],
        capture_output=True,
        text=True,
    )
    assert both.returncode == 2 and "not allowed with argument" in both.stderr
