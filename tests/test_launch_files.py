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
from evolution_manager.graph.startup import (
    LAUNCH_ARGUMENTS,
    GraphError,
    executable,
    launch_graph_nodes,
    package_config,
    trial_graph_nodes,
)
from swarm_sim.model import DEFAULT
from swarm_sim.nodes.settings import SIMULATOR_PARAMETERS, EvaluatorSettings
from swarm_sim.tasks import resolve_task, world_parameters

LAUNCH_DIR = Path(get_package_share_directory("evolution_manager")) / "launch"
ARGUMENTS = {
    # every option of `trial` that shapes the graph, and the controllers' commands and use_sim_time
    "trial_graph.launch.py": {
        "timing",
        "rate",
        "robots",
        "namespace",
        "tree",
        "swarm",
        "profile",
        "task",
        "library",
        "clock",
        "commands",
        "use_sim_time",
        "params_file",
    },
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
    declares = calls(path, "DeclareLaunchArgument")
    if all(isinstance(c.args[0], ast.Constant) for c in declares):
        declared = {c.args[0].value for c in declares}
    else:  # one declaration per entry of startup.LAUNCH_ARGUMENTS
        assert "LAUNCH_ARGUMENTS" in path.read_text()
        declared = set(LAUNCH_ARGUMENTS)
    assert declared == ARGUMENTS[name]
    assert calls(path, "package_config"), f"{name} does not hand the packages' parameter files to its nodes"


def test_the_trial_graph_launch_file_starts_the_nodes_trial_starts():
    path = LAUNCH_DIR / "trial_graph.launch.py"
    assert calls(path, "launch_graph_nodes")  # trial_graph_nodes, given the launch arguments
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


def test_the_launch_arguments_give_each_graph_its_clock_sim_time_commands_task_and_library(tmp_path):
    # two swarms launched side by side, each on its own clock: every node of a graph follows its own
    a = launch_graph_nodes({"namespace": "/swarm_a", "clock": "/swarm_a/clock", "robots": "2"})
    b = launch_graph_nodes(
        {"namespace": "/swarm_b", "clock": "/swarm_b/clock", "robots": "2", "use_sim_time": "true"}
    )
    assert [n.remaps for n in a] == [{"/clock": "/swarm_a/clock"}] * 3
    assert [n.remaps for n in b] == [{"/clock": "/swarm_b/clock"}] * 3
    assert all("use_sim_time" not in n.parameters for n in a)
    assert all(n.parameters["use_sim_time"] is True for n in b)
    assert all(n.remaps == {} for n in launch_graph_nodes({}))  # by default the root /clock
    assert len(launch_graph_nodes({})) == 1 + DEFAULT.n_robots

    nodes = launch_graph_nodes({"commands": "cmd_vel", "robots": "2", "tree": "forward"})
    assert nodes[0].parameters == {"n_robots": 2}
    assert all(n.parameters == {"commands": "cmd_vel", "tree": "forward"} for n in nodes[1:])

    library = tmp_path / "lib.json"
    library.write_text('{"format": 1, "primitives": [{"name": "go", "tree": "forward"}]}')
    nodes = launch_graph_nodes({"task": "foraging", "library": str(library), "tree": "go"})
    foraging = resolve_task("foraging")
    assert nodes[0].parameters == {**world_parameters(foraging.config()), "n_robots": foraging.robots.count}
    assert len(nodes) == 1 + foraging.robots.count
    assert all(n.parameters == {"library": str(library), "tree": "go"} for n in nodes[1:])

    free = launch_graph_nodes({"timing": "free", "rate": "2.5", "robots": "2"})
    assert free[0].parameters == {"n_robots": 2, "timing": "free", "rate": 2.5}
    assert all(n.parameters == {"timing": "free", "use_sim_time": True} for n in free[1:])
    assert "timing" not in launch_graph_nodes({"robots": "2"})[0].parameters  # lockstep: the nodes' default
    with pytest.raises(GraphError, match="rate:=fast: expected a number"):
        launch_graph_nodes({"timing": "free", "rate": "fast"})
    with pytest.raises(GraphError, match="timing 'loose': expected one of lockstep, free"):
        launch_graph_nodes({"timing": "loose"})
    with pytest.raises(GraphError, match="unknown launch arguments seed"):
        launch_graph_nodes({"seed": "1"})
    with pytest.raises(GraphError, match="use_sim_time:=yes"):
        launch_graph_nodes({"use_sim_time": "yes"})
    with pytest.raises(GraphError, match=r"launch arguments: .*no_such_task"):
        launch_graph_nodes({"task": "no_such_task"})


def test_the_evaluators_launch_file_starts_installed_evaluators():
    (node,) = calls(LAUNCH_DIR / "evaluators.launch.py", "Node")
    keywords = {k.arg: k.value.value for k in node.keywords if isinstance(k.value, ast.Constant)}
    assert executable(keywords["package"], keywords["executable"]).exists()


def test_the_parameter_files_hold_the_defaults():
    world = yaml.safe_load(package_config("swarm_sim").read_text())["/**"]["ros__parameters"]
    expected = {
        name: list(value) if isinstance(value, tuple) else value for name, value in DEFAULT.as_dict().items()
    }
    expected["layout"] = ""  # no layout: the papers' arena (the parameter holds a layout's JSON text)
    # one robot type: a parameter all the same, which as_dict leaves out so that files read as before types
    expected["robot_types"] = DEFAULT.robot_types
    expected["carries"] = ""  # every robot carries every kind (the parameter holds the groups' JSON text)
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
