"""Every Python package declares in its package.xml exactly what its code imports (rosdep keys for Python
libraries, package names for ROS packages): nothing missing, nothing unused. A package.xml that rosdep and
colcon can trust on a full ROS 2 install."""

import ast
import sys
import xml.etree.ElementTree as ET  # our own package.xml files
from pathlib import Path
from typing import TypeGuard

import pytest

SRC = Path(__file__).resolve().parents[1] / "src"
PYTHON_PACKAGES = sorted(p.parent.name for p in SRC.glob("*/setup.py"))

ROSDEP_KEYS = {
    "numpy": "python3-numpy",
    "numba": "python3-numba",
    "llvmlite": "python3-llvmlite",
    "scipy": "python3-scipy",
    "matplotlib": "python3-matplotlib",
    "defusedxml": "python3-defusedxml",
    "cma": "python3-cma",
    "deap": "python3-deap",
    "qdpy": "python3-qdpy",
    "ribs": "python3-ribs",
    "tqdm": "python3-tqdm",
    "rosbags": "python3-rosbags",
    "mcap": "python3-mcap",
    "mcap_ros2": "python3-mcap-ros2-support",
    "py_trees": "py_trees",
    "yaml": "python3-yaml",
    "setuptools": "python3-setuptools",
    "sklearn": "python3-sklearn",
    "PIL": "python3-pil",
    "dask": "python3-dask",
    "distributed": "python3-distributed",
    "dask_jobqueue": "python3-dask-jobqueue",
    "statsmodels": "python3-statsmodels",
    "pandas": "python3-pandas",
    "threadpoolctl": "python3-threadpoolctl",
}
"""Python libraries by import name, with the key their package.xml dependency uses."""
RUN_DEPENDENCIES = ("depend", "exec_depend")


def declared(package: str) -> set[str]:
    root = ET.parse(SRC / package / "package.xml").getroot()
    return {element.text.strip() for tag in RUN_DEPENDENCIES for element in root.iter(tag)}


def imported(package: str) -> dict[str, str]:
    """Top-level modules imported by the package's code and launch files, each with a file that imports it."""
    files = [*(SRC / package / package).rglob("*.py"), *(SRC / package / "launch").glob("*.py")]
    found: dict[str, str] = {}
    for path in files:
        module = ast.parse(path.read_text(), str(path))
        typing_only = {
            id(node)
            for block in ast.walk(module)
            if _is_type_checking(block)
            for statement in block.body  # not its else branch, which runs
            for node in ast.walk(statement)
        }
        for node in ast.walk(module):
            if id(node) in typing_only:
                continue  # under `if TYPE_CHECKING:`: read by type checkers, never imported at run time
            if isinstance(node, ast.Import):
                names = [alias.name for alias in node.names]
            elif isinstance(node, ast.ImportFrom) and node.level == 0 and node.module:
                names = [node.module]
            else:
                continue
            for name in names:
                found.setdefault(name.split(".")[0], str(path.relative_to(SRC)))
    return found


def _is_type_checking(node: ast.AST) -> TypeGuard[ast.If]:
    """Whether ``node`` is an ``if TYPE_CHECKING:`` (or ``typing.TYPE_CHECKING``) block."""
    if not isinstance(node, ast.If):
        return False
    test = node.test
    return (isinstance(test, ast.Name) and test.id == "TYPE_CHECKING") or (
        isinstance(test, ast.Attribute) and test.attr == "TYPE_CHECKING"
    )


def dependency_key(module: str) -> str | None:
    """The package.xml key of an imported module; None for the standard library."""
    if module in sys.stdlib_module_names or module == "__future__":
        return None
    return ROSDEP_KEYS.get(module, module)


@pytest.mark.parametrize("package", PYTHON_PACKAGES)
def test_every_import_is_declared(package):
    keys = declared(package)
    missing = {
        f"{dependency_key(module)} (imported in {where})"
        for module, where in imported(package).items()
        if module != package and dependency_key(module) is not None and dependency_key(module) not in keys
    }
    assert not missing, f"{package}/package.xml lacks: {', '.join(sorted(missing))}"


@pytest.mark.parametrize("package", PYTHON_PACKAGES)
def test_nothing_is_declared_without_use(package):
    used = {dependency_key(m) for m in imported(package)}
    unused = declared(package) - used
    assert not unused, f"{package}/package.xml declares what its code never imports: {sorted(unused)}"


def test_the_checker_sees_imports_and_declarations():
    """The checker itself: the simulator's imports are found, and the swarm_sim package.xml is read."""
    assert {"rclpy", "swarm_msgs", "numpy"} <= set(imported("swarm_sim"))
    assert "rclpy" in declared("swarm_sim")
    # swarm_ros/parameters.py imports _typeshed (no run-time module) only for the type checker
    assert "_typeshed" not in imported("swarm_ros") and "rclpy" in imported("swarm_ros")
