"""The simulator's odometry (swarm_sim.nodes.visualisation.odometry): nav_msgs/Odometry in each robot's own
frames, SI units, the velocity in the robot's base frame from the step's motion (REP 103 and 105)."""

from __future__ import annotations

import math

import pytest
from builtin_interfaces.msg import Time

from swarm_sim.nodes.visualisation import odometry

STAMP = Time(sec=3, nanosec=125_000_000)
DT = 0.125


def test_pose_in_metres_in_the_robots_odom_frame_and_no_velocity_without_a_previous_pose() -> None:
    frames = ("footbot_1/odom", "footbot_1/base_link")
    message = odometry(STAMP, (1000.0, -500.0, math.pi / 2), None, DT, *frames)
    assert message.header.frame_id == "footbot_1/odom" and message.child_frame_id == "footbot_1/base_link"
    assert message.header.stamp == STAMP
    position, orientation = message.pose.pose.position, message.pose.pose.orientation
    assert (position.x, position.y, position.z) == pytest.approx((1.0, -0.5, 0.0))
    assert 2 * math.atan2(orientation.z, orientation.w) == pytest.approx(math.pi / 2)
    twist = message.twist.twist
    assert (twist.linear.x, twist.linear.y, twist.angular.z) == (0.0, 0.0, 0.0)


def test_driving_forward_along_its_heading_is_positive_linear_x() -> None:
    # heading +y (pi/2), 6.25 mm along +y in one step of 0.125 s: 0.05 m/s forward, nothing sideways
    message = odometry(STAMP, (0.0, 6.25, math.pi / 2), (0.0, 0.0, math.pi / 2), DT, "o", "b")
    twist = message.twist.twist
    assert twist.linear.x == pytest.approx(0.05)
    assert twist.linear.y == pytest.approx(0.0, abs=1e-12)
    assert twist.angular.z == pytest.approx(0.0)


def test_turning_left_across_pi_is_a_small_positive_angular_z() -> None:
    # from just below pi to just above -pi: a small anticlockwise turn, not nearly a full turn clockwise
    message = odometry(STAMP, (0.0, 0.0, -math.pi + 0.01), (0.0, 0.0, math.pi - 0.01), DT, "o", "b")
    assert message.twist.twist.angular.z == pytest.approx(0.02 / DT)


def test_a_push_to_the_robots_left_is_positive_linear_y() -> None:
    # heading +x, pushed 2.5 mm towards +y (its left) in one step
    message = odometry(STAMP, (0.0, 2.5, 0.0), (0.0, 0.0, 0.0), DT, "o", "b")
    assert message.twist.twist.linear.y == pytest.approx(0.02)
    assert message.twist.twist.linear.x == pytest.approx(0.0, abs=1e-12)
