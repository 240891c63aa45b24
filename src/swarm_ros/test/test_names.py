"""Robot namespaces: the default names, the index a namespace names, and the clear errors."""

import pytest

from swarm_ros.names import (
    NamespaceError,
    check_robot_namespaces,
    check_topic,
    graph_namespace,
    index_from_namespace,
    robot_frame,
    robot_index,
    robot_namespaces,
)


def test_default_namespaces_count_from_zero():
    assert robot_namespaces(3) == ["footbot_0", "footbot_1", "footbot_2"]


@pytest.mark.parametrize(
    ("namespace", "index"),
    [
        ("/footbot_4", 4),
        ("/swarm_a/footbot_12", 12),
        ("/footbot_0/", 0),
        ("/robots/red", None),
        ("/footbot_04", None),
    ],
)
def test_the_index_comes_from_the_last_part_of_the_namespace(namespace, index):
    assert index_from_namespace(namespace) == index


def test_a_declared_index_must_agree_with_the_namespace():
    assert robot_index("/swarm_b/footbot_4", -1) == 4
    assert robot_index("/swarm_b/footbot_4", 4) == 4
    with pytest.raises(NamespaceError, match=r"robot:=0 contradicts namespace '/footbot_4' \(robot 4\)"):
        robot_index("/footbot_4", 0)


def test_another_namespace_needs_the_index():
    assert robot_index("/robots/red", 2) == 2
    with pytest.raises(NamespaceError, match="give the robot index with -p robot:=<i>"):
        robot_index("/robots/red", -1)


@pytest.mark.parametrize(
    ("namespaces", "problem"),
    [
        ([], "at least one"),
        (["/footbot_0"], "relative ROS names"),
        (["a", "a"], "twice"),
        (["0a"], "relative"),
    ],
)
def test_bad_robot_namespaces_are_refused(namespaces, problem):
    with pytest.raises(NamespaceError, match=problem):
        check_robot_namespaces(namespaces)


@pytest.mark.parametrize(
    "given,namespace",
    [("", ""), ("/", ""), ("swarm_a", "/swarm_a"), ("/swarm_a/", "/swarm_a"), ("/a/b_2", "/a/b_2")],
)
def test_a_graph_namespace_is_absolute_without_a_trailing_slash(given, namespace):
    assert graph_namespace(given) == namespace


@pytest.mark.parametrize("given", ["bad name", "/1x", "/a//b", "/a\nb", "\udcff", "/a-b"])
def test_a_namespace_ros_refuses_is_refused_before_a_node_starts(given):
    """trial and record said nothing and started their graph in it (issue 41)."""
    with pytest.raises(NamespaceError, match="is not a ROS namespace") as refused:
        graph_namespace(given)
    assert "\n" not in str(refused.value)


@pytest.mark.parametrize("topic", ["/clock", "clock", "/swarm_a/clock", "_x/y1"])
def test_topic_names(topic):
    assert check_topic(topic) == topic
    for bad in ("", "/", "a b", "/a//b", "1x", "/a/", "\udcff"):
        with pytest.raises(NamespaceError, match="is not a ROS topic name"):
            check_topic(bad, "--clock")


@pytest.mark.parametrize(
    ("namespace", "frame"),
    [
        ("/footbot_3", "footbot_3/base_link"),
        ("/swarm_a/footbot_3", "swarm_a/footbot_3/base_link"),
        ("/swarm_a/footbot_3/", "swarm_a/footbot_3/base_link"),
        ("/", "base_link"),
    ],
)
def test_a_robots_frame_is_namespaced_without_a_leading_slash(namespace, frame):
    assert robot_frame(namespace, "base_link") == frame
