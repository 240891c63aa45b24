"""Every node executable of the graph refuses a bad parameter in one line, with exit status 2: a value of the
wrong type or out of range, or a name the node does not declare, from ``-p NAME:=VALUE`` or from a
``--params-file`` (also when an earlier file gave the parameter a value of the right type, which rcl alone
would keep without a word), and a parameter file that is not YAML. The installed parameter files, whose
``/**`` sections every node of the graph reads, are accepted by each node."""

import signal
import subprocess

import pytest

from evolution_manager.graph.startup import executable, package_config
from swarm_ros.isolation import domain_environment, reserved_domain

STARTED = 90
"""Seconds after which a node that has not stopped is taken to have accepted its parameters (a refusal comes
before any work; starting the Python process takes a few seconds, longer on a loaded machine)."""
NODES = {
    "simulator": ("swarm_sim", "simulator"),
    "evaluator": ("swarm_sim", "evaluator"),
    "footbot_controller": ("bt_controller", "footbot_controller"),
    "sensor_bridge": ("swarm_sim", "sensor_bridge"),
}


def refused(node, *ros_args, namespace="/footbot_0"):
    """Start ``node`` with ``ros_args``; return its one-line complaint (exit 2, no traceback)."""
    package, name = NODES[node]
    command = [str(executable(package, name)), "--ros-args", "-r", f"__ns:={namespace}", *ros_args]
    with reserved_domain() as domain:
        try:
            done = subprocess.run(
                command, env=domain_environment(domain), capture_output=True, text=True, timeout=STARTED
            )
        except subprocess.TimeoutExpired:
            pytest.fail(f"{node} took {ros_args} and kept running")
    lines = done.stderr.strip().splitlines()
    assert done.returncode == 2, done.stderr
    assert len(lines) == 1 and "Traceback" not in done.stderr, done.stderr
    assert lines[0].startswith(f"{node}: ")
    return lines[0]


def params_file(tmp_path, text, name="my.yaml"):
    path = tmp_path / name
    path.write_text(text)
    return str(path)


@pytest.mark.parametrize("node", ["simulator", "evaluator"])
def test_a_value_of_the_wrong_type_on_the_command_line(node):
    line = refused(node, "-p", "wheel_speed:=fast")
    assert "wheel_speed" in line and "'fast'" in line and "expected a floating-point number" in line


def test_an_integer_for_a_floating_point_parameter_says_how_to_write_it():
    line = refused("simulator", "-p", "wheel_speed:=80")
    assert "wheel_speed := 80" in line and "write 80.0" in line


def test_a_value_out_of_range_on_the_command_line():
    line = refused("evaluator", "-p", "slice:=0")
    assert "slice := 0" in line and "expected an integer in 1..1000" in line


def test_a_controller_robot_index_of_the_wrong_type():
    line = refused("footbot_controller", "-p", "robot:=three")
    assert "robot := 'three'" in line and "expected an integer" in line


def test_an_unknown_parameter_on_the_command_line_names_the_nearest():
    line = refused("simulator", "-p", "wheel_sped:=60.0")
    assert "unknown parameter wheel_sped" in line and "did you mean wheel_speed?" in line


def test_an_unknown_parameter_of_a_controller_on_the_command_line():
    line = refused("footbot_controller", "-p", "tre:=forward")
    assert "unknown parameter tre" in line and "did you mean tree?" in line


def test_a_mistyped_value_in_a_second_file_is_not_dropped(tmp_path):
    # rcl keeps the first file's wheel_speed (a double) when the second's is a string, without a word
    mine = params_file(tmp_path, '/**:\n  ros__parameters:\n    wheel_speed: "fast"\n')
    line = refused("simulator", "--params-file", str(package_config("swarm_sim")), "--params-file", mine)
    assert mine in line and "wheel_speed" in line and "'fast'" in line and "floating-point" in line


def test_a_value_out_of_range_in_a_file(tmp_path):
    mine = params_file(tmp_path, "/**:\n  ros__parameters:\n    delivery_probability: 1.5\n")
    line = refused("simulator", "--params-file", mine)
    assert "delivery_probability" in line and "1.5" in line and "[0.0, 1.0]" in line


def test_an_unknown_key_in_a_wildcard_section_of_a_file(tmp_path):
    mine = params_file(tmp_path, "/**:\n  ros__parameters:\n    wheel_sped: 60.0\n")
    for node in ("simulator", "evaluator"):
        line = refused(node, "--params-file", mine)
        assert mine in line and "unknown parameter wheel_sped" in line and "did you mean wheel_speed?" in line


def test_a_section_for_one_node_holds_only_its_parameters(tmp_path):
    # slice is the evaluator's: a /** section may hold it for the evaluators, a simulator: section may not
    mine = params_file(tmp_path, "simulator:\n  ros__parameters:\n    slice: 5\n")
    line = refused("simulator", "--params-file", mine, namespace="/")
    assert "unknown parameter slice for node /simulator" in line
    mine = params_file(
        tmp_path, "/**/footbot_controller:\n  ros__parameters:\n    wheel_speed: 5.0\n", "c.yaml"
    )
    assert "unknown parameter wheel_speed" in refused("footbot_controller", "--params-file", mine)


def test_a_file_that_is_not_yaml_names_its_line(tmp_path):
    mine = params_file(tmp_path, "/**:\n  ros__parameters:\n    wheel_speed: [1.0,\n    n_robots: 9\n")
    for node in NODES:
        line = refused(node, "--params-file", mine)
        assert mine in line and "line " in line and "not valid YAML" in line


def test_a_file_of_another_shape_or_missing(tmp_path):
    mine = params_file(tmp_path, "wheel_speed: 60.0\n")
    assert "expected node names mapped to {ros__parameters" in refused("simulator", "--params-file", mine)
    missing = str(tmp_path / "missing.yaml")
    assert missing in refused("evaluator", "--params-file", missing)


def test_each_node_declares_the_names_the_others_leave_to_it():
    """A ``/**`` section may hold the other nodes' parameters (``shared``): the lists each node is given are
    what the others declare."""
    import dataclasses

    import rclpy

    from swarm_sim.model import FAULT_FIELDS, Config
    from swarm_sim.nodes.evaluator import EvaluatorNode
    from swarm_sim.nodes.settings import SIMULATOR_PARAMETERS, EvaluatorSettings
    from swarm_sim.nodes.simulator import SimulatorNode

    every_node = {"use_sim_time", "start_type_description_service"}
    world = {f.name for f in dataclasses.fields(Config)} - set(FAULT_FIELDS)  # faults: through conditions
    with reserved_domain() as domain:
        rclpy.init(domain_id=domain)
        try:
            simulator, evaluator = SimulatorNode(), EvaluatorNode()
            assert set(simulator._parameters) == world | SIMULATOR_PARAMETERS | every_node | {"autostart"}
            evaluator_own = {f.name for f in dataclasses.fields(EvaluatorSettings)}
            assert set(evaluator._parameters) == world | evaluator_own | every_node | {"autostart"}
            simulator.destroy_node()
            evaluator.destroy_node()
        finally:
            rclpy.shutdown()


def test_a_controller_commands_parameter_names_what_it_takes():
    line = refused("footbot_controller", "-p", "commands:=joystick")
    assert (
        line == "footbot_controller: parameter commands := 'joystick': expected one of wheels, cmd_vel, both"
    )


def test_the_timing_and_cmd_vel_type_parameters_name_what_they_take():
    assert refused("simulator", "-p", "timing:=fast", namespace="/") == (
        "simulator: parameter timing := 'fast': expected one of lockstep, free"
    )
    line = refused("simulator", "-p", "rate:=0.0", namespace="/")
    assert line.startswith("simulator: parameter rate := 0.0:"), line
    line = refused("footbot_controller", "-p", "cmd_vel_type:=Twist3")
    expected = "parameter cmd_vel_type := 'Twist3': expected one of TwistStamped, Twist"
    assert line == f"footbot_controller: {expected}"


def test_the_simulator_leaves_sensing_to_the_bridge_only_when_free_and_the_bridge_checks_its_link():
    assert refused("simulator", "-p", "sensing:=radio", namespace="/") == (
        "simulator: parameter sensing := 'radio': expected one of model, external"
    )
    assert refused("simulator", "-p", "sensing:=external", namespace="/") == (
        "simulator: parameter sensing := 'external' needs timing := 'free'"
    )
    line = refused("sensor_bridge", "-p", "loss:=1.5", namespace="/")
    assert line == "sensor_bridge: parameters loss and delay: loss must be a probability in [0, 1], got 1.5"


def test_a_controller_network_parameter_that_is_no_network_file(tmp_path):
    line = refused("footbot_controller", "-p", f"network:={tmp_path / 'missing.json'}")
    assert line.startswith("footbot_controller: the network parameter: ") and "cannot read" in line
    short = tmp_path / "short.json"
    short.write_text('{"weights": [1, 2]}')
    line = refused("footbot_controller", "-p", f"network:={short}")
    assert line.endswith(f"{short}: a network has 56 weights, got 2")
    line = refused("footbot_controller", "-p", f"network:={short}", "-p", "tree:=stop")
    assert "give one controller, not both" in line
    line = refused("footbot_controller", "-p", "tree:=nn(1, 2)")
    assert "a network has 56 weights, got 2" in line


def run_controllers(*arguments, until=None):
    """Start ``footbot_controllers ARGUMENTS`` in a domain of its own; return (exit status, output lines).
    With ``until`` (a number of lines of its log), send it SIGINT (Ctrl-C) the moment it has written that
    many."""
    command = [str(executable("bt_controller", "footbot_controllers")), *arguments]
    with reserved_domain() as domain:
        process = subprocess.Popen(
            command,
            env=domain_environment(domain),
            stdout=subprocess.PIPE,
            stderr=subprocess.STDOUT,
            text=True,
        )
        lines = []
        try:
            for line in process.stdout:
                lines.append(line.strip())
                if until is not None and len(lines) == until:
                    process.send_signal(signal.SIGINT)
            return process.wait(timeout=STARTED), lines
        finally:
            process.kill()
            process.wait()


def test_the_controllers_in_one_process_take_each_nodes_own_arguments_and_refuse_a_bad_one_by_its_node():
    def node(index, *ros_args):
        return ["--node", "--ros-args", "-r", f"__ns:=/swarm_a/footbot_{index}", *ros_args]

    # each node takes only its own parameters: robot 0's tree is not robot 1's
    # and a Ctrl-C just as they said so stops them cleanly (it once aborted the process in 1 of 5 tries)
    status, lines = run_controllers(*node(0, "-p", "tree:=forward"), *node(1), until=2)
    # (a node announcing just after the Ctrl-C shut the context down logs that it cannot reach /rosout)
    assert status == 0 and not any("Traceback" in line for line in lines), lines
    assert lines[0].endswith("ready: robot 0 in /swarm_a/footbot_0 with tree forward"), lines
    assert lines[1].endswith("ready: robot 1 in /swarm_a/footbot_1; waiting for load_tree"), lines
    # a bad parameter of the second node: one line naming that node's arguments, exit status 2
    status, lines = run_controllers(*node(0), *node(1, "-p", "tre:=forward"))
    assert status == 2 and len(lines) == 1, lines
    assert lines[0].startswith(
        "footbot_controllers: --ros-args -r __ns:=/swarm_a/footbot_1 -p tre:=forward: unknown parameter tre "
        "for node /swarm_a/footbot_1/footbot_controller: did you mean tree?"
    ), lines
    status, lines = run_controllers("--ros-args", "-r", "__ns:=/footbot_0")
    assert status == 2 and len(lines) == 1, lines
    assert lines[0].startswith("footbot_controllers: expected one '--node --ros-args ...' per controller"), (
        lines
    )
