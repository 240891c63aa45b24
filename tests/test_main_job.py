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

    evaluations = [m.message for m in read_bag(out / "run.bag") if m.topic == "/evaluations"]
    # the bag holds every evaluation once, those answered from the fixed scenario's cache marked
    assert len(evaluations) == summary["evaluations"] > 0
    assert sum(not m.cached for m in evaluations) == summary["simulations"] > 0
    assert verify_trial_bag(out / "best_trial.bag").reproduced


def test_main_job_refuses_an_existing_directory(tmp_path):
    (tmp_path / "keep.txt").write_text("precious")
    done = subprocess.run(
        [str(executable("evolution_manager", "main")), "--out", str(tmp_path)], capture_output=True, text=True
    )
    assert done.returncode == 2
    assert "exists already" in done.stderr
    assert (tmp_path / "keep.txt").read_text() == "precious"


def test_main_job_on_a_dask_cluster_evolves_there_and_runs_the_best_tree_through_the_graph(tmp_path):
    from distributed import LocalCluster

    out = tmp_path / "run"
    with LocalCluster(n_workers=1, threads_per_worker=1, processes=True, dashboard_address=":0") as cluster:
        option = cluster.scheduler_address.replace("tcp://", "dask://")
        main = str(executable("evolution_manager", "main"))
        done = subprocess.run(
            [main, "--evaluations", "150", "--out", str(out), "--cluster", option],
            capture_output=True,
            text=True,
            timeout=600,
        )
    assert done.returncode == 0, done.stderr[-3000:]
    assert f"through evolve on --cluster {option} -> {out}" in done.stdout
    assert f"cluster: work goes to the Dask scheduler at {cluster.scheduler_address}" in done.stderr
    (session,) = json.loads((out / "sessions.json").read_text())
    assert session["cluster"]["kind"] == "dask"  # the evolution's evaluations went to the cluster
    summary = json.loads((out / "summary.json").read_text())
    assert summary["objectives"]["food"]["best_tree"] in done.stdout
    assert not (out / "run.bag").exists() and "run.bag" not in done.stdout  # no manager node, no run bag
    assert verify_trial_bag(out / "best_trial.bag").reproduced  # the trial, through the node graph
    assert (out / "best" / "food_trial.gif").stat().st_size > 0


def test_main_job_refuses_bad_cluster_settings_in_one_line(tmp_path):
    import socket

    with socket.socket() as s:  # a port that nobody listens on
        s.bind(("127.0.0.1", 0))
        port = s.getsockname()[1]
    main = str(executable("evolution_manager", "main"))
    out = tmp_path / "run"
    slurm_only = tmp_path / "slurm.yaml"
    slurm_only.write_text("cores: 2\n")
    for options, said in (
        (["--cluster", "slurm", "--evaluators", "2"], "main: --evaluators applies to --cluster local only"),
        (["--cluster-config", str(tmp_path / "c.yaml")], "main: --cluster-config applies to --cluster slurm"),
        (["--cluster", f"dask://127.0.0.1:{port}"], "evolve: error: --cluster dask://127.0.0.1:"),
        (  # with dask://, the settings file gives TLS alone; evolve checks it
            ["--cluster", f"dask://127.0.0.1:{port}", "--cluster-config", str(slurm_only)],
            "'cores' applies to --cluster slurm; with --cluster dask://HOST:PORT the file gives tls_ca_file",
        ),
    ):
        done = subprocess.run(
            [main, "--out", str(out), *options], capture_output=True, text=True, timeout=120
        )
        assert done.returncode == 2 and done.stderr.count("\n") == 1 and said in done.stderr, done.stderr
        assert not out.exists()
