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
