"""The node graph: a trial through the simulator and nine footbot controller processes gives exactly the batch
evaluator's values (trial K runs its chain's earlier trials first, as the batch evaluator does); a recorded
trial reads back whole; recorders stopped by signals leave whole bags, and a killed one leaves a recoverable
bag."""

import json
import signal
import subprocess
from dataclasses import replace

import numpy as np
import pytest
from mcap.reader import make_reader

from bt_controller.language import load_library, parse, random_trees, to_text
from evolution_manager.graph.nodes.trial import RESULT_TOPIC, TrialGraph, expected_messages
from evolution_manager.graph.startup import executable
from evolution_manager.recording.bags import read_bag
from evolution_manager.recording.reproduce import verify_trial_bag
from evolution_manager.viewing.frames import frames_from_bag, frames_from_tree
from swarm_sim.evaluation import BatchEvaluator, EvaluationRequest, named_values, values_of
from swarm_sim.model import DEFAULT
from swarm_sim.tasks import FORAGING, PRIMITIVES, Trials

PARITY_TREES = 20
CLEAN_PARITY_TREES = 20


SHORT_TRIALS = replace(PRIMITIVES, name="primitives-5s", trials=Trials(ticks=10, chain_trials=5))
"""The primitives' world in 5 s trials (40 steps: the initial values at step 16, then 6 ticks), so that the
parity of 20 trees over the positions of two chains takes a quarter of the 20 s trials' steps."""


def test_trials_through_the_graph_equal_the_batch_evaluator():
    trees = ["forward", "sel(seq(in_nest, stop), forward)", *random_trees(seed=2023, count=PARITY_TREES - 2)]
    evaluator = BatchEvaluator(SHORT_TRIALS.config())
    with TrialGraph(timeout=240.0, task=SHORT_TRIALS) as graph:
        for index, text in enumerate(trees):
            seed, trial = 1000 + index, index % 7  # trials 0-6: all of chain 0, the first two of chain 1
            record = graph.run(to_text(parse(text)), seed, trial)
            _, trial_records = evaluator.evaluate_trials([EvaluationRequest(text, seed, trial + 1)])[0]
            expected = trial_records[trial]
            assert record.values == expected.values, f"tree {index}: {text}"
            assert np.array_equal(record.end_poses, expected.end_poses), f"tree {index}: {text}"
            assert np.array_equal(record.start_poses, expected.start_poses)


def test_under_the_clean_profile_the_graph_equals_the_batch_evaluator_too(tmp_path):
    trees = ["seq(forward, reverse)", *random_trees(seed=2024, count=CLEAN_PARITY_TREES - 1)]
    evaluator = BatchEvaluator(replace(DEFAULT, profile="clean"))
    # the controllers a process each, as on robots (the other graph tests hold them in one process)
    with TrialGraph(timeout=120.0, profile="clean", controller_processes="per-robot") as clean:
        for index, text in enumerate(trees):
            seed, trial = 2000 + index, index % 3  # a chain is one trial under clean
            bag = tmp_path / f"trial{index}" if index == 0 else None
            record = clean.run(to_text(parse(text)), seed, trial, bag)
            _, trial_records = evaluator.evaluate_trials([EvaluationRequest(text, seed, trial + 1)])[0]
            assert record.values == trial_records[trial].values, f"tree {index}: {text}"
            assert np.array_equal(record.end_poses, trial_records[trial].end_poses), f"tree {index}: {text}"
    messages = list(read_bag(tmp_path / "trial0"))
    (result,) = [m.message for m in messages if m.topic == RESULT_TOPIC]
    assert result.profile == "clean"
    assert named_values(result)["movement"] == pytest.approx(
        (14 - 26 + 40) / 80, abs=1e-12
    )  # docs/model.md, by hand
    assert len([m for m in messages if m.topic == "/swarm_state"]) == 176  # 16 settling steps, then 160


def test_a_recorded_trial_reads_back_whole_and_in_order(graph, tmp_path):
    bag = tmp_path / "trial"
    record = graph.run("prob(forward_left, seq(food_left, forward), reverse)", 7, 3, bag)

    messages = list(read_bag(bag))
    per_topic = {}
    for message in messages:
        per_topic.setdefault(message.topic, []).append(message)
    counts = {topic: len(items) for topic, items in per_topic.items()}
    assert counts == {**expected_messages(9, trial=3), RESULT_TOPIC: 1}
    steps = list(range(1, 4 * 160 + 1))  # trials 0, 1 and 2 of the chain, then trial 3
    for i in range(9):
        assert [m.message.step for m in per_topic[f"/footbot_{i}/range_and_bearing"]] == steps
        assert [m.message.step for m in per_topic[f"/footbot_{i}/wheels"]] == steps
        statuses = [m.message for m in per_topic[f"/footbot_{i}/tree_status"]]
        assert [s.step for s in statuses] == list(range(4, 4 * 160 + 1, 4))
    states = per_topic["/swarm_state"]
    assert [m.message.step for m in states] == steps
    assert [m.message.trial for m in states] == [k // 160 for k in range(4 * 160)]
    start = per_topic["/trial_start"][0].message
    assert (start.seed, start.trial) == (7, 3)
    result = per_topic[RESULT_TOPIC][0].message
    assert values_of(result) == record.values
    assert result.profile == "paper"
    final_poses = [[p.x, p.y, p.theta] for p in per_topic["/swarm_state"][-1].message.poses]
    assert final_poses == record.end_poses.tolist()

    # The mcap reader sees the same messages in the same order.
    (mcap_file,) = bag.glob("*.mcap")
    with mcap_file.open("rb") as stream:
        topics = [channel.topic for _, channel, _ in make_reader(stream).iter_messages(log_time_order=True)]
    assert topics == [m.topic for m in messages]


@pytest.mark.parametrize("stop_signal", [signal.SIGINT, signal.SIGTERM])
def test_a_recorder_stopped_by_a_signal_leaves_a_whole_bag(graph, tmp_path, stop_signal):
    bag = tmp_path / "recorded"
    recorder = start_recorder(graph, bag)
    # A first trial lets discovery settle (on a loaded machine the simulator may match the new recorder a
    # little late); the second must then be recorded whole.
    graph.run("forward", 10, 0)
    graph.run("sel(seq(robot_left, forward_left), forward_right)", 11, 0)
    wait_until_recorded(graph, recorder)
    recorder.send_signal(stop_signal)
    assert recorder.wait(timeout=30) == 0
    messages = list(read_bag(bag))
    second_start = [m for m in messages if m.topic == "/trial_start"][-1]
    assert (second_start.message.seed, second_start.message.trial) == (11, 0)
    counts = {}
    for message in messages:
        if message.timestamp_ns >= second_start.timestamp_ns:
            counts[message.topic] = counts.get(message.topic, 0) + 1
    assert counts == expected_messages(9)


def test_a_killed_recorder_leaves_a_recoverable_bag(graph, tmp_path):
    bag = tmp_path / "killed"
    recorder = start_recorder(graph, bag)
    # The first trials of four chains: enough messages to flush chunks. The first lets discovery settle (on a
    # loaded machine the simulator may match the new recorder a few steps late); the second must come whole.
    for trial in range(0, 20, 5):
        graph.run("prob(forward, reverse_left, seq(nest_right, forward_right))", 12, trial)
    recorder.send_signal(signal.SIGKILL)
    recorder.wait(timeout=30)
    assert not (bag / "metadata.yaml").exists()
    done = subprocess.run(
        [str(executable("evolution_manager", "recover")), str(bag), str(tmp_path / "recovered")],
        capture_output=True,
        text=True,
        check=True,
    )
    recovered = int(done.stdout.split()[1])
    assert recovered > 1000
    steps = [m.message.step for m in read_bag(tmp_path / "recovered") if m.topic == "/swarm_state"]
    second = next(i for i, step in enumerate(steps) if step == 1 and i > 0)
    assert steps[second : second + 160] == list(range(1, 161))  # the second trial came whole, in order


def start_recorder(graph, bag):
    runner = graph.runner
    process = subprocess.Popen(
        [str(executable("evolution_manager", "record")), "--bag", str(bag)],
        env=graph_environment(graph),
        stdout=subprocess.PIPE,
        text=True,
    )
    assert process.stdout.readline().startswith("recording to")
    # The recorder has matched the graph's publishers (its side of discovery); wait until the graph knows the
    # recorder too (the publishers' side), then a little longer for matching on a loaded machine (3 s: at 1 s
    # a controller's wheels topic once matched too late for the trial after it).
    assert process.stdout.readline().startswith("matched a publisher on all")
    runner.spin_until(lambda: runner.node.count_subscribers("/swarm_state") >= 1, "the recorder")
    runner.spin_for(3.0)
    return process


def wait_until_recorded(graph, recorder):
    graph.runner.spin_for(2.0)
    assert recorder.poll() is None


def graph_environment(graph):
    from swarm_ros.isolation import domain_environment

    return domain_environment(graph.graph.domain)


FORAGER = (
    "sel(seq(got_food, sel(seq(nest_left, forward_left), seq(nest_right, forward_right), forward)), "
    "sel(seq(food_left, forward_left), seq(food_right, forward_right), forward))"
)
PRIMITIVES = {
    "gotoNest": "sel(in_nest, seq(nest_left, forward_left), seq(nest_right, forward_right), "
    "prob(forward, stop))",
    "gotoFood": "sel(on_food, seq(food_left, forward_left), seq(food_right, forward_right), forward)",
}


def test_foraging_trials_through_the_graph_equal_the_batch_evaluator(tmp_path):
    # 100 s trials: got_food, success and named primitives (the controllers read the library file), a random
    # tree; under clean the second tree only (each 100 s trial through the graph costs about 23 s of CI, and
    # the clean profile's own parity test above runs random trees); the first paper trial recorded, replayed
    # bit for bit and animated as the in-process road draws it (carrying flags and deliveries included).
    library_path = tmp_path / "primitives.json"
    library_path.write_text(
        json.dumps({"format": 1, "primitives": [{"name": n, "tree": t} for n, t in PRIMITIVES.items()]})
    )
    library = load_library(library_path)
    trees = [
        FORAGER,
        "sel(seq(got_food, gotoNest), prob(gotoFood, success(seq(robot_left, forward_right))))",
        f"sel(seq(got_food, gotoNest), {random_trees(seed=7, count=1, p_success=0.3)[0]})",
    ]
    for profile, indices in (("paper", (0, 1, 2)), ("clean", (1,))):
        config = FORAGING.config(profile)
        evaluator = BatchEvaluator(config, library=library)
        with TrialGraph(timeout=120.0, profile=profile, task="foraging", library=library_path) as graph:
            for index in indices:
                text = trees[index]
                seed, trial = 3000 + index, index % 2
                bag = tmp_path / f"{profile}{index}" if index == 0 else None
                record = graph.run(text, seed, trial, bag)
                _, trial_records = evaluator.evaluate_trials([EvaluationRequest(text, seed, trial + 1)])[0]
                assert record.values == trial_records[trial].values, f"{profile} tree {index}: {text}"
                assert np.array_equal(record.end_poses, trial_records[trial].end_poses)
    paper_bag = tmp_path / "paper0"
    assert verify_trial_bag(paper_bag).reproduced
    frames = frames_from_bag(paper_bag)
    twin = frames_from_tree(FORAGER, 3000, 0, FORAGING.config("paper"))
    assert len(frames.steps) == 800
    np.testing.assert_array_equal(twin.carrying, frames.carrying)
    np.testing.assert_array_equal(twin.deliveries, frames.deliveries)
    np.testing.assert_allclose(twin.fitness, frames.fitness, rtol=0, atol=1e-12)
    states = [m.message for m in read_bag(paper_bag) if m.topic == "/swarm_state"]
    assert all(len(s.carrying) == 9 for s in states[1:])  # as answered the step before
