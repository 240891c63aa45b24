"""The main job end to end, on a small budget: the manager and an evaluator node evolve a repertoire, the best
tree runs through the full node graph, and every promised file is there and opens."""

import json
import subprocess

from evolution_manager.graph.startup import executable
from evolution_manager.recording.bags import read_bag
from evolution_manager.recording.reproduce import verify_trial_bag


def test_main_job_writes_the_run_and_the_recorded_best_trial(tmp_path):
    out = tmp_path / "run"
    done = subprocess.run(
        [
            str(executable("evolution_manager", "main")),
            "--evaluations",
            "300",
            "--evaluators",
            "1",
            "--out",
            str(out),
        ],
        capture_output=True,
        text=True,
        timeout=600,
    )
    assert done.returncode == 0, done.stderr[-3000:]
    summary = json.loads((out / "summary.json").read_text())
    food = summary["objectives"]["food"]
    assert 0.0 <= food["best_fitness"] <= 1.0 and food["best_tree"]
    for name in ("repertoire_food.json", "progress.csv", "figures/heatmap_food.png", "figures/histogram.png"):
        assert (out / name).stat().st_size > 0, name
    assert food["best_tree"] in done.stdout and str(out / "best_trial.bag") in done.stdout

    evaluations = [m for m in read_bag(out / "run.bag") if m.topic == "/evaluations"]
    # the bag holds every simulated evaluation once (under fixed scenarios a repeated tree is not simulated)
    assert len(evaluations) == summary["simulations"] > 0
    assert verify_trial_bag(out / "best_trial.bag").reproduced


def test_main_job_refuses_an_existing_directory(tmp_path):
    (tmp_path / "keep.txt").write_text("precious")
    done = subprocess.run(
        [str(executable("evolution_manager", "main")), "--out", str(tmp_path)], capture_output=True, text=True
    )
    assert done.returncode == 2
    assert "exists already" in done.stderr
    assert (tmp_path / "keep.txt").read_text() == "precious"
