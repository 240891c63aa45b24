"""Quality of service of the graph's topics, named once."""

from __future__ import annotations

from rclpy.event_handler import PublisherEventCallbacks, SubscriptionEventCallbacks
from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy

RELIABLE = QoSProfile(depth=1000, reliability=ReliabilityPolicy.RELIABLE)
"""Every lockstep topic: no message may be lost, and a step's messages can queue while a node is busy. Deep
because a reliable keep-last writer forgets its oldest unacknowledged sample when its history is full: a
recorder starved of CPU on a loaded machine trailed the lockstep by more than 100 steps and lost messages."""

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

# rclpy gives every publisher and subscription two event handlers by default (incompatible QoS, incompatible
# type), and its executors walk a node's handlers on every wake-up with a list-membership test for each: a
# quadratic cost that was most of the simulator's CPU time with its 34 publishers and 18 subscriptions (a
# trial through the graph ran 2.4 times faster without them). The nodes with many topics (the simulator,
# recorders, replay) pass these; the footbot controllers at the other end keep their handlers and still
# report a mismatch.
NO_PUBLISHER_EVENTS = PublisherEventCallbacks(use_default_callbacks=False)
"""Publisher event callbacks with no handler at all (see above)."""

NO_SUBSCRIPTION_EVENTS = SubscriptionEventCallbacks(use_default_callbacks=False)
"""Subscription event callbacks with no handler at all (see above)."""
