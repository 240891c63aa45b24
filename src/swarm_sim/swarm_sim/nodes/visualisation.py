"""What the simulator shows to RViz2 and Foxglove, in standard messages, SI units and frame ``arena``
(REP 103: metres, radians, z up; the arena centre at the origin).

- ``arena_markers``: the arena's walls, the nest and the food region of the trial's gap, published latched on
  ``markers`` at each trial's start (``visualization_msgs/MarkerArray``).
- ``robot_markers``: per robot a body (green while it carries food), a heading arrow and a text label
  ``<i> <namespace>: <action>`` (with its deliveries once it has made one), and the swarm's delivery counter,
  every sensing step on ``robot_markers``.
- ``pose_stamped``: a robot's pose, every sensing step on ``<robot namespace>/pose``.
- ``odometry``: a robot's pose and velocity as ``nav_msgs/Odometry`` in its own frames (REP 105), every
  sensing step on ``<robot namespace>/odom``.
- ``transform``: one frame's pose in its parent's (``geometry_msgs/TransformStamped``), for ``/tf`` (each
  robot's ``base_link`` in its ``odom``, every step) and ``/tf_static`` (each robot's ``odom`` in ``arena``).
"""

from __future__ import annotations

import math
from collections.abc import Sequence

from builtin_interfaces.msg import Time
from geometry_msgs.msg import Point, Pose, PoseStamped, TransformStamped
from nav_msgs.msg import Odometry
from std_msgs.msg import ColorRGBA, Header
from visualization_msgs.msg import Marker, MarkerArray

from swarm_sim.model import Config

FRAME = "arena"
"""The fixed frame of every pose and marker: the arena, centre at the origin, metres."""
MM = 0.001
"""Metres per millimetre: the world model works in millimetres."""
RAYS = 64
"""Rays of the food region's outline; a multiple of 8 so that the square's corners are among them."""


def _colour(r: float, g: float, b: float, a: float = 1.0) -> ColorRGBA:
    return ColorRGBA(r=r, g=g, b=b, a=a)


WALL, NEST, FOOD, ROBOT, LABEL, CARRYING = (
    _colour(0.3, 0.3, 0.3),
    _colour(0.2, 0.4, 0.9, 0.5),
    _colour(0.2, 0.7, 0.2, 0.35),
    _colour(0.95, 0.55, 0.1),
    _colour(1.0, 1.0, 1.0),
    _colour(0.1, 0.6, 0.1),
)


def pose_in_metres(x_mm: float, y_mm: float, theta: float, z: float = 0.0) -> Pose:
    """A ``geometry_msgs/Pose`` in metres from a planar pose in millimetres and radians (yaw about z)."""
    pose = Pose()
    pose.position.x, pose.position.y, pose.position.z = x_mm * MM, y_mm * MM, z
    pose.orientation.z = math.sin(theta / 2.0)
    pose.orientation.w = math.cos(theta / 2.0)
    return pose


def pose_stamped(stamp: Time, x_mm: float, y_mm: float, theta: float) -> PoseStamped:
    """A robot's pose in frame ``arena``, metres and radians."""
    return PoseStamped(header=Header(stamp=stamp, frame_id=FRAME), pose=pose_in_metres(x_mm, y_mm, theta))


def transform(
    stamp: Time, parent: str, child: str, x_mm: float, y_mm: float, theta: float
) -> TransformStamped:
    """Frame ``child``'s pose in frame ``parent``: translation in metres from millimetres, rotation ``theta``
    radians about z."""
    message = TransformStamped(header=Header(stamp=stamp, frame_id=parent), child_frame_id=child)
    pose = pose_in_metres(x_mm, y_mm, theta)
    translation = message.transform.translation
    translation.x, translation.y, translation.z = pose.position.x, pose.position.y, pose.position.z
    message.transform.rotation = pose.orientation
    return message


def odometry(
    stamp: Time,
    pose_mm: tuple[float, float, float],
    previous_mm: tuple[float, float, float] | None,
    dt: float,
    odom_frame: str,
    base_frame: str,
) -> Odometry:
    """A robot's odometry (REP 105): its pose ``pose_mm`` (x, y in millimetres, heading in radians) in
    ``odom_frame`` in metres, and its velocity in ``base_frame`` (``child_frame_id``) over the last step of
    ``dt`` seconds from ``previous_mm``: forward (``linear.x``) and sideways (``linear.y``, from pushes) in
    m/s about the step's mean heading, turning (``angular.z``) in rad/s, anticlockwise positive. Without a
    previous pose (a trial's first step, when the robots are placed) the velocity is zero. The simulator's
    odometry is exact: its covariances are zero."""
    message = Odometry(header=Header(stamp=stamp, frame_id=odom_frame), child_frame_id=base_frame)
    x, y, theta = pose_mm
    message.pose.pose = pose_in_metres(x, y, theta)
    if previous_mm is not None:
        px, py, ptheta = previous_mm
        turn = math.remainder(theta - ptheta, math.tau)
        heading = ptheta + turn / 2.0
        dx, dy = (x - px) * MM, (y - py) * MM
        velocity = message.twist.twist
        velocity.linear.x = (dx * math.cos(heading) + dy * math.sin(heading)) / dt
        velocity.linear.y = (-dx * math.sin(heading) + dy * math.cos(heading)) / dt
        velocity.angular.z = turn / dt
    return message


def food_outline(config: Config, gap: float) -> list[tuple[float, float, float, float]]:
    """Per ray, (inner x, inner y, outer x, outer y) in mm: where the ray from the centre enters the food
    region (the circle of radius nest_radius + gap) and where it meets the walls."""
    inner = config.nest_radius + gap
    half = config.arena_half
    out = []
    for k in range(RAYS):
        angle = 2.0 * math.pi * k / RAYS
        c, s = math.cos(angle), math.sin(angle)
        reach = half / max(abs(c), abs(s))
        out.append((inner * c, inner * s, reach * c, reach * s))
    return out


def _marker(stamp: Time, ns: str, marker_id: int, kind: int, colour: ColorRGBA) -> Marker:
    marker = Marker(header=Header(stamp=stamp, frame_id=FRAME), ns=ns, id=marker_id, type=kind)
    marker.action = Marker.ADD
    marker.color = colour
    marker.pose.orientation.w = 1.0
    return marker


def arena_markers(config: Config, gap: float, stamp: Time) -> MarkerArray:
    """The walls, the nest and the food region of an arena with nest-food gap ``gap`` (mm)."""
    clear = Marker(header=Header(stamp=stamp, frame_id=FRAME))
    clear.action = Marker.DELETEALL
    half = config.arena_half * MM
    walls = _marker(stamp, "walls", 0, Marker.LINE_STRIP, WALL)
    walls.scale.x = 0.03
    walls.points = [Point(x=x, y=y) for x, y in ((-half, -half), (half, -half), (half, half), (-half, half))]
    walls.points.append(walls.points[0])
    nest = _marker(stamp, "nest", 0, Marker.CYLINDER, NEST)
    nest.scale.x = nest.scale.y = 2.0 * config.nest_radius * MM
    nest.scale.z = 0.005
    food = _marker(stamp, "food", 0, Marker.TRIANGLE_LIST, FOOD)
    food.scale.x = food.scale.y = food.scale.z = 1.0
    rays = food_outline(config, gap)
    for (ix, iy, ox, oy), (jx, jy, px, py) in zip(rays, rays[1:] + rays[:1], strict=True):
        a, b, c, d = (
            Point(x=ix * MM, y=iy * MM),
            Point(x=ox * MM, y=oy * MM),
            Point(x=jx * MM, y=jy * MM),
            Point(x=px * MM, y=py * MM),
        )
        food.points += [a, b, d, a, d, c]
    labels = []
    for ns, text, x, y in (
        ("nest_label", "nest", 0.0, 0.0),
        ("food_label", f"food (gap {gap:.0f} mm)", 0.0, -(config.nest_radius + gap) * MM - 0.15),
    ):
        label = _marker(stamp, ns, 0, Marker.TEXT_VIEW_FACING, LABEL)
        label.pose.position.x, label.pose.position.y, label.pose.position.z = x, y, 0.05
        label.scale.z = 0.15
        label.text = text
        labels.append(label)
    return MarkerArray(markers=[clear, walls, nest, food, *labels])


def robot_markers(
    config: Config,
    stamp: Time,
    poses: Sequence[Sequence[float]],
    namespaces: Sequence[str],
    actions: Sequence[str],
    carrying: Sequence[bool] = (),
    deliveries: Sequence[int] = (),
) -> MarkerArray:
    """Per robot ``i``: a body (ns ``robots``, id i; green while it carries food), a heading arrow
    (``headings``) and a text label (``labels``: ``<i> <namespace>: <action>``, then ``, <d> delivered`` once
    it has delivered); and a text marker (ns ``deliveries``) counting the swarm's deliveries in the trial.
    ``carrying`` and ``deliveries`` are per robot (empty: none yet)."""
    markers = []
    radius = config.robot_radius * MM
    carrying = list(carrying) or [False] * len(poses)
    deliveries = list(deliveries) or [0] * len(poses)
    for i, ((x, y, theta), namespace, action) in enumerate(zip(poses, namespaces, actions, strict=True)):
        body = _marker(stamp, "robots", i, Marker.CYLINDER, CARRYING if carrying[i] else ROBOT)
        body.pose = pose_in_metres(x, y, theta, 0.05)
        body.scale.x = body.scale.y = 2.0 * radius
        body.scale.z = 0.1
        arrow = _marker(stamp, "headings", i, Marker.ARROW, WALL)
        arrow.pose = pose_in_metres(x, y, theta, 0.11)
        arrow.scale.x, arrow.scale.y, arrow.scale.z = radius * 1.4, 0.02, 0.02
        label = _marker(stamp, "labels", i, Marker.TEXT_VIEW_FACING, LABEL)
        label.pose = pose_in_metres(x, y, 0.0, 0.3)
        label.scale.z = 0.1
        label.text = f"{i} {namespace}: {action}" + (f", {deliveries[i]} delivered" if deliveries[i] else "")
        markers += [body, arrow, label]
    counter = _marker(stamp, "deliveries", 0, Marker.TEXT_VIEW_FACING, LABEL)
    position = counter.pose.position
    position.x, position.y, position.z = 0.0, config.arena_half * MM, 0.3
    counter.scale.z = 0.15
    counter.text = f"deliveries {sum(deliveries)}, carrying {sum(carrying)}"
    return MarkerArray(markers=[*markers, counter])
