"""What the simulator shows to RViz2 and Foxglove, in standard messages, SI units and frame ``arena``
(REP 103: metres, radians, z up; the arena centre at the origin).

- ``arena_markers``: the arena's walls and the trial's regions (``Config.arena_entry``), published latched on
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

from swarm_sim.model import Config, Piece, label_point

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
REGION_COLOURS: dict[str, ColorRGBA] = {
    "nest": NEST,
    "food": FOOD,
    "food2": _colour(0.6, 0.3, 0.8, 0.35),
    "food3": _colour(0.9, 0.7, 0.1, 0.35),
}
"""Each region kind's colour on the ground."""
CARRYING_COLOURS: tuple[ColorRGBA, ...] = (CARRYING, _colour(0.45, 0.15, 0.6), _colour(0.7, 0.5, 0.0))
"""A robot's body while it carries food of kind 1, 2 or 3 (the lowest kind it carries)."""


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


def _marker(stamp: Time, ns: str, marker_id: int, kind: int, colour: ColorRGBA) -> Marker:
    marker = Marker(header=Header(stamp=stamp, frame_id=FRAME), ns=ns, id=marker_id, type=kind)
    marker.action = Marker.ADD
    marker.color = colour
    marker.pose.orientation.w = 1.0
    return marker


def _wall_reach(x: float, y: float, c: float, s: float, half: float) -> float:
    """How far a ray from (x, y) inside the walls, along the unit vector (c, s), travels to the walls."""
    reach = math.inf
    for along, at in ((c, x), (s, y)):
        if along > 0.0:
            reach = min(reach, (half - at) / along)
        elif along < 0.0:
            reach = min(reach, (-half - at) / along)
    return reach


def beyond_outline(piece: Piece, half: float) -> list[tuple[float, float, float, float]]:
    """Per ray from a ``beyond`` piece's centre, (inner x, inner y, outer x, outer y) in mm: where the ray
    enters the region (the piece's circle) and where it meets the walls (``half`` from the centre)."""
    out = []
    for k in range(RAYS):
        angle = 2.0 * math.pi * k / RAYS
        c, s = math.cos(angle), math.sin(angle)
        reach = max(_wall_reach(piece.x, piece.y, c, s, half), piece.radius)
        out.append(
            (
                piece.x + piece.radius * c,
                piece.y + piece.radius * s,
                piece.x + reach * c,
                piece.y + reach * s,
            )
        )
    return out


def _piece_marker(stamp: Time, piece: Piece, marker_id: int, half: float) -> Marker:
    """One piece of a region: a flat cylinder for a disc, triangles for the rest (ns: the region's kind)."""
    colour = REGION_COLOURS[piece.kind]
    if piece.shape == "disc":
        marker = _marker(stamp, piece.kind, marker_id, Marker.CYLINDER, colour)
        marker.pose.position.x, marker.pose.position.y = piece.x * MM, piece.y * MM
        marker.scale.x = marker.scale.y = 2.0 * piece.radius * MM
        marker.scale.z = 0.005
        return marker
    marker = _marker(stamp, piece.kind, marker_id, Marker.TRIANGLE_LIST, colour)
    marker.scale.x = marker.scale.y = marker.scale.z = 1.0
    if piece.shape == "beyond":
        rays = beyond_outline(piece, half)
        for (ix, iy, ox, oy), (jx, jy, px, py) in zip(rays, rays[1:] + rays[:1], strict=True):
            a, b, c, d = (Point(x=u * MM, y=v * MM) for u, v in ((ix, iy), (ox, oy), (jx, jy), (px, py)))
            marker.points += [a, b, d, a, d, c]
        return marker
    near, far = (piece.radius, half) if piece.shape == "above" else (-piece.radius, -half)
    a, b, c, d = (
        Point(x=u * MM, y=v * MM) for u, v in ((-half, near), (half, near), (half, far), (-half, far))
    )
    marker.points += [a, b, c, a, c, d]
    return marker


def arena_markers(config: Config, trial: int, stamp: Time) -> MarkerArray:
    """The walls and the regions of trial ``trial`` (``Config.arena_entry``): each piece of a region kind
    under that kind's namespace (``nest``, ``food``), labelled (food with its gap in the papers' arena)."""
    clear = Marker(header=Header(stamp=stamp, frame_id=FRAME))
    clear.action = Marker.DELETEALL
    half_mm = config.arena_half
    half = half_mm * MM
    walls = _marker(stamp, "walls", 0, Marker.LINE_STRIP, WALL)
    walls.scale.x = 0.03
    walls.points = [Point(x=x, y=y) for x, y in ((-half, -half), (half, -half), (half, half), (-half, half))]
    walls.points.append(walls.points[0])
    markers = [clear, walls]
    labels = []
    gap = config.gap(trial)
    for m, piece in enumerate(config.arena_entry(trial)):
        markers.append(_piece_marker(stamp, piece, m, half_mm))
        label = _marker(stamp, f"{piece.kind}_label", m, Marker.TEXT_VIEW_FACING, LABEL)
        x, y = label_point(piece)
        label.pose.position.x, label.pose.position.y, label.pose.position.z = x * MM, y * MM, 0.05
        label.scale.z = 0.15
        label.text = piece.kind if math.isnan(gap) or piece.kind == "nest" else f"food (gap {gap:.0f} mm)"
        labels.append(label)
    return MarkerArray(markers=[*markers, *labels])


def robot_markers(
    config: Config,
    stamp: Time,
    poses: Sequence[Sequence[float]],
    namespaces: Sequence[str],
    actions: Sequence[str],
    carrying: Sequence[bool] = (),
    deliveries: Sequence[int] = (),
    carried: Sequence[int] = (),
) -> MarkerArray:
    """Per robot ``i``: a body (ns ``robots``, id i; coloured while it carries food), a heading arrow
    (``headings``) and a text label (``labels``: ``<i> <namespace>: <action>``, then ``, <d> delivered`` once
    it has delivered); and a text marker (ns ``deliveries``) counting the swarm's deliveries in the trial.
    ``carrying`` and ``deliveries`` are per robot (empty: none yet); ``carried``, per robot, the lowest food
    kind it carries (0: none) picks its body's colour in ``CARRYING_COLOURS`` (empty: kind 1 if carrying)."""
    markers = []
    radius = config.robot_radius * MM
    carrying = list(carrying) or [False] * len(poses)
    deliveries = list(deliveries) or [0] * len(poses)
    kinds = list(carried) or [1 if c else 0 for c in carrying]
    for i, ((x, y, theta), namespace, action) in enumerate(zip(poses, namespaces, actions, strict=True)):
        body = _marker(
            stamp, "robots", i, Marker.CYLINDER, CARRYING_COLOURS[kinds[i] - 1] if kinds[i] else ROBOT
        )
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
