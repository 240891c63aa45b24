"""Shared fixtures: the test directory is importable (``toy``), and a fresh primitive set per test."""

from __future__ import annotations

import sys
from pathlib import Path

import pytest

sys.path.insert(0, str(Path(__file__).parent))


@pytest.fixture
def pset():
    from evolution_manager.primitives import make_primitive_set

    return make_primitive_set()
