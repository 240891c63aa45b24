"""Task files: a ``TaskSpec`` as YAML and back, every key checked with a one-line error.

``task_to_yaml`` writes every key, so that the file reproduces the task exactly (``task show NAME``);
``task_from_yaml`` reads such a file, where any key but ``name`` may be left out (it then takes the default
that ``docs/tasks.md`` gives). An unknown key is refused with the nearest known name.
"""

from __future__ import annotations

import dataclasses
import difflib
import math
import types
import typing
from pathlib import Path
from typing import Any

import yaml

from swarm_sim.tasks._spec import TaskError, TaskSpec


def task_to_mapping(task: TaskSpec) -> dict[str, Any]:
    """Every key of ``task`` as plain YAML/JSON values (tuples as lists), in declaration order."""
    return _plain(dataclasses.asdict(task))


def _plain(value: object) -> Any:
    if isinstance(value, dict):
        return {k: _plain(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [_plain(v) for v in value]
    return value


def task_to_yaml(task: TaskSpec) -> str:
    """``task`` as the YAML text of a task file that reproduces it."""
    return yaml.safe_dump(task_to_mapping(task), sort_keys=False, default_flow_style=None, width=100)


def task_from_mapping(data: object, where: str = "task") -> TaskSpec:
    """The task a mapping (a task file's content) says; ``TaskError`` with one line naming the key, the value
    and what was expected for anything else. ``where`` names the source in messages."""
    try:
        return _build(TaskSpec, data, "")
    except TaskError as error:
        raise TaskError(f"{where}: {error}") from None


def task_from_yaml(text: str, where: str = "task") -> TaskSpec:
    """The task of a task file's text (see ``task_from_mapping``)."""
    try:
        data = yaml.load(text, Loader=_UniqueKeyLoader)
    except TaskError as error:
        raise TaskError(f"{where}: {error}") from None
    except yaml.YAMLError as error:
        mark = getattr(error, "problem_mark", None)
        line = f" at line {mark.line + 1}" if mark is not None else ""
        problem = getattr(error, "problem", None) or str(error).splitlines()[0]
        raise TaskError(f"{where}: not YAML{line}: {problem}") from None
    return task_from_mapping(data, where)


def read_task_file(path: Path) -> TaskSpec:
    """The task of the file at ``path``; ``TaskError`` in one line when it cannot be read or is no task."""
    try:
        text = path.read_text(encoding="utf-8")
    except UnicodeDecodeError:
        raise TaskError(f"task file {path}: not UTF-8 text") from None
    except OSError as error:
        raise TaskError(f"task file {path}: cannot be read ({error.strerror or error})") from None
    return task_from_yaml(text, f"task file {path}")


class _UniqueKeyLoader(yaml.SafeLoader):
    """YAML's safe loader, refusing a mapping that repeats a key (which YAML would silently last-win)."""


def _unique_mapping(loader: yaml.SafeLoader, node: yaml.MappingNode, deep: bool = False) -> dict:
    seen: set[object] = set()
    for key_node, _ in node.value:
        key = loader.construct_object(key_node, deep=deep)
        if key in seen:
            raise TaskError(f"the key {key!r} appears twice (line {key_node.start_mark.line + 1})")
        seen.add(key)
    return loader.construct_mapping(node, deep=deep)


_UniqueKeyLoader.add_constructor(yaml.resolver.BaseResolver.DEFAULT_MAPPING_TAG, _unique_mapping)


def _build(cls: type, data: object, prefix: str) -> Any:
    """An instance of the dataclass ``cls`` from ``data``, every field checked against its type."""
    if not isinstance(data, dict):
        raise TaskError(f"{prefix.rstrip('.') or 'the task'} must be a mapping of keys, got {data!r}")
    hints = typing.get_type_hints(cls)
    fields = {f.name: f for f in dataclasses.fields(cls)}
    for key in data:
        if key not in fields:
            close = difflib.get_close_matches(str(key), list(fields), n=1)
            hint = (
                f" (did you mean {prefix}{close[0]}?)" if close else f"; expected among {', '.join(fields)}"
            )
            raise TaskError(f"unknown key {prefix}{key}{hint}")
    values: dict[str, Any] = {}
    for name, f in fields.items():
        if name in data:
            values[name] = _value(hints[name], data[name], prefix + name)
        elif f.default is dataclasses.MISSING and f.default_factory is dataclasses.MISSING:
            raise TaskError(f"{prefix}{name} is missing: every task needs one")
    return cls(**values)


def _value(hint: Any, value: object, key: str) -> Any:
    if isinstance(hint, type) and dataclasses.is_dataclass(hint):
        return _build(hint, value, key + ".")
    origin = typing.get_origin(hint)
    if origin is tuple:
        args = typing.get_args(hint)
        if not isinstance(value, list):
            raise TaskError(f"{key} must be a list, got {value!r}")
        if len(args) == 2 and args[1] is Ellipsis:
            inner = typing.get_args(args[0]) if typing.get_origin(args[0]) is tuple else (Ellipsis,)
            if Ellipsis not in inner and value and not isinstance(value[0], list):
                value = [value]  # one value for a list of them: the same in every entry ([x, y] for centres)
            return tuple(_value(args[0], v, f"{key}[{k}]") for k, v in enumerate(value))
        if len(value) != len(args):
            raise TaskError(f"{key} must be a list of {len(args)} values, got {value!r}")
        return tuple(_value(a, v, f"{key}[{k}]") for k, (a, v) in enumerate(zip(args, value, strict=True)))
    if origin in (typing.Union, types.UnionType):
        raise TaskError(f"{key}: unsupported type")  # no optional keys in a task file
    if hint is bool:
        if not isinstance(value, bool):
            raise TaskError(f"{key} must be true or false, got {value!r}")
        return value
    if hint is int:
        if isinstance(value, bool) or not isinstance(value, int):
            raise TaskError(f"{key} must be an integer, got {value!r}")
        return value
    if hint is float:
        if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
            raise TaskError(f"{key} must be a finite number, got {value!r}")
        return float(value)
    if hint is str:
        if not isinstance(value, str):
            raise TaskError(f"{key} must be text, got {value!r}")
        return value
    raise TaskError(f"{key}: unsupported type {hint!r}")  # a field type this loader does not know
