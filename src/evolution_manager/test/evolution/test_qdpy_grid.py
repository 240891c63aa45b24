"""qdpy's Grid is imported without scikit-learn, and scikit-learn stays importable for real afterwards."""

import subprocess
import sys

SCRIPT = """
import sys
import evolution_manager.evolution.archive
print("sklearn" in sys.modules, "sklearn.cluster" in sys.modules)
import qdpy.containers.grids as grids
from evolution_manager.evolution.qdpy_grid import DeferredClass, Grid
print(isinstance(grids.KMeans, DeferredClass), Grid is grids.Grid)
import sklearn.cluster
print(grids.KMeans.real() is sklearn.cluster.KMeans, type(sklearn.cluster).__name__)
"""


def test_archive_imports_qdpy_without_scikit_learn():
    run = subprocess.run(
        [sys.executable, "-c", SCRIPT], capture_output=True, text=True, check=False, timeout=300
    )
    assert run.returncode == 0, run.stderr
    assert run.stdout.split("\n")[:3] == ["False False", "True True", "True module"]
