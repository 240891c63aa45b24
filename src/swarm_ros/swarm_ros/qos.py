"""Quality of service of the graph's topics, named once."""

from __future__ import annotations

from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy

RELIABLE = QoSProfile(depth=100, reliability=ReliabilityPolicy.RELIABLE)
"""Every lockstep topic: no message may be lost, and a step's messages can queue while a node is busy."""

LATCHED = QoSProfile(
    depth=1, reliability=ReliabilityPolicy.RELIABLE, durability=DurabilityPolicy.TRANSIENT_LOCAL
)
"""Topics a late joiner must still see (the trial's start, the arena markers): the last message is kept."""

RECORDING = QoSProfile(depth=1000, reliability=ReliabilityPolicy.RELIABLE)
"""A recorder's subscriptions: deep, so that a burst is never dropped while the bag writes."""

RECORDING_LATCHED = QoSProfile(
    depth=1000, reliability=ReliabilityPolicy.RELIABLE, durability=DurabilityPolicy.TRANSIENT_LOCAL
)
"""A recorder's subscriptions to latched topics: it receives what was published before it joined."""
