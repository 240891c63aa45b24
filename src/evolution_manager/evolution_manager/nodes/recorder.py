"""Record the topics of a trial graph to a rosbag2 bag with MCAP storage.

Executable ``record``: ``ws/run evolution_manager record --bag DIR [--robots 9]`` records every topic of the
trial graph (the simulator's and each footbot's) until SIGINT or SIGTERM, then closes the bag so that it is
whole. A recorder killed with SIGKILL leaves the chunks already flushed, which ``recover`` brings back.

Messages are stamped in the bag with their header stamp (simulated time), so a replay follows the trial's own
clock. The ``GraphRecorder`` class is also used in-process by ``trial``.
"""

from __future__ import annotations

import argparse
import signal
import sys
import threading
from collections import Counter
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

import rclpy
from geometry_msgs.msg import PoseArray
from rclpy.executors import SingleThreadedExecutor
from rclpy.node import Node
from rclpy.qos import QoSProfile, ReliabilityPolicy
from rclpy.serialization import serialize_message
from rclpy.signals import SignalHandlerOptions
from rosgraph_msgs.msg import Clock

from evolution_manager.bags import BagError, BagRecorder
from swarm_msgs.msg import (
    GroundSensor,
    RangeAndBearingReadings,
    SwarmState,
    TreeStatus,
    TrialStart,
    WheelCommand,
)

RELIABLE = QoSProfile(depth=1000, reliability=ReliabilityPolicy.RELIABLE)


def msgtype_name(msg_class: type) -> str:
    """The ROS 2 type name of a message class, e.g. ``swarm_msgs/msg/WheelCommand``."""
    module = msg_class.__module__.split(".")
    return f"{module[0]}/{module[1]}/{msg_class.__name__}"


def trial_topics(robots: int) -> list[tuple[str, type]]:
    """Every topic of a trial graph with ``robots`` footbots, with its message class."""
    topics: list[tuple[str, type]] = [
        ("/clock", Clock),
        ("/trial_start", TrialStart),
        ("/swarm_state", SwarmState),
        ("/poses", PoseArray),
    ]
    for i in range(robots):
        topics += [
            (f"/footbot_{i}/ground", GroundSensor),
            (f"/footbot_{i}/range_and_bearing", RangeAndBearingReadings),
            (f"/footbot_{i}/wheels", WheelCommand),
            (f"/footbot_{i}/tree_status", TreeStatus),
        ]
    return topics


def stamp_ns(msg: Any) -> int:  # any stamped ROS message (generated, untyped)
    """A message's time in nanoseconds: its header stamp, or the clock of a Clock message."""
    stamp = msg.clock if isinstance(msg, Clock) else msg.header.stamp
    return stamp.sec * 1_000_000_000 + stamp.nanosec


class GraphRecorder:
    """Subscribes to topics on ``node`` and writes every message to ``bag`` (thread-safe)."""

    def __init__(self, node: Node, bag: BagRecorder, topics: Sequence[tuple[str, type]]) -> None:
        self.bag = bag
        self.topics = list(topics)
        self.counts: Counter[str] = Counter()
        self.last_stamp = 0
        self._lock = threading.Lock()
        for topic, msg_class in self.topics:
            node.create_subscription(msg_class, topic, self._writer(topic, msg_class), RELIABLE)

    def _writer(self, topic: str, msg_class: type) -> Callable[[object], None]:
        msgtype = msgtype_name(msg_class)

        def write(msg: object) -> None:
            data = serialize_message(msg)
            stamp = stamp_ns(msg)
            with self._lock:
                self.bag.write_cdr(topic, msgtype, stamp, data)
                self.counts[topic] += 1
                self.last_stamp = max(self.last_stamp, stamp)

        return write

    def all_publishers_seen(self, node: Node) -> bool:
        """Whether every recorded topic has at least one publisher in the graph."""
        return all(node.count_publishers(topic) > 0 for topic, _ in self.topics)


def main(argv: Sequence[str] | None = None) -> int:
    """``record``: record a trial graph's topics until SIGINT or SIGTERM."""
    parser = argparse.ArgumentParser(prog="record", description=__doc__.split("\n\n")[1])
    parser.add_argument("--bag", required=True, type=Path, help="new bag directory to write")
    parser.add_argument("--robots", type=int, default=9, help="footbots in the graph (default 9)")
    args = parser.parse_args(rclpy.utilities.remove_ros_args(list(sys.argv[1:] if argv is None else argv)))
    stop = threading.Event()
    for sig in (signal.SIGINT, signal.SIGTERM):
        signal.signal(sig, lambda *_: stop.set())
    context = rclpy.Context()
    rclpy.init(context=context, signal_handler_options=SignalHandlerOptions.NO)
    try:
        with BagRecorder(args.bag) as bag:
            node = Node("recorder", context=context)
            executor = SingleThreadedExecutor(context=context)
            executor.add_node(node)
            GraphRecorder(node, bag, trial_topics(args.robots))
            print(f"recording to {args.bag}; stop with Ctrl-C", flush=True)
            while not stop.is_set():
                executor.spin_once(timeout_sec=0.1)
            executor.shutdown()
            node.destroy_node()
        print(f"recorded {bag.count} messages to {args.bag}", flush=True)
    except BagError as error:
        print(f"record: {error}", file=sys.stderr)
        return 2
    finally:
        rclpy.try_shutdown(context=context)
    return 0
