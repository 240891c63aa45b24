"""Declared ROS parameters from a frozen dataclass, and the one start-up of every node that refuses a bad one.

A node declares its settings with :func:`declare_dataclass` (one parameter per field, its default the
dataclass's, its description the field's docstring, with ranges and read-only flags) and gets back the
validated object its core uses, so the parameters (``ros2 param list/describe``, a ``--params-file``) and the
core's configuration never disagree. A field holding a tuple of numbers becomes a double array.

Every node executable starts its node with :func:`start_node` (several nodes in one process:
:func:`start_nodes`): a value of the wrong type or out of range,
or a parameter the node does not declare, whether from ``-p NAME:=VALUE`` or from a ``--params-file``, stops
it with one line naming the parameter, the value and what was expected, and exit status 2 (a parameter file
that is not YAML: one line naming the file and the line). rclpy alone would raise a traceback for a wrong
type given with ``-p``, accept an unknown name, and silently keep the first of two files' values for a
parameter when the second file's has another type; so the files are read here too (:func:`check_overrides`).
"""

from __future__ import annotations

import ast
import dataclasses
import difflib
import inspect
import re
import signal
import sys
import textwrap
from collections.abc import Callable, Collection, Mapping, Sequence
from itertools import pairwise
from pathlib import Path
from typing import TYPE_CHECKING, Any, NoReturn, TypeVar

import rclpy
import yaml
from rcl_interfaces.msg import FloatingPointRange, IntegerRange, ParameterDescriptor
from rclpy.exceptions import ParameterException
from rclpy.impl.implementation_singleton import rclpy_implementation
from rclpy.node import Node
from rclpy.parameter import Parameter

if TYPE_CHECKING:  # typeshed's name for "an instance of any dataclass" (no runtime counterpart)
    from _typeshed import DataclassInstance

T = TypeVar("T", bound="DataclassInstance")
N = TypeVar("N", bound=Node)

EXIT_BAD_PARAMETER = 2
"""The exit status of a node stopped by a bad parameter (as every command of the workspace for bad input)."""

ANY = None
"""``shared`` for a node that leaves every name of a wildcard section it does not declare to the other nodes
(see :func:`check_overrides`)."""


class ParameterError(ValueError):
    """A parameter the node cannot take; the message is the one line a user sees (the parameter, the value and
    what was expected, or the file and line that could not be read)."""


_EXPECTED = {
    Parameter.Type.BOOL: "true or false",
    Parameter.Type.INTEGER: "an integer",
    Parameter.Type.DOUBLE: "a floating-point number",
    Parameter.Type.STRING: "a string",
    Parameter.Type.BYTE_ARRAY: "a list of bytes",
    Parameter.Type.BOOL_ARRAY: "a list of true/false",
    Parameter.Type.INTEGER_ARRAY: "a list of integers",
    Parameter.Type.DOUBLE_ARRAY: "a list of floating-point numbers",
    Parameter.Type.STRING_ARRAY: "a list of strings",
}


def value_problem(value: object, descriptor: ParameterDescriptor) -> str:
    """What ``value`` should have been for a parameter declared with ``descriptor`` (whose type is set), or
    "" when the parameter takes it. An integer is no floating-point number (rclpy refuses ``80`` for a
    double)."""
    expected = Parameter.Type(descriptor.type)
    try:
        kind = Parameter.Type.from_parameter_value(value)  # type: ignore[arg-type]  # any YAML value is tried
    except TypeError:
        kind = None
    empty_list = isinstance(value, list) and not value and expected.name.endswith("_ARRAY")
    if kind != expected and not empty_list:
        hint = (
            " (write 80.0, not 80)"
            if expected is Parameter.Type.DOUBLE and kind is Parameter.Type.INTEGER
            else ""
        )
        return f"expected {_EXPECTED.get(expected, expected.name.lower())}{hint}"
    for integers in descriptor.integer_range:
        if not integers.from_value <= value <= integers.to_value:
            return f"expected an integer in {integers.from_value}..{integers.to_value}"
    for numbers in descriptor.floating_point_range:
        if not numbers.from_value <= value <= numbers.to_value:
            return f"expected a number in [{numbers.from_value}, {numbers.to_value}]"
    return ""


def _shown(value: object) -> str:
    return (
        repr(value)
        if isinstance(value, str)
        else str(value).replace("True", "true").replace("False", "false")
    )


def declare(node: Node, name: str, default: Any, descriptor: ParameterDescriptor) -> Any:
    """Declare the parameter ``name`` (its type that of ``default``) and return its value; a value given to
    the node (``-p``, a parameter file) of the wrong type or out of range raises ``ParameterError``."""
    descriptor.type = Parameter.Type.from_parameter_value(default).value
    given = node._parameter_overrides.get(name)  # rclpy keeps no public view of the values given to a node
    if given is not None:
        problem = value_problem(given.value, descriptor)
        if problem:
            raise ParameterError(
                f"parameter {name} := {_shown(given.value)}: {problem} (default {_shown(default)})"
            )
    try:
        return node.declare_parameter(name, default, descriptor).value
    except ParameterException as error:  # a check of rclpy's beyond those above
        raise ParameterError(f"parameter {name}: {error}") from None


def attribute_docs(cls: type) -> dict[str, str]:
    """Each field's docstring (the string literal under its annotation in the class body), by field name."""
    try:
        tree = ast.parse(textwrap.dedent(inspect.getsource(cls)))
    except (OSError, TypeError):  # no source (a frozen executable): descriptions stay empty
        return {}
    docs: dict[str, str] = {}
    if not tree.body or not isinstance(tree.body[0], ast.ClassDef):
        return docs
    for statement, following in pairwise(tree.body[0].body):
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
    skip: Collection[str] = (),
) -> T:
    """Declare one parameter per field of the dataclass instance ``defaults`` (named ``prefix + field``),
    but those in ``skip`` (the caller declares them its own way), and return a new instance built from the
    parameters' values (which validates them)."""
    docs = attribute_docs(type(defaults))
    ranges = ranges or {}
    values: dict[str, Any] = {}
    for field in dataclasses.fields(defaults):
        if field.name in skip:
            continue
        default = getattr(defaults, field.name)
        is_tuple = isinstance(default, tuple)
        integer = isinstance(default, int) and not isinstance(default, bool)
        value = declare(
            node,
            prefix + field.name,
            list(default) if is_tuple else default,
            descriptor(
                docs.get(field.name, field.name.replace("_", " ")),
                read_only=read_only,
                value_range=ranges.get(field.name),
                integer=integer,
            ),
        )
        values[field.name] = tuple(value) if is_tuple else value
    return dataclasses.replace(defaults, **values)


def field_names(cls: type) -> frozenset[str]:
    """The parameter names a dataclass of settings declares (one per field)."""
    return frozenset(f.name for f in dataclasses.fields(cls))


# --- parameter files ---------------------------------------------------------------------------------------
def parameter_files(args: Sequence[str]) -> list[Path]:
    """The ``--params-file FILE`` arguments among the ROS arguments of ``args`` (after ``--ros-args``, up to
    ``--``), in order."""
    files: list[Path] = []
    in_ros = False
    for i, arg in enumerate(args):
        if arg == "--ros-args":
            in_ros = True
        elif arg == "--":
            in_ros = False
        elif in_ros and arg == "--params-file" and i + 1 < len(args):
            files.append(Path(args[i + 1]))
    return files


@dataclasses.dataclass(frozen=True)
class FileSection:
    """The parameters one section of a parameter file gives the nodes its key names."""

    path: Path
    node: str
    """The section's node name, absolute, as written (wildcards ``*`` and ``**`` included)."""
    parameters: dict[str, object]
    """Parameter name (nested keys joined with '.') -> value."""

    @property
    def wildcard(self) -> bool:
        """Whether the section is for nodes of any name (``/**``, ``/swarm_a/*``), rather than for the nodes
        of one name (``simulator``, ``/**/simulator``)."""
        return "*" in self.node.rsplit("/", 1)[-1]

    def names(self, fully_qualified_name: str) -> bool:
        """Whether the section applies to the node ``fully_qualified_name`` (``/ns/name``), as rcl decides:
        ``*`` stands for one name token, ``/**`` for any number of them."""
        pattern = ""
        for token in self.node.strip("/").split("/"):
            if token == "**":
                pattern += "(/[^/]+)*"
            else:
                pattern += "/" + re.escape(token).replace(r"\*", "[^/]*")
        return re.fullmatch(pattern, fully_qualified_name) is not None


def _flatten(values: dict, prefix: str = "") -> dict[str, object]:
    flat: dict[str, object] = {}
    for key, value in values.items():
        name = f"{prefix}{key}"
        if isinstance(value, dict):
            flat.update(_flatten(value, name + "."))
        else:
            flat[name] = value
    return flat


def read_parameter_file(path: Path) -> list[FileSection]:
    """The sections of the ROS parameter file ``path``; ``ParameterError`` (one line naming the file and the
    line) for a file that cannot be read, is not YAML, or is not shaped as
    ``NODE: {ros__parameters: {...}}``."""
    try:
        text = path.read_text()
    except (OSError, UnicodeDecodeError) as error:
        raise ParameterError(f"cannot read the parameter file {path}: {error}") from None
    try:
        document = yaml.safe_load(text)
    except yaml.YAMLError as error:
        mark = getattr(error, "problem_mark", None)
        where = f" line {mark.line + 1}" if mark is not None else ""
        problem = getattr(error, "problem", None) or str(error).splitlines()[0]
        raise ParameterError(f"parameter file {path}{where}: not valid YAML: {problem}") from None
    sections: list[FileSection] = []

    def walk(values: object, node: str) -> None:
        if not isinstance(values, dict) or not values:
            raise ParameterError(
                f"parameter file {path}: {node or 'the file'} holds {_shown(values)}; expected node names "
                "mapped to {ros__parameters: {NAME: VALUE}} "
                "(e.g. /**: {ros__parameters: {wheel_speed: 50.0}})"
            )
        for key, value in values.items():
            if key == "ros__parameters":
                if not isinstance(value, dict):
                    raise ParameterError(f"parameter file {path}: ros__parameters of {node} is not a mapping")
                sections.append(FileSection(path, node or "/", _flatten(value)))
            else:
                walk(value, f"{node}/{str(key).strip('/')}")

    walk(document, "")
    return sections


def check_overrides(node: Node, files: Sequence[Path], shared: Collection[str] | None = frozenset()) -> None:
    """Refuse, with ``ParameterError``, what the declarations alone let through: a value in a parameter file
    that another file's value of another type hid from rcl, a value of the wrong type or out of range in any
    file section for this node, and a parameter the node does not declare.

    A section for nodes of this node's name (``simulator``, ``/**/simulator``) must hold only its parameters.
    A section for nodes of any name (``/**``), which every node of a graph reads, may also hold the names in
    ``shared`` (parameters of the workspace's other nodes, which this node leaves to them); ``shared=ANY``:
    any name (a node that cannot know the others').
    A name given with ``-p`` that the node does not declare is refused."""
    fqn = node.get_fully_qualified_name()
    in_files: set[str] = set()
    for path in files:
        for section in read_parameter_file(path):
            if not section.names(fqn):
                continue
            for name, value in section.parameters.items():
                in_files.add(name)
                if node.has_parameter(name):
                    problem = value_problem(value, node.describe_parameter(name))
                    if problem:
                        raise ParameterError(f"{path}: parameter {name}: {_shown(value)}: {problem}")
                elif not (section.wildcard and (shared is ANY or name in shared)):
                    raise ParameterError(f"{path}: {unknown(node, name)}")
    for name in node._parameter_overrides:  # rclpy keeps no public view of the values given to a node
        if not node.has_parameter(name) and name not in in_files:
            raise ParameterError(unknown(node, name) + " (given with -p)")


def check_file_values(
    path: Path,
    fully_qualified_name: str,
    declared: Mapping[str, tuple[Any, tuple[float, float] | None]],
    shared: Collection[str] = frozenset(),
) -> dict[str, object]:
    """Check, without starting a node, what the parameter file ``path`` gives the node
    ``fully_qualified_name`` that declares ``declared`` (name -> default and closed range, as
    :func:`declare_dataclass` declares them): ``ParameterError`` for a value of the wrong type or out of
    range, or for a name the node does not declare (in a ``/**`` section, one of ``shared`` is left to the
    graph's other nodes); the values the file gives the node's declared parameters, by name."""
    given: dict[str, object] = {}
    for section in read_parameter_file(path):
        if not section.names(fully_qualified_name):
            continue
        for name, value in section.parameters.items():
            if name in declared:
                default, value_range = declared[name]
                default = list(default) if isinstance(default, tuple) else default
                integer = isinstance(default, int) and not isinstance(default, bool)
                expected = descriptor(name, read_only=True, value_range=value_range, integer=integer)
                expected.type = Parameter.Type.from_parameter_value(default).value
                problem = value_problem(value, expected)
                if problem:
                    raise ParameterError(f"{path}: parameter {name}: {_shown(value)}: {problem}")
                given[name] = value
            elif not (section.wildcard and name in shared):
                near = difflib.get_close_matches(name, sorted(declared), n=1)
                hint = f"did you mean {near[0]}?" if near else f"it takes {', '.join(sorted(declared))}"
                raise ParameterError(
                    f"{path}: unknown parameter {name} for node {fully_qualified_name}: {hint}"
                )
    return given


def unknown(node: Node, name: str) -> str:
    """The line for a parameter ``name`` that ``node`` does not declare, with the nearest names it does."""
    declared = sorted(node._parameters)  # rclpy keeps no public list of the declared names
    near = difflib.get_close_matches(name, declared, n=1)
    hint = f"did you mean {near[0]}?" if near else f"it takes {', '.join(declared)}"
    return f"unknown parameter {name} for node {node.get_fully_qualified_name()}: {hint}"


def start_node(
    program: str,
    make: Callable[[], N],
    args: Sequence[str] | None = None,
    *,
    shared: Collection[str] | None = frozenset(),
    errors: tuple[type[Exception], ...] = (),
) -> N:
    """Initialise rclpy with ``args`` (the command line when None) and return the node ``make()`` builds, its
    parameters checked (:func:`check_overrides` with ``shared``). A bad parameter, a parameter file that
    cannot be read, or one of ``errors`` raised by ``make`` (the node's own checks of its settings) prints
    one line ``PROGRAM: ...`` and exits with status 2."""
    argv = list(sys.argv if args is None else args)
    node: N | None = None
    try:
        check_files_read(argv)
        try:
            init_rclpy(argv)
        except rclpy_implementation.RCLError as error:  # a file PyYAML reads but rcl does not
            raise ParameterError(rcl_problem(error)) from None
        node = make()
        check_overrides(node, parameter_files(argv), shared)
    except (ParameterError, *errors) as error:  # type: ignore[misc]  # a tuple of exception classes, unpacked
        refuse(f"{program}: {error}", [] if node is None else [node])
    return node


def start_nodes(
    program: str,
    make: Callable[..., N],
    node_args: Sequence[Sequence[str]],
    *,
    shared: Collection[str] | None = frozenset(),
    errors: tuple[type[Exception], ...] = (),
) -> list[N]:
    """Several nodes in one process (as a ROS 2 component container holds them): initialise rclpy without
    arguments and return one node per entry of ``node_args``, built by ``make(cli_args=ARGS,
    use_global_arguments=False)`` from the ROS arguments (``--ros-args ...``) it would have had as a process
    of its own, and checked as :func:`start_node` checks them. A problem with any of them prints one line
    ``PROGRAM: NODE ARGUMENTS: ...`` and exits with status 2, the nodes built so far destroyed."""
    nodes: list[N] = []
    init_rclpy([])
    current: Sequence[str] = ()
    try:
        for current in node_args:
            check_files_read(current)
            try:
                node = make(cli_args=list(current), use_global_arguments=False)
            except rclpy_implementation.RCLError as error:  # a file PyYAML reads but rcl does not
                raise ParameterError(rcl_problem(error)) from None
            nodes.append(node)
            check_overrides(node, parameter_files(current), shared)
    except (ParameterError, *errors) as error:  # type: ignore[misc]  # a tuple of exception classes, unpacked
        refuse(f"{program}: {' '.join(current)}: {error}", nodes)
    return nodes


def refuse(line: str, built: Sequence[Node]) -> NoReturn:
    """A node start-up's end on a bad parameter: print ``line``, destroy the nodes ``built`` so far, shut
    rclpy down and exit with status 2."""
    print(line, file=sys.stderr)
    for node in built:
        node.destroy_node()
    rclpy.try_shutdown()
    raise SystemExit(EXIT_BAD_PARAMETER) from None


def init_rclpy(args: Sequence[str]) -> None:
    """``rclpy.init(args=args)``, with Ctrl-C a request to stop: rclpy's signal handler shuts the context
    down (which ends ``spinning.spin_until_shutdown``) and then calls the handler it found, here one that
    does nothing. Python's own would raise ``KeyboardInterrupt`` wherever the main thread is, inside the
    events executor's C++ too: a Ctrl-C just as a controller said it was ready aborted its process
    ("Destroying callback manager with callbacks remaining") in 5 of 25 tries."""
    signal.signal(signal.SIGINT, _stop_requested)
    rclpy.init(args=list(args))


def _stop_requested(signum: int, frame: object) -> None:
    """Python's part of a Ctrl-C once rclpy is up: nothing (rclpy's handler shut the context down)."""


def check_files_read(args: Sequence[str]) -> None:
    """Read every ``--params-file`` of ``args`` (``ParameterError`` for one that cannot be): before rcl, whose
    message names neither the file's line nor the problem plainly."""
    for path in parameter_files(args):
        read_parameter_file(path)


def rcl_problem(error: Exception) -> str:
    """rcl's message for arguments it refused, without its source locations and prefix."""
    return re.sub(r",? at /\S+:\d+", "", str(error)).replace("failed to initialize rcl: ", "")
