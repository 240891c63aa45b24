"""Declared parameters from a dataclass: one per field, with its docstring, range and read-only flag, read
back into a new instance; parameter overrides (as from a --params-file) change the instance. A value of the
wrong type or out of range, a parameter the node does not declare, and a parameter file that is not YAML are
refused in one line (``ParameterError``), including a file's value that rcl would drop without a word."""

import subprocess
import sys
from dataclasses import dataclass
from pathlib import Path

import pytest
import rclpy
from rclpy.node import Node
from rclpy.parameter import Parameter

from swarm_ros.isolation import domain_environment, reserved_domain
from swarm_ros.parameters import (
    ANY,
    ParameterError,
    attribute_docs,
    check_overrides,
    declare_dataclass,
    parameter_files,
    read_parameter_file,
)


@dataclass(frozen=True)
class Settings:
    """A toy of a node's settings."""

    speed: float = 50.0
    """Nominal speed (mm/s)."""
    steps: int = 4
    """Steps per tick."""
    gaps: tuple[float, ...] = (500.0, 700.0)
    """Gaps, one per arena."""
    name: str = "paper"


@pytest.fixture
def context():
    with reserved_domain() as domain:
        context = rclpy.Context()
        rclpy.init(context=context, domain_id=domain)
        try:
            yield context
        finally:
            rclpy.shutdown(context=context)


def test_attribute_docs_are_the_field_docstrings():
    assert attribute_docs(Settings) == {
        "speed": "Nominal speed (mm/s).",
        "steps": "Steps per tick.",
        "gaps": "Gaps, one per arena.",
    }


def test_every_field_becomes_a_described_read_only_parameter(context):
    node = Node("parameters_test", context=context, start_parameter_services=False)
    try:
        settings = declare_dataclass(node, Settings(), ranges={"steps": (1, 8)})
        assert settings == Settings()
        (speed, steps, name) = node.describe_parameters(["speed", "steps", "name"])
        assert speed.description == "Nominal speed (mm/s)." and speed.read_only
        assert (steps.integer_range[0].from_value, steps.integer_range[0].to_value) == (1, 8)
        assert name.description == "name"
        assert node.get_parameter("gaps").type_ == Parameter.Type.DOUBLE_ARRAY
        result = node.set_parameters([Parameter("speed", value=60.0)])[0]
        assert not result.successful and "read-only" in result.reason
    finally:
        node.destroy_node()


def test_overrides_change_the_instance_and_ranges_are_enforced(context):
    overrides = [Parameter("speed", value=80.0), Parameter("gaps", value=[600.0])]
    node = Node(
        "parameters_test", context=context, parameter_overrides=overrides, start_parameter_services=False
    )
    try:
        assert declare_dataclass(node, Settings()) == Settings(speed=80.0, gaps=(600.0,))
    finally:
        node.destroy_node()
    node = Node(
        "parameters_test",
        context=context,
        parameter_overrides=[Parameter("steps", value=9)],
        start_parameter_services=False,
    )
    try:
        with pytest.raises(ParameterError, match=r"^parameter steps := 9: expected an integer in 1..8"):
            declare_dataclass(node, Settings(), ranges={"steps": (1, 8)})
    finally:
        node.destroy_node()


@pytest.mark.parametrize(
    ("given", "problem"),
    [
        (Parameter("speed", value="fast"), "parameter speed := 'fast': expected a floating-point number"),
        (Parameter("speed", value=80), "parameter speed := 80: expected a floating-point number (write 80.0"),
        (Parameter("steps", value=2.5), "parameter steps := 2.5: expected an integer (default 4)"),
        (
            Parameter("gaps", value=["a"]),
            "parameter gaps := ['a']: expected a list of floating-point numbers",
        ),
        (Parameter("name", value=True), "parameter name := true: expected a string (default 'paper')"),
    ],
)
def test_a_value_of_the_wrong_type_is_one_line_naming_it(context, given, problem):
    node = Node(
        "parameters_test", context=context, parameter_overrides=[given], start_parameter_services=False
    )
    try:
        with pytest.raises(ParameterError) as refused:
            declare_dataclass(node, Settings())
        assert str(refused.value).startswith(problem) and "\n" not in str(refused.value)
    finally:
        node.destroy_node()


# --- parameter files ---------------------------------------------------------------------------------------
def write(tmp_path: Path, text: str, name: str = "p.yaml") -> Path:
    path = tmp_path / name
    path.write_text(text)
    return path


def test_the_parameter_files_of_the_ros_arguments():
    args = ["prog", "--params-file", "not_ros.yaml", "--ros-args", "-p", "a:=1", "--params-file", "a.yaml"]
    assert parameter_files(
        [*args, "--", "--params-file", "x.yaml", "--ros-args", "--params-file", "b.yaml"]
    ) == [
        Path("a.yaml"),
        Path("b.yaml"),
    ]


def test_sections_name_nodes_as_rcl_does(tmp_path):
    path = write(
        tmp_path,
        "/**:\n  ros__parameters: {a: 1}\n"
        "/**/simulator:\n  ros__parameters: {b: {c: 2.0}}\n"
        "simulator:\n  ros__parameters: {d: x}\n"
        "/swarm_a/*:\n  ros__parameters: {e: [1, 2]}\n"
        "swarm_b:\n  simulator:\n    ros__parameters: {f: true}\n",
    )
    sections = read_parameter_file(path)
    assert [(s.node, s.parameters) for s in sections] == [
        ("/**", {"a": 1}),
        ("/**/simulator", {"b.c": 2.0}),
        ("/simulator", {"d": "x"}),
        ("/swarm_a/*", {"e": [1, 2]}),
        ("/swarm_b/simulator", {"f": True}),
    ]
    names = {s.node: s for s in sections}
    assert all(names["/**"].names(n) for n in ("/simulator", "/swarm_a/footbot_3/footbot_controller"))
    assert names["/**/simulator"].names("/simulator") and names["/**/simulator"].names("/swarm_a/simulator")
    assert not names["/**/simulator"].names("/evaluator")
    assert names["/simulator"].names("/simulator") and not names["/simulator"].names("/swarm_a/simulator")
    assert names["/swarm_a/*"].names("/swarm_a/simulator") and not names["/swarm_a/*"].names(
        "/swarm_b/simulator"
    )
    assert [s.wildcard for s in sections] == [True, False, False, True, False]


@pytest.mark.parametrize(
    ("text", "problem"),
    [
        ("/**:\n  ros__parameters:\n    a: [1.0,\n    b: 2\n", "line 5: not valid YAML: expected ',' or ']'"),
        ("/**:\n  ros__parameters:\n    a: 1\n   b: 2\n", "line 4: not valid YAML"),
        ("a: 1\n", "expected node names mapped to {ros__parameters"),
        ("/**:\n  ros__parameters: 3\n", "ros__parameters of /** is not a mapping"),
        ("", "expected node names mapped to"),
    ],
)
def test_a_file_that_is_not_a_parameter_file_is_one_line(tmp_path, text, problem):
    path = write(tmp_path, text)
    with pytest.raises(ParameterError) as refused:
        read_parameter_file(path)
    assert str(path) in str(refused.value) and problem in str(refused.value)
    with pytest.raises(ParameterError, match="cannot read the parameter file"):
        read_parameter_file(tmp_path / "missing.yaml")


def declared_node(context, overrides=()):
    node = Node(
        "simulator", context=context, parameter_overrides=list(overrides), start_parameter_services=False
    )
    declare_dataclass(node, Settings())
    return node


def test_a_mistyped_value_that_an_earlier_file_hid_from_rcl_is_refused(context, tmp_path):
    # rcl keeps the first file's speed (80.0): the node would run with it, the second file's "fast" unheard of
    first = write(tmp_path, "/**:\n  ros__parameters: {speed: 80.0}\n", "first.yaml")
    second = write(tmp_path, "/**:\n  ros__parameters: {speed: fast}\n", "second.yaml")
    node = declared_node(context, [Parameter("speed", value=80.0)])
    try:
        check_overrides(node, [first])
        with pytest.raises(ParameterError) as refused:
            check_overrides(node, [first, second])
        assert str(refused.value) == f"{second}: parameter speed: 'fast': expected a floating-point number"
    finally:
        node.destroy_node()


def test_a_value_out_of_range_in_a_file(context, tmp_path):
    node = Node("simulator", context=context, start_parameter_services=False)
    try:
        declare_dataclass(node, Settings(), ranges={"steps": (1, 8), "speed": (0.0, 100.0)})
        for text, problem in (("steps: 9", "expected an integer in 1..8"), ("speed: -1.0", "[0.0, 100.0]")):
            path = write(tmp_path, f"/**:\n  ros__parameters: {{{text}}}\n")
            with pytest.raises(ParameterError, match=problem.replace("[", r"\[").replace(".", r"\.")):
                check_overrides(node, [path])
    finally:
        node.destroy_node()


def test_unknown_names_are_refused_but_a_shared_file_may_hold_other_nodes_names(context, tmp_path):
    wildcard = write(tmp_path, "/**:\n  ros__parameters: {speed: 50.0, slice: 5}\n", "shared.yaml")
    own = write(tmp_path, "simulator:\n  ros__parameters: {slice: 5}\n", "own.yaml")
    other = write(tmp_path, "evaluator:\n  ros__parameters: {slice: 5}\n", "other.yaml")
    overrides = [Parameter("slice", value=5)]
    node = declared_node(context, overrides)
    try:
        with pytest.raises(ParameterError) as refused:
            check_overrides(node, [wildcard])
        assert str(refused.value) == f"{wildcard}: unknown parameter slice for node /simulator: it takes " + (
            "gaps, name, speed, start_type_description_service, steps, use_sim_time"
        )
        check_overrides(node, [wildcard], shared={"slice"})  # the evaluators' parameter, left to them
        check_overrides(node, [wildcard], shared=ANY)
        with pytest.raises(ParameterError, match="unknown parameter slice for node /simulator"):
            check_overrides(node, [own], shared=ANY)  # a section for this node holds only its parameters
        check_overrides(node, [other, wildcard], shared={"slice"})  # a section for another node is not read
    finally:
        node.destroy_node()
    node = declared_node(context, [Parameter("sped", value=1.0)])
    try:
        with pytest.raises(ParameterError) as refused:
            check_overrides(node, [wildcard], shared={"slice"})
        assert (
            str(refused.value)
            == "unknown parameter sped for node /simulator: did you mean speed? (given with -p)"
        )
    finally:
        node.destroy_node()


def test_a_node_started_with_a_bad_parameter_prints_one_line_and_exits_2(tmp_path):
    program = (
        "from dataclasses import dataclass\n"
        "from rclpy.node import Node\n"
        "from swarm_ros.parameters import declare_dataclass, start_node\n"
        "@dataclass(frozen=True)\n"
        "class S:\n"
        "    speed: float = 50.0\n"
        "def make():\n"
        "    node = Node('toy')\n"
        "    declare_dataclass(node, S())\n"
        "    return node\n"
        "start_node('toy', make)\n"
        "print('started')\n"
    )
    bad_yaml = write(tmp_path, "/**:\n  ros__parameters: {speed: [1.0,\n", "bad.yaml")
    cases = {
        (
            "-p",
            "speed:=fast",
        ): "toy: parameter speed := 'fast': expected a floating-point number (default 50.0)",
        ("-p", "sped:=1.0"): "toy: unknown parameter sped for node /toy: did you mean speed? (given with -p)",
        ("--params-file", str(bad_yaml)): f"toy: parameter file {bad_yaml} line 3: not valid YAML",
    }
    with reserved_domain() as domain:
        for args, line in cases.items():
            done = subprocess.run(
                [sys.executable, "-c", program, "--ros-args", *args],
                env=domain_environment(domain),
                capture_output=True,
                text=True,
                timeout=120,
            )
            assert (done.returncode, done.stdout) == (2, ""), done.stderr
            assert done.stderr.startswith(line) and done.stderr.count("\n") == 1, done.stderr
        done = subprocess.run(
            [sys.executable, "-c", program, "--ros-args", "-p", "speed:=60.0"],
            env=domain_environment(domain),
            capture_output=True,
            text=True,
            timeout=120,
        )
        assert (done.returncode, done.stdout) == (0, "started\n"), done.stderr
