"""Distributed evaluation: a manager node spreads a MAP-Elites run over three evaluator processes, one of
which is killed with SIGKILL mid-run; the run completes, its bag holds every evaluation exactly once, and its
result files are byte for byte those of the same run with the in-process batch evaluator and no fault."""

import csv
import subprocess
import time

import rclpy
from rclpy.executors import SingleThreadedExecutor
from rclpy.node import Node

from bt_controller.language import random_trees
from evolution_manager.evolution.run_config import evaluation_seed
from evolution_manager.graph.service_evaluator import ServiceEvaluator, ServiceSettings
from evolution_manager.graph.startup import Graph, executable
from evolution_manager.recording.bags import read_bag
from evolution_manager.studies.evolve import evolve
from swarm_sim.evaluation import BatchEvaluator, EvaluationRequest, named_values

BUDGET = 1000  # QD: a batch of 100, then batches of 50; about 3 ms an evaluation here
SEED = 5
# fresh scenarios: every evaluation is simulated and sent (fixed ones answer repeats from the cache)
RUN_OPTIONS = ["--algorithm", "qd", "--objective", "food", "--evaluations", str(BUDGET), "--seed", str(SEED)]
RUN_OPTIONS += ["--scenarios", "fresh"]
RESULT_FILES = [
    "evaluations.csv",
    "progress.csv",
    "summary.json",
    "archive.json",
    "repertoire_density.json",
    "repertoire_nest.json",
    "repertoire_food.json",
]


def manager_command(out, *extra):
    return [
        str(executable("evolution_manager", "manager")),
        *RUN_OPTIONS,
        "--out",
        str(out),
        "--no-figures",
        "--no-progress",
        *extra,
    ]


def batches_done(out):
    progress = out / "progress.csv"
    return max(0, len(progress.read_text().splitlines()) - 1) if progress.exists() else 0


def test_a_killed_evaluator_loses_nothing_and_counts_nothing_twice(tmp_path, workspace):
    out = tmp_path / "distributed"
    with Graph(workspace.domain, log_dir=tmp_path / "logs") as graph:
        for i in (1, 2, 3):
            graph.start(f"evaluator_{i}", "swarm_sim", "evaluator", node_name=f"evaluator_{i}")
        # A dead evaluator's chunk is re-sent after 10 s (first calls, which compile, get 300 s).
        command = manager_command(out, "--expect", "3", "--wait", "120", "--ros-args", "-p", "timeout:=10.0")
        manager = subprocess.Popen(
            command,
            env=workspace.env,
            stdout=subprocess.PIPE,
            stderr=subprocess.STDOUT,
            text=True,
        )
        try:
            deadline = time.monotonic() + 150
            while batches_done(out) < 2 and manager.poll() is None and time.monotonic() < deadline:
                time.sleep(0.02)
            assert manager.poll() is None, "the manager ended before the fault: " + manager.stdout.read()
            assert batches_done(out) < BUDGET // 50 - 5, "too late for a fault mid-run"
            graph.kill("evaluator_2")
            graph.check()  # the two others are alive
            output, _ = manager.communicate(timeout=180)
        finally:
            if manager.poll() is None:
                manager.kill()
                manager.wait()
    assert manager.returncode == 0, output
    assert "/evaluator_2/evaluate did not answer" in output or "/evaluator_2/evaluate vanished" in output
    assert "re-sending" in output

    # Every evaluation is in the bag once, in order, and agrees with the evaluation log.
    with open(out / "evaluations.csv", newline="") as handle:
        rows = list(csv.DictReader(handle))
    messages = list(read_bag(out / "run.bag"))
    evaluations = [m.message for m in messages if m.topic == "/evaluations"]
    assert [(m.tree, m.seed) for m in evaluations] == [(r["tree"], int(r["seed"])) for r in rows]
    assert [m.seed for m in evaluations] == [evaluation_seed(SEED, i) for i in range(len(rows))]
    assert len({m.seed for m in evaluations}) == len(rows) > BUDGET // 2
    assert all(
        named_values(m)["food"] == float(r["food"]) for m, r in zip(evaluations, rows, strict=True) if m.ok
    )
    progress = [m.message for m in messages if m.topic == "/progress"]
    assert len(progress) == 3 * batches_done(out)
    assert progress[-1].evaluations == len(rows)

    # The same run in-process, with no fault, writes the same files.
    reference = tmp_path / "in_process"
    assert evolve([*RUN_OPTIONS, "--out", str(reference), "--no-figures", "--no-progress"]) == 0
    for name in RESULT_FILES:
        assert (out / name).read_bytes() == (reference / name).read_bytes(), name


def test_a_manager_with_no_evaluator_says_so(tmp_path, workspace):
    done = subprocess.run(
        manager_command(tmp_path / "lonely", "--wait", "3"),
        env=workspace.env,
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert done.returncode == 1
    assert "no evaluator service found" in done.stderr


def test_the_service_evaluator_finds_evaluators_started_later_and_answers_as_in_process(tmp_path, workspace):
    requests = [EvaluationRequest(t, 100 + i, 2) for i, t in enumerate(random_trees(seed=3, count=20))]
    requests += [
        EvaluationRequest("sel(forward", 1, 2),  # not a tree
        EvaluationRequest("forward", -1, 2),  # not a seed
        EvaluationRequest("forward", 1, 3),  # other trials: another chunk
        EvaluationRequest("stop", 2, 0),  # not a number of trials
    ]
    expected = BatchEvaluator().evaluate(requests)
    assert sum(r.error is not None for r in expected) == 3
    with Graph(workspace.domain, log_dir=tmp_path / "logs") as graph:
        graph.start("evaluator_1", "swarm_sim", "evaluator", node_name="evaluator_1")
        context = rclpy.Context()
        rclpy.init(context=context, domain_id=workspace.domain)
        node = Node("service_evaluator_test", context=context)
        executor = SingleThreadedExecutor(context=context)
        executor.add_node(node)
        try:
            services = ServiceEvaluator(node, executor, ServiceSettings(max_chunk=4, discovery_period=0.2))
            assert services.wait_for(1, 120) == ["/evaluator_1/evaluate"]
            assert services.evaluate(requests) == expected
            graph.start("evaluator_2", "swarm_sim", "evaluator", node_name="evaluator_2")
            deadline = time.monotonic() + 120
            while len(services.discover()) < 2 and time.monotonic() < deadline:  # the run goes on meanwhile
                assert services.evaluate(requests[:3]) == expected[:3]
            before = services.dispatcher.answered_chunks("/evaluator_2/evaluate")
            # the newcomer shares the work: on a loaded machine its first goals may come too late for a
            # round, which the first evaluator then answers alone (the same results either way)
            deadline = time.monotonic() + 120
            while True:
                assert services.evaluate(requests) == expected
                shared = services.dispatcher.answered_chunks("/evaluator_2/evaluate") > before
                if shared or time.monotonic() > deadline:
                    break
            assert shared, "the evaluator started later never answered a chunk"
            graph.check()
        finally:
            executor.shutdown()
            node.destroy_node()
            rclpy.shutdown(context=context)
