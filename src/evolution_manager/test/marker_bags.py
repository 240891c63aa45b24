"""The markers a trial bag holds for ``snapshot``: an arena's outline (``/markers``) and one robot
(``/robot_markers``), for the tests that need a bag ``snapshot`` can draw."""

from __future__ import annotations

from geometry_msgs.msg import Point
from rclpy.serialization import serialize_message
from visualization_msgs.msg import Marker, MarkerArray

ARRAY = "visualization_msgs/msg/MarkerArray"


def write_snapshot_markers(recorder) -> None:
    """Write the arena's outline at time 1 and one robot at time 2 with ``recorder`` (a ``BagRecorder``)."""
    corners = ((-1.0, -1.0), (1.0, -1.0), (1.0, 1.0), (-1.0, 1.0), (-1.0, -1.0))
    arena = Marker(type=Marker.LINE_STRIP, points=[Point(x=x, y=y) for x, y in corners])
    arena.color.a = 1.0
    robot = Marker(type=Marker.CYLINDER)
    robot.scale.x = 0.17
    robot.color.r = robot.color.a = 1.0
    recorder.write_cdr("/markers", ARRAY, 1, serialize_message(MarkerArray(markers=[arena])))
    recorder.write_cdr("/robot_markers", ARRAY, 2, serialize_message(MarkerArray(markers=[robot])))
