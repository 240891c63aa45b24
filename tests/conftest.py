"""Fixtures of the system tests: ``workspace`` (tests that start processes), ``graph``, one trial graph under
the defaults for every test that needs one, and ``slurm``, a real one-node SLURM on this machine
(slurm_cluster)."""

from __future__ import annotations

import shutil
import tempfile
from collections.abc import Iterator
from pathlib import Path

import pytest
from slurm_cluster import OneNodeSlurm

from evolution_manager.graph.nodes.trial import TrialGraph
from swarm_ros import isolation

workspace = pytest.fixture(isolation.workspace)  # the shared fixture of tests that start processes


@pytest.fixture(scope="session")
def graph() -> Iterator[TrialGraph]:
    """A trial graph under the defaults (paper profile, primitives task, nine robots) in a domain of its own,
    shared by every system test that runs trials through such a graph: starting its ten node processes and
    stopping them costs about 20 s of two cores each time. A trial loads its trees into every controller
    and runs its chain from the start, so a test sees no trace of the trials before it; a test must leave
    the graph running (one that kills or reconfigures nodes starts its own). The timeout (seconds without a
    step or an answer before a trial fails) is the largest any of its tests used."""
    with TrialGraph(timeout=240.0) as running:
        yield running


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
