"""A real one-node SLURM (Debian's slurm-wlm and munge, started by the ``slurm`` fixture): jobs are really
submitted, run and cancelled; then experiments and runs through dask-jobqueue's SLURMCluster."""

from __future__ import annotations

import time
from pathlib import Path

import pytest
from slurm_cluster import OneNodeSlurm


def wait_for(condition, timeout: float, what: str) -> None:
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        if condition():
            return
        time.sleep(0.2)
    pytest.fail(f"no {what} within {timeout} s")


def test_the_node_is_this_machine_and_idle(slurm: OneNodeSlurm):
    import os

    out = slurm.run(["sinfo", "--noheader", "--format", "%P %c %T"]).stdout.split()
    assert out == [f"{slurm.PARTITION}*", str(os.cpu_count()), "idle"]


def test_sbatch_runs_a_batch_job_and_srun_a_step(slurm: OneNodeSlurm, tmp_path):
    output = tmp_path / "job.out"
    job = slurm.run(["sbatch", "--parsable", "--output", str(output), "--wrap", "echo ran in $SLURM_JOB_ID"])
    job_id = job.stdout.strip().split(";")[0]
    assert job_id.isdigit()
    wait_for(lambda: output.exists() and output.read_text().strip(), 60, "output of the batch job")
    assert output.read_text().strip() == f"ran in {job_id}"
    step = slurm.run(["srun", "-n1", "bash", "-c", "echo step of $SLURM_JOB_ID on $SLURMD_NODENAME"])
    assert step.stdout.startswith("step of ") and step.stdout.strip().endswith(f"on {slurm.NODE}")


def test_scancel_ends_a_running_job_and_its_processes(slurm: OneNodeSlurm, tmp_path):
    pid_file = tmp_path / "sleep.pid"
    job = slurm.run(
        ["sbatch", "--parsable", "--output", "/dev/null", "--wrap", f"sleep 300 & echo $! > {pid_file}; wait"]
    )
    job_id = job.stdout.strip().split(";")[0]
    wait_for(lambda: pid_file.exists() and pid_file.read_text().strip(), 60, "start of the batch job")
    sleeper = Path("/proc") / pid_file.read_text().strip()
    assert sleeper.exists() and slurm.jobs().get(job_id) == "RUNNING"
    slurm.run(["scancel", job_id])
    wait_for(lambda: job_id not in slurm.jobs(), 30, "end of the cancelled job")
    wait_for(lambda: not sleeper.exists(), 10, "end of the job's process")
    wait_for(lambda: slurm.node_state() == "idle", 30, "the node idle again")


# Dask workers as SLURM jobs (dask-jobqueue) ---------------------------------------------------------------
def run_files(root: Path) -> dict[str, bytes]:
    """A run directory's files but those holding wall-clock times (timing.json, checkpoint.json), its lock,
    and its SVG drawings (matplotlib salts their clip-path names at random: two local runs differ there)."""
    return {
        str(p.relative_to(root)): p.read_bytes()
        for p in sorted(root.rglob("*"))
        if p.is_file() and p.name not in {"timing.json", "checkpoint.json", ".lock"} and p.suffix != ".svg"
    }


def test_runs_on_slurm_jobs_equal_local_runs_and_a_cancelled_job_loses_nothing(slurm, tmp_path, monkeypatch):
    import os

    from evolution_manager.cluster.client import open_client
    from evolution_manager.cluster.evaluator import DaskEvaluator
    from evolution_manager.cluster.runs import map_runs
    from evolution_manager.cluster.settings import ClusterSettings, SlurmSettings
    from evolution_manager.evolution.run import Run
    from evolution_manager.evolution.run_config import RunConfig
    from evolution_manager.evolution.run_results import run_results
    from evolution_manager.studies.experiment import run_one
    from evolution_manager.viewing.results import write_results
    from swarm_sim.evaluation import BatchEvaluator
    from swarm_sim.model import default_config

    monkeypatch.setenv("SLURM_CONF", str(slurm.conf))  # the client commands and the jobs find this cluster
    configs = [
        RunConfig.make("qd", "food", 200, seed=31, trials=3),  # its job is cancelled mid-run
        RunConfig.make("gp-fnd", None, 50, seed=32, trials=3),
    ]
    planned = [(c.to_json(), str(tmp_path / "slurm" / f"run{k}")) for k, c in enumerate(configs)]
    for k, config in enumerate(configs):
        run_one(config.to_json(), str(tmp_path / "local" / f"run{k}"), checkpoint_interval=0)
    single = RunConfig.make("qd", "nest", 60, seed=33, trials=3)
    in_process = BatchEvaluator(default_config(single.profile))
    local_run = Run.start(single, tmp_path / "local" / "single", in_process)
    local_run.execute(checkpoint_interval=0)
    write_results(local_run, run_results(local_run, local_run.evaluator), with_figures=False)
    local_run.lock.release()

    settings = ClusterSettings(
        "slurm",
        slurm=SlurmSettings(
            cores=1, memory="1GB", walltime="00:30:00", jobs=2, log_directory=str(tmp_path / "jobs")
        ),
    )
    said: list[str] = []
    cancelled: list[str] = []
    with open_client(settings, say=said.append) as client:
        assert said[0] == "cluster: work goes to 2 SLURM job(s) of 1 core(s), 1GB, 00:30:00"
        client.wait_for_workers(2, timeout=120)
        first_jobs = set(slurm.jobs())
        assert len(first_jobs) == 2 and set(slurm.jobs().values()) == {"RUNNING"}
        job_of = client.run(lambda: os.environ["SLURM_JOB_ID"])  # worker address -> its SLURM job
        assert set(job_of.values()) == first_jobs

        def on_progress(root: str, produced: int) -> None:
            if root == planned[0][1] and produced > 0 and not cancelled:  # checkpointed, not finished
                address = next(a for a, keys in client.processing().items() if any(root in k for k in keys))
                cancelled.append(job_of[address])
                slurm.run(["scancel", job_of[address]])

        results = dict(map_runs(client, run_one, planned, checkpoint_interval=0, on_progress=on_progress))
        assert results == {root: None for _, root in planned}
        assert cancelled and cancelled[0] not in slurm.jobs()
        wait_for(lambda: set(slurm.jobs()) - first_jobs, 60, "a job submitted in place of the cancelled one")

        evaluator = DaskEvaluator(client, single.profile, chunk=10)
        run = Run.start(single, tmp_path / "slurm" / "single", evaluator)
        run.execute(checkpoint_interval=0)
        write_results(run, run_results(run, evaluator), with_figures=False)
        run.lock.release()
    for k in range(len(configs)):
        local = run_files(tmp_path / "local" / f"run{k}")
        assert "summary.json" in local and run_files(tmp_path / "slurm" / f"run{k}") == local
    assert run_files(tmp_path / "slurm" / "single") == run_files(tmp_path / "local" / "single")
    wait_for(lambda: not slurm.jobs(), 60, "the worker jobs ended with the client")


# The experiment command through SLURM ---------------------------------------------------------------------
def slurm_job_of(pid: int) -> str | None:
    """The SLURM job a process runs in (its SLURM_JOB_ID), or None."""
    try:
        environ = (Path("/proc") / str(pid) / "environ").read_bytes().split(b"\0")
    except OSError:
        return None
    found = [item.split(b"=", 1)[1].decode() for item in environ if item.startswith(b"SLURM_JOB_ID=")]
    return found[0] if found else None


def test_an_experiment_through_slurm_equals_the_local_one_though_a_job_is_cancelled_mid_run(slurm, tmp_path):
    """``experiment --cluster slurm`` against ``--cluster local``: the same runs.csv and run files, although
    the job running the longest run (GP_fnd) is cancelled mid-run: it is replaced, the run continues."""
    import json
    import subprocess

    from evolution_manager.graph.startup import executable
    from evolution_manager.processes import lock_holder

    config = tmp_path / "cluster.yaml"
    jobs = tmp_path / "jobs"
    config.write_text(f"cores: 1\nmemory: 1GB\nwalltime: '00:30:00'\njobs: 2\nlog_directory: {jobs}\n")
    small = ["--runs", "1", "--evaluations", "60", "--trials", "3", "--checkpoint-every", "0"]
    small.append("--no-progress")
    experiment = str(executable("evolution_manager", "experiment"))
    started = {}
    for where, options in (
        ("local", ["--processes", "1"]),
        ("slurm", ["--cluster", "slurm", "--cluster-config", str(config)]),
    ):
        log = (tmp_path / f"{where}.log").open("w")
        started[where] = subprocess.Popen(
            [experiment, *small, "--out", str(tmp_path / where), *options],
            env=slurm.environment(),
            stdout=log,
            stderr=subprocess.STDOUT,
        )  # both at once: the SLURM jobs start while the local runs go
        log.close()
    victim = tmp_path / "slurm" / "runs" / "GP_fnd" / "run00"
    cancelled = None
    deadline = time.monotonic() + 600
    try:
        while started["slurm"].poll() is None and time.monotonic() < deadline:
            if (
                cancelled is None
                and (victim / "checkpoint.json").exists()
                and not (victim / "summary.json").exists()
            ):
                job = slurm_job_of(lock_holder(victim / ".lock") or 0)
                if job is not None and not (victim / "summary.json").exists():
                    slurm.run(["scancel", job])
                    cancelled = job
            time.sleep(0.1)
        for where, process in started.items():
            assert process.wait(timeout=600) == 0, (tmp_path / f"{where}.log").read_text()[-3000:]
    finally:
        for process in started.values():
            if process.poll() is None:
                process.kill()
    assert cancelled is not None, "the GP_fnd run was never caught mid-run"
    assert (
        "cluster: work goes to 2 SLURM job(s) of 1 core(s), 1GB, 00:30:00"
        in (tmp_path / "slurm.log").read_text()
    )
    assert len(list(jobs.glob("*.err"))) >= 3  # the 2 jobs and the one submitted in place of the cancelled
    local, on_slurm = tmp_path / "local", tmp_path / "slurm"
    assert (on_slurm / "runs.csv").read_bytes() == (local / "runs.csv").read_bytes()
    assert (on_slurm / "experiment.json").read_bytes() == (local / "experiment.json").read_bytes()
    plan = json.loads((local / "experiment.json").read_text())["plan"]
    assert len(plan) == 7
    for planned in plan:
        files = run_files(local / planned["dir"])
        assert "summary.json" in files and run_files(on_slurm / planned["dir"]) == files, planned["dir"]
    (session,) = json.loads((on_slurm / "sessions.json").read_text())
    assert session["cluster"]["kind"] == "slurm" and session["cluster"]["slurm"]["jobs"] == 2
    assert session["runs_finished"] == 7
    wait_for(lambda: not slurm.jobs(), 60, "the worker jobs ended with the experiment")
