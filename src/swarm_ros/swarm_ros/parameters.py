"""Declared ROS parameters from a frozen dataclass: one parameter per field, its default the dataclass's,
its description the field's docstring, with ranges and read-only flags; read once into a new instance.

A node declares its settings with :func:`declare_dataclass` and gets back the validated object its core
uses, so the parameters (``ros2 param list/describe``, a ``--params-file``) and the core's configuration
never disagree. A field holding a tuple of numbers becomes a double array.
"""

from __future__ import annotations

import ast
import dataclasses
import inspect
import textwrap
from collections.abc import Mapping
from itertools import pairwise
from typing import Any, TypeVar

from rcl_interfaces.msg import FloatingPointRange, IntegerRange, ParameterDescriptor
from rclpy.node import Node

T = TypeVar("T")


def attribute_docs(cls: type) -> dict[str, str]:
    """Each field's docstring (the string literal under its annotation in the class body), by field name."""
    try:
        tree = ast.parse(textwrap.dedent(inspect.getsource(cls)))
    except (OSError, TypeError):  # no source (a frozen executable): descriptions stay empty
        return {}
    docs: dict[str, str] = {}
    body = tree.body[0].body  # type: ignore[attr-defined]
    for statement, following in pairwise(body):
        if (
            isinstance(statement, ast.AnnAssign)
            and isinstance(statement.target, ast.Name)
            and isinstance(following, ast.Expr)
            and isinstance(following.value, ast.Constant)
            and isinstance(following.value.value, str)
        ):
            docs[statement.target.id] = " ".join(following.value.value.split())
    return docs


def descriptor(
    description: str,
    *,
    read_only: bool,
    value_range: tuple[float, float] | None = None,
    integer: bool = False,
) -> ParameterDescriptor:
    """A parameter descriptor: description, read-only flag and an optional closed range."""
    out = ParameterDescriptor(description=description, read_only=read_only)
    if value_range is not None:
        low, high = value_range
        if integer:
            out.integer_range = [IntegerRange(from_value=int(low), to_value=int(high), step=1)]
        else:
            out.floating_point_range = [FloatingPointRange(from_value=float(low), to_value=float(high))]
    return out


def declare_dataclass(
    node: Node,
    defaults: T,
    *,
    read_only: bool = True,
    ranges: Mapping[str, tuple[float, float]] | None = None,
    prefix: str = "",
) -> T:
    """Declare one parameter per field of the dataclass instance ``defaults`` (named ``prefix + field``)
    and return a new instance built from the parameters' values (which validates them)."""
    docs = attribute_docs(type(defaults))
    ranges = ranges or {}
    values: dict[str, Any] = {}
    for field in dataclasses.fields(defaults):  # type: ignore[arg-type]
        default = getattr(defaults, field.name)
        is_tuple = isinstance(default, tuple)
        integer = isinstance(default, int) and not isinstance(default, bool)
        value = node.declare_parameter(
            prefix + field.name,
            list(default) if is_tuple else default,
            descriptor(
                docs.get(field.name, field.name.replace("_", " ")),
                read_only=read_only,
                value_range=ranges.get(field.name),
                integer=integer,
            ),
        ).value
        values[field.name] = tuple(value) if is_tuple else value
    return dataclasses.replace(defaults, **values)  # type: ignore[type-var]
