"""Fixtures of the system tests: ``workspace`` (tests that start processes) and ``slurm``, a real one-node
SLURM on this machine (slurm_cluster)."""

from __future__ import annotations

import shutil
import tempfile
from collections.abc import Iterator
from pathlib import Path

import pytest
from slurm_cluster import OneNodeSlurm

from swarm_ros import isolation

workspace = pytest.fixture(isolation.workspace)  # the shared fixture of tests that start processes


@pytest.fixture(scope="session")
def slurm() -> Iterator[OneNodeSlurm]:
    """MUNGE, slurmctld and slurmd started for the session (the node idle in ``sinfo``), stopped by PID at
    its end with nothing left running. A short directory under /tmp: MUNGE's socket path has a length limit
    and wants its directories open for execute, which pytest's own temporary directories are not."""
    directory = Path(tempfile.mkdtemp(prefix="swarm-slurm-"))
    cluster = OneNodeSlurm(directory)
    cluster.start()
    try:
        yield cluster
    finally:
        cluster.stop()
        assert not cluster.stray_processes(), "processes of the test SLURM outlived it"
        shutil.rmtree(directory, ignore_errors=True)
