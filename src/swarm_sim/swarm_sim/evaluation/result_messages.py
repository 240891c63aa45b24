"""The one conversion between the world's results and the graph's messages, written once for every node,
the recorder and the bags.

Nothing here imports ROS: a message is filled from (and read into) plain field values, so the same functions
serve rclpy's message classes (``EvaluationResult(**result_fields(...))``), rosbags' (``bag.message(type,
**result_fields(...))``) and any object with the fields. Fields follow ``swarm_msgs``: ``EvaluationResult``,
the ``RunTrial`` action's result and service response (``success``, ``message``, ``gap``, ``names`` and
``values``: every value of ``VALUE_NAMES`` by name, ``start_poses``, ``end_poses``) and ``RobotPose`` (``x``,
``y`` in mm, ``theta`` in rad). Messages recorded before names and values held a field per value; they are
read all the same (``named_values``).
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from typing import Any, Protocol

import numpy as np

from swarm_sim.core import TrialRecord
from swarm_sim.evaluation.batch import EvaluationResult, failed
from swarm_sim.model import N_OBJECTIVES, OBJECTIVES, VALUE_NAMES

__all__ = ["evaluation_fields", "named_values", "result_fields", "trial_fields", "values_of"]


class ResultValues(Protocol):
    """What a result of the evaluator contract holds (``EvaluationResult``, a run's ``Outcome``)."""

    @property
    def fitness(self) -> tuple[float, ...] | None: ...
    @property
    def descriptors(self) -> tuple[float, ...] | None: ...
    @property
    def error(self) -> str | None: ...


class PoseMessage(Protocol):
    """The fields read from a ``swarm_msgs/msg/RobotPose``."""

    @property
    def x(self) -> float: ...
    @property
    def y(self) -> float: ...
    @property
    def theta(self) -> float: ...


class EvaluationMessage(Protocol):
    """The fields read from a ``swarm_msgs/msg/EvaluationResult`` besides the six values."""

    @property
    def ok(self) -> bool: ...
    @property
    def error(self) -> str: ...


class TrialMessage(Protocol):
    """The fields read from a ``RunTrial`` result or response besides the six values."""

    @property
    def gap(self) -> float: ...
    @property
    def start_poses(self) -> Sequence[PoseMessage]: ...
    @property
    def end_poses(self) -> Sequence[PoseMessage]: ...


def result_fields(
    tree: str,
    seed: int,
    trials: int,
    values: Sequence[float] | None,
    objective: str,
    error: str = "",
    *,
    profile: str,
    cached: bool = False,
) -> dict[str, Any]:
    """The fields of a ``swarm_msgs/msg/EvaluationResult``: ``values`` (``VALUE_NAMES`` order) or
    None with ``error`` saying why the tree could not be evaluated; ``fitness`` is the ``objective``'s
    value; ``profile`` the model's profile it was evaluated under; ``cached`` when a run answered it from
    its cache instead of simulating it again."""
    if objective not in OBJECTIVES:
        raise ValueError(f"objective must be one of {', '.join(OBJECTIVES)}, got {objective!r}")
    fields: dict[str, Any] = {
        "tree": tree,
        "seed": int(seed),
        "trials": int(trials),
        "profile": profile,
        "cached": cached,
    }
    if values is None:
        failure = {"ok": False, "error": error or "no fitness or descriptors", "fitness": 0.0}
        return {**fields, **failure, "names": [], "values": []}
    named = {name: float(v) for name, v in zip(VALUE_NAMES, values, strict=True)}
    return {**fields, "ok": True, "error": "", "fitness": named[objective], **_by_name(named)}


def _by_name(named: dict[str, float]) -> dict[str, Any]:
    return {"names": list(named), "values": list(named.values())}


def evaluation_fields(
    tree: str,
    seed: int,
    trials: int,
    result: ResultValues,
    objective: str,
    *,
    profile: str,
    cached: bool = False,
) -> dict[str, Any]:
    """``result_fields`` of an evaluator contract's result (or anything with its three fields)."""
    if result.error is not None or result.fitness is None or result.descriptors is None:
        error = result.error or ""
        return result_fields(tree, seed, trials, None, objective, error, profile=profile, cached=cached)
    values = (*result.fitness, *result.descriptors)
    return result_fields(tree, seed, trials, values, objective, profile=profile, cached=cached)


def named_values(msg: object) -> dict[str, float]:
    """Every value a message holds, by name: its ``names`` and ``values``, or, in a message recorded before
    them, its fields named after ``VALUE_NAMES`` (as many as it has: bags before the six primitives hold the
    paper's three objectives)."""
    names = getattr(msg, "names", None)
    if names is None:
        return {name: float(getattr(msg, name)) for name in VALUE_NAMES if hasattr(msg, name)}
    values = list(getattr(msg, "values", ()))
    if len(values) != len(names):
        raise ValueError(f"the message has {len(names)} value names but {len(values)} values")
    return {str(name): float(value) for name, value in zip(names, values, strict=True)}


def values_of(msg: object) -> tuple[float, ...]:
    """The values of a message, ``VALUE_NAMES`` order; ValueError naming a value it lacks."""
    named = named_values(msg)
    missing = [name for name in VALUE_NAMES if name not in named]
    if missing:
        raise ValueError(f"the message holds no value for {missing[0]}")
    return tuple(named[name] for name in VALUE_NAMES)


def evaluation_result_of(msg: EvaluationMessage) -> EvaluationResult:
    """The evaluator contract's result from an ``EvaluationResult`` message (values copied bit for bit)."""
    if not msg.ok:
        return failed(msg.error)
    values = values_of(msg)
    return EvaluationResult(fitness=values[:N_OBJECTIVES], descriptors=values[N_OBJECTIVES:], error=None)


def trial_fields(record: TrialRecord, pose: Callable[..., object]) -> dict[str, Any]:
    """The fields of a successful ``RunTrial`` result; ``pose`` builds a ``RobotPose`` from x, y, theta."""
    return {
        "success": True,
        "message": "",
        "gap": float(record.gap),
        **_by_name(dict(zip(VALUE_NAMES, (float(v) for v in record.values), strict=True))),
        "start_poses": [pose(x=x, y=y, theta=t) for x, y, t in record.start_poses.tolist()],
        "end_poses": [pose(x=x, y=y, theta=t) for x, y, t in record.end_poses.tolist()],
    }


def fill(msg: object, fields: dict[str, Any]) -> object:
    """Set ``fields`` on ``msg`` (a response or result, which cannot be built with keywords); return it."""
    for name, value in fields.items():
        setattr(msg, name, value)
    return msg


def trial_record_of(msg: TrialMessage, trial: int) -> TrialRecord:
    """The record of trial ``trial`` from a successful ``RunTrial`` result or response."""
    return TrialRecord(
        trial=trial,
        gap=float(msg.gap),
        values=values_of(msg),
        start_poses=np.array([[p.x, p.y, p.theta] for p in msg.start_poses]),
        end_poses=np.array([[p.x, p.y, p.theta] for p in msg.end_poses]),
    )
