"""Record the topics of a trial graph to a rosbag2 bag with MCAP storage.

Executable ``record``: ``ws/run evolution_manager record --bag DIR [--robots 9] [--namespace /swarm_a]``
records every topic of the trial graph (the simulator's and each footbot's, visualisation, odometry and
``/tf`` included; ``--no-frames`` leaves out each robot's ``odom``, ``/tf`` and ``/tf_static``) until SIGINT
or SIGTERM, then closes the bag so that it is whole. It prints a line once every topic has a matched
publisher: a trial started after that line is recorded from its first step. A recorder killed with SIGKILL
leaves the chunks already flushed, which ``recover`` brings back. Latched topics (``trial_start``,
``markers``, ``/tf_static``) are subscribed transient-local, so the recorder also gets their last message
from before it joined.

Messages are stamped in the bag with their header stamp (simulated time), so a replay follows the trial's own
clock. The ``GraphRecorder`` class is also used in-process by ``trial``.
"""

from __future__ import annotations

import argparse
import signal
import struct
import sys
import threading
from collections import Counter
from collections.abc import Callable, Collection, Sequence
from pathlib import Path

import rclpy
from geometry_msgs.msg import PoseArray, PoseStamped
from nav_msgs.msg import Odometry
from rclpy.experimental import EventsExecutor
from rclpy.node import Node
from rclpy.serialization import deserialize_message
from rclpy.signals import SignalHandlerOptions
from rosgraph_msgs.msg import Clock
from visualization_msgs.msg import MarkerArray

from evolution_manager.arguments import OneLineParser, int_in, without_ros_args
from evolution_manager.recording.bags import BagError, BagRecorder, check_new_bag, is_latched
from swarm_msgs.msg import (
    GroundSensor,
    RangeAndBearingReadings,
    SwarmState,
    TreeStatus,
    TrialStart,
    WheelCommand,
)
from swarm_ros.names import NamespaceError, check_topic, graph_namespace, robot_frames, robot_namespaces
from swarm_ros.qos import NO_SUBSCRIPTION_EVENTS, RECORDING, RECORDING_LATCHED
from swarm_sim.model import DEFAULT
from tf2_msgs.msg import TFMessage


def msgtype_name(msg_class: type) -> str:
    """The ROS 2 type name of a message class, e.g. ``swarm_msgs/msg/WheelCommand``."""
    module = msg_class.__module__.split(".")
    return f"{module[0]}/{module[1]}/{msg_class.__name__}"


def trial_topics(
    robots: int, namespace: str = "", clock: str = "/clock", frames: bool = True
) -> list[tuple[str, type]]:
    """Every topic of a trial graph with ``robots`` footbots under ``namespace`` (e.g. ``/swarm_a``; the root
    by default), as absolute names, with its message class. The simulator's clock is ``clock`` (``/clock``
    unless remapped: a graph in a namespace keeps it at the root). With ``frames`` (the default), also what a
    ROS user replays to see the robots' frames: ``/tf``, ``/tf_static`` (at the root, as tf2 expects; the
    frames are namespaced) and each robot's ``odom``."""
    prefix = namespace.rstrip("/")
    topics: list[tuple[str, type]] = [
        (clock, Clock),
        (f"{prefix}/trial_start", TrialStart),
        (f"{prefix}/markers", MarkerArray),
        (f"{prefix}/robot_markers", MarkerArray),
        (f"{prefix}/swarm_state", SwarmState),
        (f"{prefix}/poses", PoseArray),
    ]
    for robot in robot_namespaces(robots):
        ns = f"{prefix}/{robot}"
        topics += [
            (f"{ns}/ground", GroundSensor),
            (f"{ns}/range_and_bearing", RangeAndBearingReadings),
            (f"{ns}/pose", PoseStamped),
            (f"{ns}/wheels", WheelCommand),
            (f"{ns}/tree_status", TreeStatus),
        ]
        if frames:
            topics.append((f"{ns}/odom", Odometry))
    if frames:
        topics += [("/tf", TFMessage), ("/tf_static", TFMessage)]
    return topics


def graph_frames(robots: int, namespace: str = "") -> set[str]:
    """The frame ids the trial graph of ``robots`` footbots under ``namespace`` publishes on ``/tf`` and
    ``/tf_static`` (each robot's ``odom`` and ``base_link``, ``swarm_ros.names.robot_frames``)."""
    return {frame for pair in robot_frames(namespace, robot_namespaces(robots)) for frame in pair}


def cdr_stamp_ns(data: bytes, msg_class: type) -> int:
    """The time in nanoseconds of a message of ``msg_class`` serialized as CDR, read without deserializing it:
    its header stamp, the clock of a Clock message, or the first marker's (transform's) stamp of a MarkerArray
    (TFMessage; 0 for an empty one). Each of these is the message's first field (a MarkerArray's or a
    TFMessage's after its element count), so it lies at a fixed offset behind the 4-byte encapsulation
    header, whose second byte gives the byte order."""
    order = "<" if data[1] == 1 else ">"
    offset = 4
    if msg_class is MarkerArray or msg_class is TFMessage:
        (count,) = struct.unpack_from(f"{order}I", data, offset)
        if count == 0:
            return 0
        offset += 4
    seconds, nanoseconds = struct.unpack_from(f"{order}iI", data, offset)
    return seconds * 1_000_000_000 + nanoseconds


class GraphRecorder:
    """Subscribes to topics on ``node`` and writes every message to ``bag`` (thread-safe). With ``frames``
    (``graph_frames``), a ``tf2_msgs/TFMessage`` is written only when it moves one of those frames: ``/tf``
    and ``/tf_static`` are at the root, shared by every graph of the domain, and a bag keeps its own graph's
    (on its own clock)."""

    def __init__(
        self,
        node: Node,
        bag: BagRecorder,
        topics: Sequence[tuple[str, type]],
        *,
        armed: bool = True,
        frames: Collection[str] | None = None,
    ) -> None:
        self.bag = bag
        self.frames = None if frames is None else frozenset(frames)
        self.topics = list(topics)
        self.counts: Counter[str] = Counter()
        self.received: Counter[str] = Counter()  # written or not (before ``arm``)
        self.last_stamp = 0
        self.armed = armed
        self._lock = threading.Lock()
        self.subscriptions = [
            node.create_subscription(
                msg_class,
                topic,
                self._writer(topic, msg_class),
                RECORDING_LATCHED if is_latched(topic) else RECORDING,
                event_callbacks=NO_SUBSCRIPTION_EVENTS,
                raw=True,  # the serialized bytes go to the bag as they came
            )
            for topic, msg_class in self.topics
        ]

    def arm(self) -> None:
        """Write every message received from now on (a recorder made with ``armed=False`` drops the latched
        messages it receives on joining, which belong to an earlier trial)."""
        with self._lock:
            self.armed = True

    def _writer(self, topic: str, msg_class: type) -> Callable[[bytes], None]:
        msgtype = msgtype_name(msg_class)
        frames = self.frames if msg_class is TFMessage else None

        def write(data: bytes) -> None:
            if frames is not None and not any(
                t.child_frame_id in frames for t in deserialize_message(data, TFMessage).transforms
            ):
                return  # another graph's frames
            stamp = cdr_stamp_ns(data, msg_class)
            with self._lock:
                self.received[topic] += 1
                if not self.armed:
                    return
                self.bag.write_cdr(topic, msgtype, stamp, data)
                self.counts[topic] += 1
                self.last_stamp = max(self.last_stamp, stamp)

        return write

    def all_publishers_matched(self) -> bool:
        """Whether every subscription has matched at least one publisher."""
        return all(subscription.get_publisher_count() > 0 for subscription in self.subscriptions)


MAX_ROBOTS = 1000
"""The most robots ``record --robots`` takes: the subscriptions of a graph of more (six topics a robot) are
not a graph anyone runs, and a mistyped count must not make millions."""


def main(argv: Sequence[str] | None = None) -> int:
    """``record``: record a trial graph's topics until SIGINT or SIGTERM."""
    parser = OneLineParser(prog="record", description=__doc__.split("\n\n")[1])
    parser.add_argument("--bag", required=True, type=Path, help="new bag directory to write")
    parser.add_argument(
        "--robots",
        type=int_in(1, MAX_ROBOTS, "a number of robots"),
        default=DEFAULT.n_robots,
        help=f"footbots in the graph, 1 to {MAX_ROBOTS} (default {DEFAULT.n_robots})",
    )
    parser.add_argument(
        "--namespace", default="", help="the graph's namespace, e.g. /swarm_a (default: the root)"
    )
    parser.add_argument("--clock", default="/clock", help="the graph's clock topic (default /clock)")
    parser.add_argument(
        "--frames",
        action=argparse.BooleanOptionalAction,
        default=True,
        help="record each robot's odom, /tf and /tf_static (default); --no-frames leaves them out",
    )
    args = parser.parse_args(without_ros_args(sys.argv[1:] if argv is None else argv))
    try:  # before the node starts: a name ROS refuses, a bag that cannot be new
        namespace = graph_namespace(args.namespace)
        check_topic(args.clock, "--clock")
        check_new_bag(args.bag)
    except (NamespaceError, BagError) as error:
        print(f"record: {error}", file=sys.stderr)
        return 2
    stop = threading.Event()
    for sig in (signal.SIGINT, signal.SIGTERM):
        signal.signal(sig, lambda *_: stop.set())
    context = rclpy.Context()
    rclpy.init(context=context, signal_handler_options=SignalHandlerOptions.NO)
    try:
        with BagRecorder(args.bag) as bag:
            node = Node("recorder", context=context)
            executor = EventsExecutor(context=context)  # a third less CPU a message (trial.TrialRunner)
            executor.add_node(node)
            recorder = GraphRecorder(
                node,
                bag,
                trial_topics(args.robots, namespace, args.clock, args.frames),
                frames=graph_frames(args.robots, namespace),
            )
            print(f"recording to {args.bag}; stop with Ctrl-C", flush=True)
            node.get_logger().info(f"ready: recording {namespace or '/'} to {args.bag}")
            matched = False
            while not stop.is_set():
                executor.spin_once(timeout_sec=0.1)
                if not matched and recorder.all_publishers_matched():
                    # Discovery takes a moment: a trial started before this line may lose its first steps.
                    matched = True
                    print(f"matched a publisher on all {len(recorder.topics)} topics", flush=True)
            executor.shutdown()
            node.destroy_node()
        print(f"recorded {bag.count} messages to {args.bag}", flush=True)
    except BagError as error:
        print(f"record: {error}", file=sys.stderr)
        return 2
    finally:
        rclpy.try_shutdown(context=context)
    return 0
