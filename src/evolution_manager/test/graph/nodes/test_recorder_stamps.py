"""The recorder writes the bytes it receives and reads each message's stamp from them without deserializing:
the stamp it reads equals the stamp set in the message, for every message type of the trial graph."""

import pytest
from builtin_interfaces.msg import Time
from geometry_msgs.msg import TransformStamped
from rclpy.serialization import serialize_message
from visualization_msgs.msg import Marker, MarkerArray

from evolution_manager.graph.nodes.recorder import cdr_stamp_ns, trial_topics
from tf2_msgs.msg import TFMessage


def stamped(msg_class: type, stamp: Time):
    msg = msg_class()
    if msg_class is MarkerArray:
        msg.markers = [Marker(), Marker()]
        msg.markers[0].header.stamp = stamp
        msg.markers[1].header.stamp = Time(sec=99, nanosec=1)  # only the first marker's stamp counts
    elif msg_class is TFMessage:
        msg.transforms = [TransformStamped(), TransformStamped()]
        msg.transforms[0].header.stamp = stamp
        msg.transforms[0].header.frame_id = "swarm_a/footbot_0/odom"  # strings after the stamp only
        msg.transforms[1].header.stamp = Time(sec=99, nanosec=1)  # only the first transform's stamp counts
    elif hasattr(msg, "clock"):
        msg.clock = stamp
    else:
        msg.header.stamp = stamp
    return msg


@pytest.mark.parametrize("msg_class", sorted({cls for _, cls in trial_topics(2)}, key=lambda c: c.__name__))
@pytest.mark.parametrize("sec, nanosec", [(0, 0), (21, 125_000_000), (2**31 - 1, 999_999_999)])
def test_the_stamp_read_from_the_bytes_is_the_stamp_set(msg_class, sec, nanosec):
    data = serialize_message(stamped(msg_class, Time(sec=sec, nanosec=nanosec)))
    assert cdr_stamp_ns(data, msg_class) == sec * 1_000_000_000 + nanosec


def test_an_empty_marker_array_or_tf_message_has_stamp_zero():
    assert cdr_stamp_ns(serialize_message(MarkerArray()), MarkerArray) == 0
    assert cdr_stamp_ns(serialize_message(TFMessage()), TFMessage) == 0


def test_the_trial_topics_hold_odom_and_tf_unless_left_out():
    topics = dict(trial_topics(2, "/swarm_a"))
    assert topics["/tf"] is TFMessage and topics["/tf_static"] is TFMessage
    assert topics["/swarm_a/footbot_1/odom"].__name__ == "Odometry"
    lean = dict(trial_topics(2, "/swarm_a", frames=False))
    assert set(topics) - set(lean) == {
        "/tf",
        "/tf_static",
        "/swarm_a/footbot_0/odom",
        "/swarm_a/footbot_1/odom",
    }


def test_a_big_endian_message_is_read_in_its_own_byte_order():
    data = serialize_message(stamped(MarkerArray, Time(sec=3, nanosec=5)))
    # the same message as a big-endian writer would send it: encapsulation 0x0000, every number swapped
    big = bytes([0, 0]) + data[2:4] + (2).to_bytes(4, "big") + (3).to_bytes(4, "big") + (5).to_bytes(4, "big")
    assert cdr_stamp_ns(big, MarkerArray) == 3_000_000_005
