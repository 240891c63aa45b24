"""Declared parameters from a dataclass: one per field, with its docstring, range and read-only flag, read
back into a new instance; parameter overrides (as from a --params-file) change the instance."""

from dataclasses import dataclass

import pytest
import rclpy
from rclpy.exceptions import InvalidParameterValueException
from rclpy.node import Node
from rclpy.parameter import Parameter

from swarm_ros.isolation import reserved_domain
from swarm_ros.parameters import attribute_docs, declare_dataclass


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
        with pytest.raises(InvalidParameterValueException):
            declare_dataclass(node, Settings(), ranges={"steps": (1, 8)})
    finally:
        node.destroy_node()
