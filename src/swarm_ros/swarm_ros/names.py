"""Robot namespaces: the default names of a swarm's robots and the robot index a namespace names.

Every node of the graph uses relative names; a robot's topics and services live in its namespace
(``footbot_<i>`` below the graph's namespace, e.g. ``/swarm_a/footbot_3/wheels``). The simulator takes its
robots' namespaces from its ``robot_namespaces`` parameter (default ``footbot_0`` .. ``footbot_<n - 1>``);
robot ``i`` is the i-th entry.
"""

from __future__ import annotations

import re
from collections.abc import Sequence

ROBOT_PREFIX = "footbot_"
_ROBOT_NAME = re.compile(rf"{ROBOT_PREFIX}(0|[1-9][0-9]*)")
_NAME = re.compile(r"[A-Za-z_][A-Za-z0-9_]*(/[A-Za-z_][A-Za-z0-9_]*)*")


class NamespaceError(ValueError):
    """A namespace or robot index that does not fit the graph; the message says what was expected."""


_TOKEN = "[A-Za-z_][A-Za-z0-9_]*"
_ABSOLUTE = re.compile(rf"(/{_TOKEN})+")
_TOPIC = re.compile(rf"/?{_TOKEN}(/{_TOKEN})*")


def graph_namespace(namespace: str) -> str:
    """``namespace`` as an absolute ROS namespace without a trailing slash ("" for the root, given as "" or
    "/"; "swarm_a" is "/swarm_a"); ``NamespaceError`` for one that is not a ROS name (each part letters,
    digits and '_', not starting with a digit), before any node is started in it."""
    if not namespace.strip("/"):
        return ""
    absolute = "/" + namespace.strip("/")
    if not _ABSOLUTE.fullmatch(absolute):
        raise NamespaceError(
            f"namespace {namespace!r} is not a ROS namespace: expected names of letters, digits and '_' "
            "(not starting with a digit) separated by single '/', e.g. /swarm_a"
        )
    return absolute


def check_topic(topic: str, what: str = "topic") -> str:
    """``topic`` if it is a ROS topic name (absolute or relative: parts of letters, digits and '_', not
    starting with a digit, separated by single '/'); ``NamespaceError`` otherwise."""
    if not _TOPIC.fullmatch(topic):
        raise NamespaceError(
            f"{what} {topic!r} is not a ROS topic name: expected names of letters, digits and '_' (not "
            "starting with a digit) separated by single '/', e.g. /clock or /swarm_a/clock"
        )
    return topic


def robot_namespaces(robots: int) -> list[str]:
    """The default namespaces of ``robots`` robots: ``footbot_0`` .. ``footbot_<robots - 1>``."""
    return [f"{ROBOT_PREFIX}{i}" for i in range(robots)]


def check_robot_namespaces(namespaces: list[str]) -> list[str]:
    """``namespaces`` if they are distinct relative ROS names; ``NamespaceError`` otherwise."""
    if not namespaces:
        raise NamespaceError("robot_namespaces must name at least one robot")
    for name in namespaces:
        if not _NAME.fullmatch(name):
            raise NamespaceError(
                f"robot_namespaces holds {name!r}: expected relative ROS names such as 'footbot_0' "
                "(letters, digits, '_' and '/', not starting with '/' or a digit)"
            )
    if len(set(namespaces)) != len(namespaces):
        raise NamespaceError(f"robot_namespaces names a robot twice: {namespaces}")
    return list(namespaces)


def index_from_namespace(namespace: str) -> int | None:
    """The robot index ``i`` of a namespace whose last part is ``footbot_<i>``; None for any other."""
    last = namespace.rstrip("/").rsplit("/", 1)[-1]
    match = _ROBOT_NAME.fullmatch(last)
    return int(match.group(1)) if match else None


def robot_frame(namespace: str, frame: str) -> str:
    """A robot's frame id: ``frame`` (e.g. ``base_link``, REP 105) under the robot's namespace without its
    leading slash (``/swarm_a/footbot_3`` -> ``swarm_a/footbot_3/base_link``), so that every robot of every
    swarm has frames of its own; ``frame`` alone at the root namespace."""
    prefix = namespace.strip("/")
    return f"{prefix}/{frame}" if prefix else frame


def robot_frames(graph: str, namespaces: Sequence[str]) -> list[tuple[str, str]]:
    """Each robot's ``(odom, base_link)`` frame ids (REP 105) in the graph of namespace ``graph`` (``/`` or
    ``""`` for the root, ``/swarm_a``), robot namespaces ``namespaces`` (relative: ``footbot_3``): under the
    robot's full namespace (``robot_frame``: ``swarm_a/footbot_3/base_link``), so no two swarms share one."""
    prefix = graph.rstrip("/")
    return [
        (robot_frame(f"{prefix}/{ns}", "odom"), robot_frame(f"{prefix}/{ns}", "base_link"))
        for ns in namespaces
    ]


def robot_index(namespace: str, declared: int) -> int:
    """A controller's robot index: from its namespace (``.../footbot_<i>``), checked against ``declared``
    (the ``robot`` parameter, -1 when not given). A namespace of another form needs ``declared``."""
    derived = index_from_namespace(namespace)
    if derived is None:
        if declared < 0:
            raise NamespaceError(
                f"namespace {namespace!r} does not end in {ROBOT_PREFIX}<i>: give the robot index with "
                "-p robot:=<i> (its position in the simulator's robot_namespaces)"
            )
        return declared
    if declared >= 0 and declared != derived:
        raise NamespaceError(
            f"parameter robot:={declared} contradicts namespace {namespace!r} (robot {derived}): "
            f"drop the parameter or start the node in /{ROBOT_PREFIX}{declared}"
        )
    return derived
