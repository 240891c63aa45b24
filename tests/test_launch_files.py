"""The launch files (for full ROS 2 installs; `launch` is not on PyPI) name executables that are installed."""

import ast
from pathlib import Path

import pytest
from ament_index_python.packages import get_package_share_directory

from evolution_manager.graph import executable

LAUNCH_DIR = Path(get_package_share_directory("evolution_manager")) / "launch"


def launched_executables(path):
    """(package, executable) of every launch_ros Node(...) call in a launch file."""
    found = []
    for call in ast.walk(ast.parse(path.read_text())):
        if isinstance(call, ast.Call) and getattr(call.func, "id", None) == "Node":
            keywords = {k.arg: k.value for k in call.keywords if isinstance(k.value, ast.Constant)}
            found.append((keywords["package"].value, keywords["executable"].value))
    return found


@pytest.mark.parametrize("name", ["trial_graph.launch.py", "evaluators.launch.py"])
def test_launch_files_are_installed_and_name_installed_executables(name):
    path = LAUNCH_DIR / name
    assert path.exists(), f"{name} is not installed in share/evolution_manager/launch"
    nodes = launched_executables(path)
    assert nodes, f"{name} starts no node"
    for package, name in nodes:
        assert executable(package, name).exists()
