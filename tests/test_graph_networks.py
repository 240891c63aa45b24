"""A network (``bt_controller.interpreters.network``) through the node graph: `trial --network FILE` gives
exactly the batch evaluator's values and poses, its bag records the network's text, `replay --verify` re-runs
it and the animation of the bag shows the in-process twin's frames."""

import json
import subprocess

import numpy as np

from bt_controller.interpreters import N_WEIGHTS, Network
from bt_controller.interpreters import network_text as to_text
from evolution_manager.graph.nodes.trial import RESULT_TOPIC
from evolution_manager.graph.startup import executable
from evolution_manager.recording.bags import read_bag
from evolution_manager.recording.reproduce import verify_trial_bag
from evolution_manager.viewing.frames import frames_from_bag, frames_from_tree
from swarm_sim.evaluation import BatchEvaluator, EvaluationRequest

WEIGHTS = [round(float(w), 2) for w in np.random.default_rng(37).uniform(-5, 5, N_WEIGHTS)]
TEXT = to_text(Network(tuple(WEIGHTS)))


def test_trial_network_matches_the_batch_evaluator_and_replays(tmp_path, workspace):
    # a ROS domain of its own (``workspace``): no other graph on the machine answers
    network = tmp_path / "net.json"
    network.write_text(json.dumps({"weights": WEIGHTS}))
    bag = tmp_path / "net.bag"
    done = subprocess.run(
        [str(executable("evolution_manager", "trial")), "--network", str(network), "--seed", "43", "--trial",
         "1", "--bag", str(bag), "--controller-processes", "per-robot"],
        capture_output=True, text=True, timeout=1800, env=workspace.env,
    )  # fmt: skip
    assert done.returncode == 0, done.stderr
    logs = sorted(p.name for p in (tmp_path / "net.bag.logs").glob("*.log"))
    assert logs == sorted([*(f"footbot_{i}.log" for i in range(9)), "simulator.log"])  # a process each
    document = json.loads(done.stdout)
    assert document["network"] == WEIGHTS and "tree" not in document
    [(_, records)] = BatchEvaluator().evaluate_trials([EvaluationRequest(TEXT, 43, 2)])
    assert document["per_trial"] == [records[1].as_dict()]
    [result] = [m.message for m in read_bag(bag) if m.topic == RESULT_TOPIC]
    assert result.tree == TEXT
    verification = verify_trial_bag(bag)
    assert verification.reproduced, verification.summary()
    frames = frames_from_bag(bag)
    twin = frames_from_tree(TEXT, 43, 1)
    np.testing.assert_array_equal(frames.poses, twin.poses)
    np.testing.assert_array_equal(frames.actions, twin.actions)
