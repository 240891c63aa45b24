"""The cluster subpackage: its options checked whole, and real Dask (a LocalCluster of worker processes,
reached as ``dask://HOST:PORT``) running chunks of a batch and whole runs, with the same bytes as a local run,
a worker SIGKILLed mid-task included. The SLURM side, with real daemons and jobs: tests/test_slurm.py."""

from __future__ import annotations

import json
import os
import re
import signal
import socket
import threading
import time
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

import pytest
from distributed import Client, LocalCluster

from bt_controller.language import random_trees
from evolution_manager.cluster.client import open_client, slurm_cluster_options
from evolution_manager.cluster.evaluator import DaskEvaluator, chunks, evaluate_chunk
from evolution_manager.cluster.runs import map_runs
from evolution_manager.cluster.settings import (
    ClusterError,
    ClusterSettings,
    SlurmSettings,
    parse_cluster,
    read_slurm_settings,
)
from evolution_manager.evolution.run import Run
from evolution_manager.evolution.run_config import RunConfig
from evolution_manager.evolution.run_results import run_results
from evolution_manager.studies.experiment import run_one
from evolution_manager.viewing.results import write_results
from swarm_sim.evaluation import BatchEvaluator, EvaluationRequest
from swarm_sim.model import OBJECTIVES, default_config
from swarm_sim.tasks import FORAGING

VARYING = {"timing.json", "checkpoint.json", ".lock"}
"""Files of a run directory that hold wall-clock times (or nothing): every other file is the same bytes."""


def run_files(root: Path) -> dict[str, bytes]:
    """Every file of a run directory by relative path, but those that hold wall-clock times and the SVG
    drawings (matplotlib names their clip paths from a fresh random salt: two local runs differ there too)."""
    return {
        str(p.relative_to(root)): p.read_bytes()
        for p in sorted(root.rglob("*"))
        if p.is_file() and p.name not in VARYING and p.suffix != ".svg"
    }


@pytest.fixture(scope="module")
def cluster():
    """Two worker processes of one thread each, with nannies (a killed worker is restarted)."""
    with LocalCluster(n_workers=2, threads_per_worker=1, processes=True, dashboard_address=None) as local:
        yield local


@pytest.fixture(scope="module")
def client(cluster):
    with Client(cluster) as connected:
        yield connected


# The options ----------------------------------------------------------------------------------------------
def test_the_three_kinds_of_cluster_option_are_read():
    assert parse_cluster("local") == ClusterSettings()
    assert parse_cluster("dask://scheduler.example:8786") == ClusterSettings(
        "dask", address="tcp://scheduler.example:8786"
    )
    assert parse_cluster("dask://[::1]:8786").address == "tcp://[::1]:8786"
    assert parse_cluster("slurm") == ClusterSettings("slurm", slurm=SlurmSettings())


@pytest.mark.parametrize(
    "option,expected",
    [
        ("remote", "--cluster must be local, dask://HOST:PORT or slurm, got 'remote'"),
        ("dask://host", "expected dask://HOST:PORT"),
        ("dask://:8786", "expected dask://HOST:PORT"),
        ("dask://host:port", "Port could not be cast"),
        ("dask://host:99999", "out of range"),
        ("dask://host:8786/path", "with nothing after the port"),
        ("tcp://host:8786", "--cluster must be local, dask://HOST:PORT or slurm"),
    ],
)
def test_a_bad_cluster_option_is_one_line_naming_it(option, expected):
    with pytest.raises(ClusterError) as caught:
        parse_cluster(option)
    message = str(caught.value)
    assert message.startswith("--cluster") and expected in message and "\n" not in message


def test_a_cluster_config_goes_with_slurm_and_with_dask_for_tls_only(tmp_path):
    config = tmp_path / "cluster.yaml"
    config.write_text("cores: 2\n")
    with pytest.raises(ClusterError, match="--cluster-config applies to --cluster slurm or dask://HOST:PORT"):
        parse_cluster("local", config)
    with pytest.raises(
        ClusterError, match="'cores' applies to --cluster slurm; with --cluster dask://HOST:PORT"
    ):
        parse_cluster("dask://host:8786", config)
    assert parse_cluster("slurm", config).slurm == SlurmSettings(cores=2)
    pem = tmp_path / "x.pem"
    pem.write_text("not read here\n")
    config.write_text(f"tls_ca_file: {pem}\ntls_cert: {pem}\ntls_key: {pem}\n")
    settings = parse_cluster("dask://host:8786", config)
    assert settings.address == "tls://host:8786" and settings.describe_option() == "dask://host:8786"
    assert settings.tls is not None and settings.tls.tls_key == str(pem)
    assert settings.to_json()["tls"] == {"tls_ca_file": str(pem), "tls_cert": str(pem), "tls_key": str(pem)}
    assert "tls" not in parse_cluster("dask://host:8786").to_json()  # plain: recorded as before
    for text, expected in (
        ("", "expected tls_ca_file, tls_cert and tls_key (TLS with the scheduler), got no key"),
        (f"tls_ca_file: {pem}\n", "tls_cert is missing; TLS takes tls_ca_file, tls_cert and tls_key"),
        (f"tls_ca_file: {pem}\ntls_cert: {pem}\ntls_key: nowhere.pem\n", "tls_key must be a readable file"),
    ):
        config.write_text(text)
        with pytest.raises(ClusterError, match=re.escape(expected)) as caught:
            parse_cluster("dask://host:8786", config)
        assert str(caught.value).startswith(f"--cluster-config {config}: ") and "\n" not in str(caught.value)


def test_a_cluster_config_file_gives_every_setting(tmp_path):
    config = tmp_path / "cluster.yaml"
    config.write_text(
        "cores: 4\nmemory: 8GB\nwalltime: '1-02:00:00'\npartition: compute\naccount: proj-1\njobs: 8\n"
        "container: apptainer exec --bind /scratch swarm.sif\npython: /opt/venv/bin/python\n"
        "interface: ib0\nlog_directory: logs/dask\n"
    )
    assert read_slurm_settings(config) == SlurmSettings(
        cores=4,
        memory="8GB",
        walltime="1-02:00:00",
        partition="compute",
        account="proj-1",
        jobs=8,
        container="apptainer exec --bind /scratch swarm.sif",
        python="/opt/venv/bin/python",
        interface="ib0",
        log_directory="logs/dask",
    )
    config.write_text("")  # an empty file: every default
    assert read_slurm_settings(config) == SlurmSettings()


@pytest.mark.parametrize(
    "text,expected",
    [
        ("nodes: 4\n", "unknown key 'nodes'; the keys are cores, memory, walltime"),
        ("cores: 0\n", "cores must be a positive integer, got 0"),
        ("cores: true\n", "cores must be a positive integer, got True"),
        ("jobs: '3'\n", "jobs must be a positive integer, got '3'"),
        ("memory: 8\n", "memory must be an amount with its unit such as 4GB"),
        ("memory: 8 bananas\n", "memory must be an amount with its unit"),
        ("cores: 4\nmemory: 1GB\n", "leaves 238 MiB each; give at least 512 MiB per core"),
        ("walltime: 3600\n", "walltime must be a time limit [D-]HH:MM:SS"),
        ("walltime: '01:61:00'\n", "walltime must be a time limit"),
        ("walltime: '00:00:00'\n", "walltime must be a time limit"),
        ("partition: two words\n", "partition must be a name without spaces or quotes"),
        ('container: "apptainer exec \'unclosed"\n', "container: cannot split"),
        ("python: ''\n", "python must be a command (text)"),
        ("log_directory: 5\n", "log_directory must be a directory path"),
        ("- cores\n", "expected a mapping of settings (key: value), got list"),
        ("cores: [\n", "not valid YAML at line"),
        ("cores: 4\ncores: 8\n", "the key 'cores' appears twice (line 2); expected each setting once"),
        ("jobs: 2\nmemory: 8GB\njobs: 3\n", "the key 'jobs' appears twice (line 3)"),
    ],
)
def test_a_bad_cluster_config_is_one_line_naming_the_file_and_key(tmp_path, text, expected):
    config = tmp_path / "cluster.yaml"
    config.write_text(text)
    with pytest.raises(ClusterError) as caught:
        parse_cluster("slurm", config)
    message = str(caught.value)
    assert message.startswith(f"--cluster-config {config}: ") and expected in message and "\n" not in message


def test_a_missing_cluster_config_is_one_line(tmp_path):
    with pytest.raises(ClusterError, match=r"cannot read it \(No such file or directory\)"):
        parse_cluster("slurm", tmp_path / "absent.yaml")


def test_the_job_script_starts_one_worker_process_per_core_inside_the_container():
    from dask_jobqueue import SLURMCluster

    settings = SlurmSettings(
        cores=2,
        memory="4GB",
        walltime="02:00:00",
        partition="compute",
        account="proj",
        container="apptainer exec --bind /scratch swarm.sif",
    )
    options = slurm_cluster_options(settings)
    options["scheduler_options"]["dashboard_address"] = None
    with SLURMCluster(**options) as slurm:
        script = slurm.job_script()
    for line in ("#SBATCH -p compute", "#SBATCH -A proj", "#SBATCH -t 02:00:00", "#SBATCH --cpus-per-task=2"):
        assert line in script
    worker = next(line for line in script.splitlines() if "distributed.cli.dask_worker" in line)
    assert worker.startswith("apptainer exec --bind /scratch swarm.sif /workspace/ws/python -m ")
    assert "--nthreads 1" in worker and "--nworkers 2" in worker
    without = slurm_cluster_options(SlurmSettings(), python="/venv/bin/python")
    assert without["python"] == "/venv/bin/python" and without["processes"] == 1


# Checks before any work is sent -------------------------------------------------------------------------
def test_no_scheduler_at_the_address_is_one_clear_error():
    with socket.socket() as s:  # a port that nobody listens on
        s.bind(("127.0.0.1", 0))
        port = s.getsockname()[1]
    settings = parse_cluster(f"dask://127.0.0.1:{port}")
    with pytest.raises(ClusterError) as caught, open_client(settings, timeout=3):
        pass
    assert str(caught.value).startswith(f"--cluster dask://127.0.0.1:{port}: no Dask scheduler answers there")


def test_a_port_that_is_not_a_dask_scheduler_is_one_clear_error():
    with socket.socket() as server:  # listens, never speaks Dask's protocol
        server.bind(("127.0.0.1", 0))
        server.listen()
        port = server.getsockname()[1]
        settings = parse_cluster(f"dask://127.0.0.1:{port}")
        with pytest.raises(ClusterError) as caught, open_client(settings, timeout=2):
            pass
    message = str(caught.value)
    assert message.startswith(f"--cluster dask://127.0.0.1:{port}: something answers there, but not as")
    assert "\n" not in message


def test_slurm_not_installed_is_one_clear_error(monkeypatch, tmp_path):
    monkeypatch.setenv("PATH", str(tmp_path))  # a PATH without sbatch, squeue or scancel
    with pytest.raises(ClusterError) as caught, open_client(parse_cluster("slurm")):
        pass
    assert str(caught.value) == (
        "--cluster slurm: SLURM is not installed here (no sbatch, squeue, scancel on PATH); run on a login "
        "node of a SLURM cluster, or use --cluster local or dask://HOST:PORT"
    )


def test_local_opens_no_client():
    with open_client(parse_cluster("local")) as opened:
        assert opened is None


# Chunks of a batch ------------------------------------------------------------------------------------------
@pytest.mark.parametrize(
    "count,least,threads,expected",
    [
        (0, 25, 2, []),
        (10, 25, 2, [10]),  # smaller than a chunk: one
        (50, 25, 1, [50]),  # one worker thread: one chunk per batch
        (50, 25, 2, [25, 25]),
        (49, 25, 2, [49]),
        (50, 25, 8, [25, 25]),  # more threads than chunks worth sending
        (50, 10, 3, [17, 17, 16]),
        (50, 10, 0, [10, 10, 10, 10, 10]),  # no worker yet: as many as can be
        (100, 25, 64, [25, 25, 25, 25]),
    ],
)
def test_a_batch_is_cut_in_order_into_a_chunk_per_thread_none_too_small(count, least, threads, expected):
    pieces = chunks(count, least, threads)
    assert [len(piece) for piece in pieces] == expected
    assert [i for piece in pieces for i in piece] == list(range(count))


def test_a_chunk_travels_as_text_and_numbers():
    answer = evaluate_chunk("paper", [("sel(on_food, forward)", 3, 2), ("nonsense(", 3, 2)])
    local = BatchEvaluator(default_config("paper")).evaluate(
        [EvaluationRequest("sel(on_food, forward)", 3, 2), EvaluationRequest("nonsense(", 3, 2)]
    )
    assert answer == [(r.fitness, r.descriptors, r.error) for r in local]
    assert all(type(v) is float for v in answer[0][0] + answer[0][1])


def test_the_dask_evaluator_answers_exactly_as_the_in_process_one(client):
    requests = [EvaluationRequest(tree, 100 + i, 3) for i, tree in enumerate(random_trees(7, 30))]
    requests += [EvaluationRequest("sel(on_food", 1, 1), EvaluationRequest(requests[0].tree, 5, 0)]
    evaluator = DaskEvaluator(client, "clean", chunk=4)
    results = evaluator.evaluate([*requests, "not a request"])
    assert results[:-1] == BatchEvaluator(default_config("clean")).evaluate(requests)
    assert results[-1].error == "expected an EvaluationRequest, got str"
    assert results[-3].error.startswith("bad tree") and results[-2].error.startswith("trials must be")
    assert evaluator.tasks == 2  # 32 requests: a chunk for each of the 2 worker threads
    assert evaluator.evaluate([]) == []


def test_a_changed_world_travels_whole_to_the_workers(client):
    from swarm_sim.model import apply_conditions

    world, _ = apply_conditions(["dead-robots=3", "weak-wheel=2:0.5"], default_config("paper"))
    requests = [EvaluationRequest(tree, 9, 4) for tree in random_trees(8, 6)]
    results = DaskEvaluator(client, world, chunk=4).evaluate(requests)
    assert results == BatchEvaluator(world).evaluate(requests)
    assert results != BatchEvaluator(default_config("paper")).evaluate(requests)


def test_a_foraging_world_and_a_library_travel_to_the_workers(client):
    # the run's trial length in its world, its library as JSON text: every objective comes back, foraging too
    from bt_controller.language import library_from_json

    library = library_from_json(
        {
            "format": 1,
            "primitives": [{"name": "toFood", "tree": "sel(on_food, seq(food_left, forward_left))"}],
        },
        "hand-made",
    )
    world = FORAGING.config("paper")
    trees = ["sel(seq(got_food, in_nest), toFood, forward)", *random_trees(9, 3, p_success=0.3)]
    requests = [EvaluationRequest(tree, 4, 2) for tree in trees] + [EvaluationRequest("toNest", 4, 2)]
    results = DaskEvaluator(client, world, chunk=2, library=library).evaluate(requests)
    assert results == BatchEvaluator(world, library=library).evaluate(requests)
    foraging = OBJECTIVES.index("foraging")
    assert len(results[0].fitness) == len(OBJECTIVES) and results[0].fitness[foraging] >= 0.0
    assert "toNest" in results[-1].error and "hand-made" in results[-1].error


def test_every_worker_builds_the_evaluator_of_a_world_once(client):
    from swarm_sim.model import apply_conditions

    def built() -> int:  # evaluators built so far in this worker process
        from evolution_manager.cluster.evaluator import worker_evaluator

        return worker_evaluator.cache_info().misses

    world, _ = apply_conditions(["message-loss=0.25"], default_config("clean"))  # a world no other test uses
    before = client.run(built)
    evaluator = DaskEvaluator(client, world, chunk=2)  # its plugin builds the evaluator on every worker
    assert client.run(built) == {worker: n + 1 for worker, n in before.items()}
    for seed in range(3):
        evaluator.evaluate([EvaluationRequest(tree, seed, 2) for tree in random_trees(seed, 8)])
    assert client.run(built) == {worker: n + 1 for worker, n in before.items()}  # 6 chunks, nothing new
    assert evaluator.tasks == 6


def test_a_run_through_dask_writes_the_bytes_of_a_local_run(client, tmp_path):
    config = RunConfig.make("qd", "food", 120, seed=5, trials=3, profile="paper")
    roots = {"local": tmp_path / "local", "dask": tmp_path / "dask"}
    evaluators = {
        "local": BatchEvaluator(default_config("paper")),
        "dask": DaskEvaluator(client, "paper", chunk=9),
    }
    for name, root in roots.items():
        run = Run.start(config, root, evaluators[name])
        run.execute(checkpoint_interval=0)
        write_results(run, run_results(run, evaluators[name]), with_figures=False)
        run.lock.release()
    local, dask = run_files(roots["local"]), run_files(roots["dask"])
    assert "evaluations.csv" in local and "heldout.json" in local and "best/food.png" in local
    assert dask == local
    assert evaluators["dask"].tasks >= 8  # the batches (and the held-out scores) went as 2 chunks each


# Nothing lost when a worker dies --------------------------------------------------------------------------
def worker_pids(client: Client) -> dict[str, int]:
    return client.run(os.getpid)


def wait_for(condition, timeout: float, what: str) -> None:
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        if condition():
            return
        time.sleep(0.05)
    pytest.fail(f"no {what} within {timeout} s")


def test_a_chunk_whose_worker_is_killed_mid_task_runs_again_elsewhere(client):
    # several seconds of work even on an idle machine (200 trials each took about 1 s there: the chunk could
    # finish before the kill below)
    requests = [EvaluationRequest(tree, 7, 1000) for tree in random_trees(11, 12)]
    evaluator = DaskEvaluator(client, "paper", chunk=len(requests))  # one chunk, on one worker
    client.wait_for_workers(2)
    pids = worker_pids(client)
    with ThreadPoolExecutor(1) as pool:
        answer = pool.submit(evaluator.evaluate, requests)
        wait_for(lambda: any(client.processing().values()), 30, "chunk on a worker")
        time.sleep(1.0)  # well inside the chunk's seconds
        (address, keys), *_ = [(a, k) for a, k in client.processing().items() if k]
        os.kill(pids[address], signal.SIGKILL)
        results = answer.result(timeout=300)
    story = client.story(keys[0])  # the chunk's transitions, on the scheduler and the workers
    on_scheduler = [(e[2], e[3], e[5]) for e in story if e[0] == "scheduler"]
    taken_back = [
        k
        for k, (a, b, why) in enumerate(on_scheduler)
        if (a, b) == ("processing", "released") and why.startswith("handle-worker-cleanup")
    ]  # taken back from the killed worker while it ran ...
    assert len(taken_back) == 1
    assert ("processing", "memory") in [(a, b) for a, b, _ in on_scheduler[taken_back[0] :]]  # ... run again
    ran_on = {e[0] for e in story if e[0] != "scheduler" and e[2:4] == ("ready", "executing")}
    assert ran_on and address not in ran_on
    assert results == BatchEvaluator(default_config("paper")).evaluate(requests)
    client.wait_for_workers(2)  # the nanny restarted the killed worker


def test_runs_on_a_dask_scheduler_equal_local_runs_even_when_a_worker_dies(cluster, tmp_path):
    configs = [
        RunConfig.make("qd", "nest", 200, seed=21, trials=3),  # the one whose worker is killed
        RunConfig.make("gp", "food", 50, seed=22, trials=3, scenarios="fresh"),
    ]
    planned = [(config.to_json(), str(tmp_path / "dask" / f"run{k}")) for k, config in enumerate(configs)]
    for k, config in enumerate(configs):
        run_one(config.to_json(), str(tmp_path / "local" / f"run{k}"), checkpoint_interval=0)
    progress: dict[str, int] = {}
    finished = []
    killed = threading.Event()
    settings = parse_cluster(cluster.scheduler_address.replace("tcp://", "dask://"))
    with open_client(settings) as client:
        assert client is not None
        client.wait_for_workers(2)
        pids = worker_pids(client)
        victim = planned[0][1]

        def on_progress(root: str, produced: int) -> None:
            progress[root] = max(progress.get(root, 0), produced)
            if root == victim and produced > 0 and not killed.is_set():  # mid-run: checkpointed, not done
                address = next(a for a, keys in client.processing().items() if any(root in k for k in keys))
                killed.set()
                os.kill(pids[address], signal.SIGKILL)

        for root, error in map_runs(client, run_one, planned, checkpoint_interval=0, on_progress=on_progress):
            assert error is None, f"{root}: {error}"
            finished.append(root)
    assert killed.is_set()
    assert sorted(finished) == sorted(root for _, root in planned)
    assert set(progress) == set(finished) and all(n > 0 for n in progress.values())
    for k in range(len(configs)):
        local = run_files(tmp_path / "local" / f"run{k}")
        assert run_files(tmp_path / "dask" / f"run{k}") == local and "summary.json" in local


def test_finished_runs_are_left_alone(client, tmp_path):
    config = RunConfig.make("qd", "food", 50, seed=3, trials=2)
    root = str(tmp_path / "run")
    run_one(config.to_json(), root, checkpoint_interval=0)
    before = {p: p.stat().st_mtime_ns for p in Path(root).rglob("*") if p.is_file()}
    assert list(map_runs(client, run_one, [(config.to_json(), root)])) == [(root, None)]
    assert {p: p.stat().st_mtime_ns for p in Path(root).rglob("*") if p.is_file()} == before


# The commands' --cluster ----------------------------------------------------------------------------------
def dask_option(cluster: LocalCluster) -> str:
    return cluster.scheduler_address.replace("tcp://", "dask://")


def test_evolve_on_a_dask_scheduler_writes_the_bytes_of_a_local_run(cluster, tmp_path, capsys):
    from evolution_manager.studies.evolve import evolve

    run = ["--algorithm", "qd", "--objective", "nest", "--evaluations", "60", "--seed", "4", "--trials", "3"]
    run += ["--no-progress", "--no-figures", "--checkpoint-every", "0"]
    assert evolve([*run, "--out", str(tmp_path / "local")]) == 0
    assert evolve([*run, "--out", str(tmp_path / "dask"), "--cluster", dask_option(cluster)]) == 0
    said = capsys.readouterr().err
    assert f"cluster: work goes to the Dask scheduler at {cluster.scheduler_address}" in said
    local, dask = run_files(tmp_path / "local"), run_files(tmp_path / "dask")
    assert "heldout.json" in local and "summary.json" in local  # the held-out scores too
    assert {k: v for k, v in dask.items() if k != "sessions.json"} == {
        k: v for k, v in local.items() if k != "sessions.json"
    }
    (session,) = json.loads(dask["sessions.json"])  # where it ran, beside the run, not in config.json
    assert session["cluster"] == {"kind": "dask", "address": cluster.scheduler_address, "slurm": None}
    assert session["command"].endswith(f"--cluster {dask_option(cluster)}")
    assert json.loads(local["sessions.json"])[0]["cluster"]["kind"] == "local"


def test_adapt_benchmark_on_a_dask_scheduler_writes_the_files_of_a_local_one(cluster, tmp_path):
    from small_repertoires import adapt_benchmark_argv, food_repertoire

    from evolution_manager.adaptation.adapt_benchmark import main as adapt_benchmark

    common = adapt_benchmark_argv(food_repertoire(tmp_path / "repertoire", 6), budget=3, ceiling=30, trials=2)
    for where, options in (("local", []), ("dask", ["--cluster", dask_option(cluster)])):
        with pytest.raises(SystemExit) as ended:
            adapt_benchmark([*common, "--out", str(tmp_path / where), *options])
        assert ended.value.code == 0
    for name in ("runs.csv", "ceilings.csv", "summary.json"):  # report.md names its --out
        assert (tmp_path / "dask" / name).read_bytes() == (tmp_path / "local" / name).read_bytes(), name


def _no_port() -> int:
    with socket.socket() as s:  # a port that nobody listens on
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


@pytest.mark.parametrize(
    "command,options,expected",
    [
        ("experiment", ["--cluster", "dask://127.0.0.1:{port}"], "no Dask scheduler answers there"),
        ("evolve", ["--cluster", "dask://127.0.0.1:{port}"], "no Dask scheduler answers there"),
        ("adapt-benchmark", ["--cluster", "dask://127.0.0.1:{port}"], "no Dask scheduler answers there"),
        ("experiment", ["--cluster", "slurm", "--cluster-config", "{config}"], "unknown key 'queue'"),
        ("evolve", ["--cluster", "slurm", "--cluster-config", "{config}"], "unknown key 'queue'"),
        ("adapt-benchmark", ["--cluster", "slurm", "--cluster-config", "{config}"], "unknown key 'queue'"),
        ("experiment", ["--cluster", "dask://host:port"], "--cluster 'dask://host:port': Port could not"),
        ("experiment", ["--cluster", "dask://h:1", "--processes", "2"], "--processes applies to --cluster"),
        ("evolve", ["--cluster", "dask://h:1", "--workers", "2"], "--workers applies to --cluster local"),
    ],
)
def test_bad_cluster_settings_are_one_line_and_exit_2(command, options, expected, tmp_path, capsys):
    from evolution_manager.adaptation.adapt_benchmark import main as adapt_benchmark
    from evolution_manager.studies.evolve import evolve
    from evolution_manager.studies.experiment import experiment

    config = tmp_path / "cluster.yaml"
    config.write_text("cores: 1\nqueue: compute\n")  # dask-jobqueue's name; ours is partition
    out = tmp_path / "out"
    argv = {
        "experiment": ["--runs", "1", "--evaluations", "10", "--out", str(out)],
        "evolve": ["--algorithm", "qd", "--objective", "food", "--evaluations", "10", "--out", str(out)],
        "adapt-benchmark": ["--repertoires", str(tmp_path), "--condition-set", "c=1", "--out", str(out)],
    }[command] + [option.format(port=_no_port(), config=config) for option in options]
    if command == "adapt-benchmark":
        with pytest.raises(SystemExit) as ended:
            adapt_benchmark(argv)
        status = ended.value.code
    else:
        status = {"experiment": experiment, "evolve": evolve}[command](argv)
    err = capsys.readouterr().err
    assert status == 2
    assert err.count("\n") == 1 and err.startswith(f"{command}: error: ") and expected in err, err
    assert not out.exists()  # nothing written
