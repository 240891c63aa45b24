"""Replay a bag, or verify that a recorded trial reproduces.

``ws/run evolution_manager replay BAG [--rate X]`` republishes every message of the bag on its topic, paced
by the recorded timestamps (``--rate 2`` twice as fast, ``--rate 0`` as fast as possible) after ``--delay``
seconds for discovery, with ``/clock`` following the bag's time, so any ROS tool (``ros2 topic echo``, RViz,
Foxglove) can watch the trial again. ``--wait-for TOPIC`` (repeatable) first waits until each such topic has a
subscriber, so a listener that is slow to discover the replay misses nothing.

``ws/run evolution_manager replay BAG --verify`` publishes nothing: it re-runs the recorded trial from its
seed and reports whether it reproduces the recording bit for bit (exit code 0) or where it first differs (1).
"""

from __future__ import annotations

import importlib
import re
import signal
import sys
import threading
import time
from collections.abc import Sequence
from pathlib import Path

import rclpy
from rclpy.node import Node
from rclpy.publisher import Publisher
from rclpy.signals import SignalHandlerOptions
from rosbags.rosbag2 import Reader
from rosgraph_msgs.msg import Clock

from evolution_manager.arguments import OneLineParser, finite, without_ros_args
from evolution_manager.recording.bags import (
    BagError,
    check_bag,
    check_crcs,
    is_latched,
    promised_messages,
    read_bag,
    recover_bag,
)
from evolution_manager.recording.reproduce import verify_trial_bag
from swarm_ros.qos import NO_PUBLISHER_EVENTS, RECORDING, RECORDING_LATCHED

RELIABLE = RECORDING


MESSAGE_PACKAGES = (
    "swarm_msgs",
    "std_msgs",
    "geometry_msgs",
    "nav_msgs",
    "tf2_msgs",
    "visualization_msgs",
    "rosgraph_msgs",
    "builtin_interfaces",
    "diagnostic_msgs",
    "lifecycle_msgs",
    "rcl_interfaces",
)
"""The packages whose message types ``replay`` loads: the project's and the standard ROS ones its graph
publishes. A bag names its types as text (``metadata.yaml``, the MCAP schemas); loading one means importing a
Python module of that name, so a type of any other package is refused, never imported."""

_MESSAGE_TYPE = re.compile(r"(?P<package>[a-z][a-z0-9_]*)/msg/(?P<name>[A-Z][A-Za-z0-9]*)")


def check_message_type(msgtype: str, topic: str = "") -> tuple[str, str]:
    """The package and name of the message type ``msgtype`` (``swarm_msgs/msg/WheelCommand``); ``BagError``
    in one line for a type that is not ``PACKAGE/msg/Name`` of one of ``MESSAGE_PACKAGES``."""
    where = f"topic {topic} has " if topic else ""
    match = _MESSAGE_TYPE.fullmatch(msgtype)
    if match is None or match["package"] not in MESSAGE_PACKAGES:
        raise BagError(
            f"{where}message type {msgtype!r}, which replay does not load: expected PACKAGE/msg/Name of "
            f"{', '.join(MESSAGE_PACKAGES)}"
        )
    return match["package"], match["name"]


def message_class(msgtype: str) -> type:
    """The rclpy message class of a type name such as ``swarm_msgs/msg/WheelCommand``, of the allowed
    packages only (``check_message_type``)."""
    package, name = check_message_type(msgtype)
    cls = getattr(importlib.import_module(f"{package}.msg"), name, None)
    if not isinstance(cls, type):
        raise BagError(f"message type {msgtype!r} is not a message of the installed {package}")
    return cls


class NoSubscriberError(Exception):
    """A topic of ``--wait-for`` found no subscriber in the time allowed."""


def replay(
    bag: Path,
    rate: float,
    delay: float,
    stop: threading.Event,
    wait_for: Sequence[str] = (),
    wait_timeout: float = 60.0,
) -> int:
    """Publish every message of ``bag``, after ``delay`` seconds for discovery; return how many. With
    ``wait_for``, first wait until each of those topics has a matched subscription (``NoSubscriberError``
    after ``wait_timeout`` seconds). A bag whose types are not all allowed (``check_message_type``), whose
    MCAP files fail their CRCs, or that lacks a topic of ``wait_for`` is refused (``BagError``) before the
    node starts."""
    topics = bag_topics(bag)
    check_crcs(bag)  # a damaged chunk: refused, not half published
    missing = [topic for topic in wait_for if topic not in topics]
    if missing:
        raise BagError(
            f"{bag} has no topic {missing[0]} to wait for: its topics are {', '.join(sorted(topics))}"
        )
    context = rclpy.Context()
    rclpy.init(context=context, signal_handler_options=SignalHandlerOptions.NO)
    node = Node("replay", context=context)
    clock = node.create_publisher(Clock, "/clock", RELIABLE, event_callbacks=NO_PUBLISHER_EVENTS)
    publishers: dict[str, Publisher] = {
        topic: node.create_publisher(
            message_class(msgtype),
            topic,
            RECORDING_LATCHED if is_latched(topic) else RELIABLE,
            event_callbacks=NO_PUBLISHER_EVENTS,
        )
        for topic, msgtype in topics.items()
        if topic != "/clock"
    }
    publishers["/clock"] = clock
    published = 0
    subscribers = "has a subscriber" if len(wait_for) == 1 else "have subscribers"
    waiting = f"once {', '.join(wait_for)} {subscribers}, then " if wait_for else ""
    node.get_logger().info(f"ready: {len(topics)} topics of {bag}; publishing {waiting}in {delay} s")
    try:
        # A matched subscription on our side can precede the subscriber matching us; the delay covers that.
        deadline = time.monotonic() + wait_timeout
        for topic in wait_for:
            while publishers[topic].get_subscription_count() == 0 and not stop.is_set():
                if time.monotonic() > deadline:
                    raise NoSubscriberError(f"no subscriber of {topic} appeared in {wait_timeout:g} s")
                stop.wait(0.05)
        stop.wait(delay)  # let subscribers discover and match the publishers
        wall_start = time.monotonic()
        bag_start: int | None = None
        for message in read_bag(bag):
            if stop.is_set():
                break
            bag_start = message.timestamp_ns if bag_start is None else bag_start
            if rate > 0:
                due = wall_start + (message.timestamp_ns - bag_start) / 1e9 / rate
                time.sleep(max(0.0, due - time.monotonic()))
            if "/clock" not in topics:
                seconds, nanoseconds = divmod(message.timestamp_ns, 1_000_000_000)
                clock.publish(Clock(clock=rclpy.time.Time(seconds=seconds, nanoseconds=nanoseconds).to_msg()))
            publishers[message.topic].publish(message.data)
            published += 1
    finally:
        node.destroy_node()
        rclpy.try_shutdown(context=context)
    return published


def bag_topics(bag: Path) -> dict[str, str]:
    """Every topic of a whole bag with its message type."""
    check_bag(bag)
    try:
        with Reader(bag) as reader:
            topics = {connection.topic: connection.msgtype for connection in reader.connections}
    except Exception as error:  # rosbags' ReaderError: a truncated or empty MCAP, a damaged metadata.yaml
        raise BagError(f"{bag} is not a readable bag ({type(error).__name__}: {error})") from None
    for topic, msgtype in topics.items():  # every type checked before any is loaded
        try:
            check_message_type(msgtype, topic)
        except BagError as error:
            raise BagError(f"{bag}: {error}") from None
    return topics


def main(argv: Sequence[str] | None = None) -> int:
    """``replay``: republish a bag, or ``--verify`` a recorded trial."""
    parser = OneLineParser(prog="replay", description=__doc__.split("\n\n")[1])
    parser.add_argument("bag", type=Path, help="the bag directory")
    parser.add_argument(
        "--rate", type=finite(0.0, what="speed"), default=1.0, help="playback speed; 0 = as fast as possible"
    )
    parser.add_argument(
        "--delay",
        type=finite(0.0, what="number of seconds"),
        default=1.0,
        help="seconds to wait for discovery first",
    )
    parser.add_argument(
        "--wait-for",
        action="append",
        default=[],
        metavar="TOPIC",
        help="before the delay, wait until TOPIC has a subscriber (repeatable)",
    )
    parser.add_argument(
        "--wait-timeout",
        type=finite(0.0, what="number of seconds"),
        default=60.0,
        help="seconds --wait-for waits for a subscriber before giving up (status 1)",
    )
    parser.add_argument("--verify", action="store_true", help="re-run the recorded trial and compare")
    args = parser.parse_args(without_ros_args(sys.argv[1:] if argv is None else argv))
    try:
        if args.verify:
            verification = verify_trial_bag(args.bag)
            print(verification.summary())
            return 0 if verification.reproduced else 1
        stop = threading.Event()
        for sig in (signal.SIGINT, signal.SIGTERM):
            signal.signal(sig, lambda *_: stop.set())
        count = replay(args.bag, args.rate, args.delay, stop, args.wait_for, args.wait_timeout)
    except BagError as error:
        print(f"replay: {error}", file=sys.stderr)
        return 2
    except NoSubscriberError as error:
        print(f"replay: {error}; nothing published", file=sys.stderr)
        return 1
    print(f"replayed {count} messages from {args.bag}")
    return 0


def recover_main(argv: Sequence[str] | None = None) -> int:
    """``recover DAMAGED NEW_BAG``: write a whole bag from what a killed recorder left."""
    parser = OneLineParser(
        prog="recover",
        description="Write a whole bag at NEW_BAG from every message that reached the disk in DAMAGED, a bag "
        "whose recorder was killed (no metadata.yaml, no MCAP summary).",
    )
    parser.add_argument("damaged", type=Path, help="the damaged bag directory (or its .mcap file)")
    parser.add_argument("recovered", type=Path, help="the new bag directory to write")
    args = parser.parse_args(sys.argv[1:] if argv is None else argv)
    try:
        if not args.damaged.exists():
            raise BagError(f"no bag at {args.damaged}")
        promised = promised_messages(args.damaged) if args.damaged.is_dir() else None
        count = recover_bag(args.damaged, args.recovered)
    except BagError as error:
        print(f"recover: {error}", file=sys.stderr)
        return 2
    if promised is None:
        print(f"recovered {count} messages into {args.recovered} (no count in a metadata.yaml to compare)")
    elif count < promised:
        print(
            f"recovered {count} of the {promised} messages its metadata.yaml counts into {args.recovered}: "
            f"{promised - count} lost (a damaged or truncated MCAP file)"
        )
    else:
        print(f"recovered {count} of the {promised} messages its metadata.yaml counts into {args.recovered}")
    return 0
