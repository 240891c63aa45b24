"""Shared fixtures: the test directory is importable (``toy``), and a fresh primitive set per test."""

from __future__ import annotations

import sys
from pathlib import Path

import pytest

from swarm_ros import isolation

sys.path.insert(0, str(Path(__file__).parent))


@pytest.fixture
def pset():
    from evolution_manager.evolution.deap_trees import make_primitive_set

    return make_primitive_set()


workspace = pytest.fixture(isolation.workspace)  # the shared fixture of tests that start processes
