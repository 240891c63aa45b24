"""Fixtures of the system tests."""

import pytest

from swarm_ros import isolation

workspace = pytest.fixture(isolation.workspace)  # the shared fixture of tests that start processes
