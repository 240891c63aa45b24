"""The launch files (for full ROS 2 installs; `launch` and `launch_ros` are not on PyPI, so they cannot run
here): their arguments, the node set they describe (the same function `trial` starts its processes from), and
the parameter files they hand to the nodes, which hold the nodes' own defaults."""

import ast
from dataclasses import asdict
from pathlib import Path

import pytest
import yaml
from ament_index_python.packages import get_package_share_directory

from bt_controller.nodes.footbot_controller import ControllerSettings
from evolution_manager.graph.nodes.manager import ManagerParameters
from evolution_manager.graph.startup import GraphError, executable, package_config, trial_graph_nodes
from swarm_sim.config import DEFAULT
from swarm_sim.nodes.settings import SIMULATOR_PARAMETERS, EvaluatorSettings

LAUNCH_DIR = Path(get_package_share_directory("evolution_manager")) / "launch"
ARGUMENTS = {
    "trial_graph.launch.py": {"robots", "namespace", "tree", "swarm", "profile", "params_file"},
    "evaluators.launch.py": {"count", "profile", "params_file"},
}


def calls(path, name):
    """Every call of ``name`` (a plain name) in a launch file."""
    tree = ast.parse(path.read_text())
    return [c for c in ast.walk(tree) if isinstance(c, ast.Call) and getattr(c.func, "id", None) == name]


@pytest.mark.parametrize("name", sorted(ARGUMENTS))
def test_launch_files_are_installed_and_declare_their_arguments(name):
    path = LAUNCH_DIR / name
    assert path.exists(), f"{name} is not installed in share/evolution_manager/launch"
    declared = {c.args[0].value for c in calls(path, "DeclareLaunchArgument")}
    assert declared == ARGUMENTS[name]
    assert calls(path, "package_config"), f"{name} does not hand the packages' parameter files to its nodes"


def test_the_trial_graph_launch_file_starts_the_nodes_trial_starts():
    path = LAUNCH_DIR / "trial_graph.launch.py"
    assert calls(path, "trial_graph_nodes")
    nodes = trial_graph_nodes(3, "/swarm_a", tree="forward", profile="clean")
    assert [(n.package, n.executable, n.namespace) for n in nodes] == [
        ("swarm_sim", "simulator", "/swarm_a"),
        *[("bt_controller", "footbot_controller", f"/swarm_a/footbot_{i}") for i in range(3)],
    ]
    assert nodes[0].parameters == {"n_robots": 3, "profile": "clean"}
    assert all(n.parameters == {"tree": "forward"} for n in nodes[1:])
    for node in nodes:
        assert executable(node.package, node.executable).exists()
    assert trial_graph_nodes(9)[0].parameters == {"n_robots": 9}  # no profile given: the parameter file's
    assert all(n.remaps == {} for n in nodes)  # the clock stays /clock, at the root, in a namespaced graph
    assert trial_graph_nodes(2, "/swarm_b", clock="/swarm_b/clock")[0].remaps == {"/clock": "/swarm_b/clock"}
    (node,) = calls(path, "Node")
    assert "remappings" in {k.arg for k in node.keywords}, "the launch file does not hand the remappings over"
    with pytest.raises(GraphError, match="at least one robot"):
        trial_graph_nodes(0)


def test_the_evaluators_launch_file_starts_installed_evaluators():
    (node,) = calls(LAUNCH_DIR / "evaluators.launch.py", "Node")
    keywords = {k.arg: k.value.value for k in node.keywords if isinstance(k.value, ast.Constant)}
    assert executable(keywords["package"], keywords["executable"]).exists()


def test_the_parameter_files_hold_the_defaults():
    world = yaml.safe_load(package_config("swarm_sim").read_text())["/**"]["ros__parameters"]
    expected = {
        name: list(value) if isinstance(value, tuple) else value for name, value in DEFAULT.as_dict().items()
    }
    assert {k: v for k, v in world.items() if k in expected} == expected
    assert world["answer_timeout"] == 60.0
    controller = yaml.safe_load(package_config("bt_controller").read_text())["/**"]["ros__parameters"]
    assert controller == asdict(ControllerSettings())
    # every name of the shared world file is declared by the simulator or the evaluator
    assert set(world) <= set(expected) | SIMULATOR_PARAMETERS | set(asdict(EvaluatorSettings())) | {
        "autostart"
    }
    manager = yaml.safe_load(package_config("evolution_manager").read_text())["/**"]["ros__parameters"]
    assert manager == asdict(ManagerParameters())
