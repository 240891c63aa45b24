"""Check that a recorded trial reproduces: re-run it from its seed and compare it with the recording.

A trial's bag (``trial --bag``) begins with ``/trial_start`` (seed, trial index and the trial's length in
ticks) and ends with ``/trial_result`` (the tree, with any primitives written out, or for a heterogeneous
swarm the JSON list of the robots' trees, ``swarm_sim.model.swarm_layout.SwarmLayout.label``; the model's
profile and every value); ``/swarm_state`` holds the exact poses, and each robot's carrying flag and
deliveries, of every step of the trial's chain up to the trial (the earlier trials of the chain are run, and
recorded, first). A graph run under a namespace (``/swarm_a/trial_start``, ...) is read the same way. The
trial is re-run in-process exactly as the node graph runs it
(``swarm_sim.roads.lockstep.run_with_controllers``), under the recorded profile and trial length, and every
recorded pose, carrying flag, delivery count and value is compared with the re-run's, bit for bit (a bag
recorded before foraging has none of these to compare). A heterogeneous swarm's trial is re-run with each
robot's own tree.

Then every other topic the re-run produces is compared byte for byte with the recording: the messages the
simulator and the controllers publish are built by their own code (``swarm_sim.nodes.simulator.step_messages``
and ``trial_start_message``, ``bt_controller.nodes.footbot_controller.answer_messages``, the arena's markers)
from the re-run, and compared field by field with the recorded ones (CDR padding bytes are not part of a
message); the clock's stamps start at the recording's first and advance one step at a time. Each robot's
``odom``, ``/tf`` and ``/tf_static`` are compared too where the bag has them (``simulator.frame_messages``
and ``static_frames``). The readings, ``wheels`` and ``tree_status`` name a robot by its frame
``<graph namespace>/footbot_<i>/base_link``; a bag whose readings name it ``footbot_<i>`` (recorded before
robot frames were namespaced) is re-run with those names. The MCAP files' CRCs are checked first
(``recording.bags.check_crcs``). The verdict names the topics compared, and those of the bag the re-run
does not produce.
"""

from __future__ import annotations

import json
from collections.abc import Sequence
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any

from bt_controller.errors import TreeError
from bt_controller.interpreters import Network, parse_controller
from bt_controller.language import ACTIONS, Node
from bt_controller.model_settings import PROFILES
from evolution_manager.recording.bags import BagError, check_crcs, read_bag
from swarm_ros.names import robot_frames, robot_namespaces
from swarm_sim.evaluation import named_values
from swarm_sim.model import (
    DEFAULT,
    VALUE_NAMES,
    Config,
    LayoutError,
    config_from_dict,
    default_config,
    layout_of_label,
)
from swarm_sim.roads import LockstepChain, run_with_controllers

RESULT_TOPIC = "/trial_result"
"""Topic of a trial bag's last message: its tree, seed and values (swarm_msgs/EvaluationResult)."""


@dataclass(frozen=True)
class Verification:
    """The outcome of re-running a recorded trial."""

    tree: str
    seed: int
    trial: int
    steps_compared: int
    first_divergence: str | None
    """None when the re-run reproduced the recording; else what first differed."""
    topics_compared: tuple[str, ...] = ()
    """The bag's topics compared with the re-run (every message of each)."""
    topics_not_compared: tuple[str, ...] = ()
    """The bag's topics the re-run does not produce."""
    crcs_checked: int = 0
    """CRCs of the bag's MCAP files checked (0: a bag written without them)."""

    @property
    def reproduced(self) -> bool:
        return self.first_divergence is None

    def summary(self) -> str:
        what = f"trial {self.trial} of seed {self.seed} with {self.tree}"
        compared = (
            f"{len(self.topics_compared)} topics compared ({', '.join(self.topics_compared)})"
            + (
                f"; not produced by the re-run: {', '.join(self.topics_not_compared)}"
                if self.topics_not_compared
                else ""
            )
            + (
                f"; {self.crcs_checked} MCAP CRCs checked"
                if self.crcs_checked
                else "; the bag has no MCAP CRCs"
            )
        )
        if self.reproduced:
            return (
                f"reproduced: {what}: {self.steps_compared} steps of poses and every value identical, and "
                f"every message of {compared}"
            )
        return f"NOT reproduced: {what}: {self.first_divergence}; {compared}"


def recorded_world(start: Any, profile: str) -> Config:
    """The world a trial bag's ``/trial_start`` says its trial ran in: its ``world`` (every model parameter:
    the task's world, the profile, any conditions) or, in bags recorded before it, the model under
    ``profile`` with the recorded trial length (before tasks: the primitives' trials)."""
    text = getattr(start, "world", "")
    if not text:
        return replace(default_config(profile), ticks=int(getattr(start, "ticks", 0) or DEFAULT.ticks))
    try:
        return config_from_dict(json.loads(text))
    except (ValueError, TypeError) as error:  # not JSON, or not a world the model can run
        raise BagError(f"the recorded world (/trial_start) cannot be rebuilt: {error}") from None


def verify_trial_bag(path: Path | str) -> Verification:
    """Re-run the trial recorded in the bag at ``path`` and compare it with the recording: every topic the
    re-run produces, after the MCAP files' CRCs."""
    crcs = check_crcs(path)
    starts, results, states = [], [], []
    by_topic: dict[str, list[bytes]] = {}
    prefix = ""
    reading_frames: dict[str, str] = {}  # the first ground reading's frame, by topic
    for message in read_bag(path):
        by_topic.setdefault(message.topic, []).append(message.data)
        name = "/" + message.topic.rsplit("/", 1)[-1]  # the topic's name below the graph's namespace
        if name == "/ground":
            reading_frames.setdefault(message.topic, message.message.header.frame_id)
        if name == "/trial_start":
            starts.append(message.message)
            prefix = message.topic[: -len(name)]
        elif name == RESULT_TOPIC:
            results.append(message.message)
        elif name == "/swarm_state":
            states.append(message.message)
    if len(starts) != 1 or len(results) != 1:
        raise BagError(
            f"{path} is not the bag of one recorded trial: it has {len(starts)} /trial_start and "
            f"{len(results)} {RESULT_TOPIC} messages (expected one of each; record with `trial --bag`)"
        )
    start, result = starts[0], results[0]
    try:
        if result.tree.lstrip().startswith("["):  # a heterogeneous swarm: each robot re-runs its own tree
            tree: Node | Network | list[Node | Network] = layout_of_label(
                result.tree, DEFAULT.n_robots
            ).parsed()
        else:
            tree = parse_controller(result.tree)
    except (TreeError, LayoutError) as error:
        raise BagError(f"the recorded tree does not parse: {error}") from None
    seed, trial = int(start.seed), int(start.trial)
    profile = getattr(result, "profile", "") or DEFAULT.profile  # bags recorded before profiles: the default
    if profile not in PROFILES:
        raise BagError(f"the recorded profile {profile!r} is not one of {', '.join(PROFILES)}")

    recorded = {state.step: [(p.x, p.y, p.theta) for p in state.poses] for state in states}
    cargo = {
        state.step: (list(state.carrying), list(state.deliveries))
        for state in states
        if len(getattr(state, "carrying", ()))  # bags before foraging, and a chain's first step: none
    }
    divergences: list[str] = []
    visited: list[int] = []

    def compare(world: LockstepChain) -> None:
        visited.append(world.step)
        poses = [tuple(p) for p in world.poses().tolist()]
        if not divergences and recorded.get(world.step) != poses:
            divergences.append(f"the poses differ at step {world.step}")
        carried = ([bool(row.any()) for row in world.carrying], [int(row.sum()) for row in world.deliveries])
        if not divergences and world.step in cargo and cargo[world.step] != carried:
            divergences.append(f"the carrying flags or deliveries differ at step {world.step}")

    config = recorded_world(start, profile)
    first = states[0].header.stamp if states else None
    robots = int(start.robots) or config.n_robots
    published = _Published(
        prefix, robots, config, seed, trial, first, bare_frames(reading_frames, prefix, robots)
    )

    def on_step(world: LockstepChain) -> None:
        compare(world)
        published.step(world)

    record = run_with_controllers(tree, seed, trial, config, on_step=on_step, on_outcomes=published.answers)
    if not divergences and sorted(recorded) != visited:
        divergences.append(f"/swarm_state has {len(recorded)} steps; the trial has {len(visited)}")
    try:
        recorded_values = named_values(result)  # bags recorded before the six primitives: the paper's values
    except ValueError as error:
        raise BagError(f"{RESULT_TOPIC}: {error}") from None
    for name, value in zip(VALUE_NAMES, record.values, strict=True):
        kept = recorded_values.get(name)
        if not divergences and kept is not None and kept != value:
            divergences.append(f"{name} was {kept!r}, the re-run gives {value!r}")
    # rclpy: the recording wing is ROS-free; only replaying through the nodes loads ROS
    from rclpy.serialization import deserialize_message

    compared, other = [], []
    for topic in sorted(by_topic):
        if topic == prefix + RESULT_TOPIC:  # the values, compared above
            compared.append(topic)
            continue
        expected = published.messages.get(topic)
        if expected is None:
            other.append(topic)
            continue
        compared.append(topic)
        found = by_topic[topic]
        # latched: the last one is the trial's (an earlier one, the simulator's start, or the regions of an
        # earlier trial of the chain)
        if topic in (prefix + "/markers", "/tf_static"):
            found, expected = found[-1:], expected[-1:]
        if divergences:
            continue
        if len(found) != len(expected):
            divergences.append(f"{topic} has {len(found)} messages; the re-run publishes {len(expected)}")
            continue
        for k, (was, now) in enumerate(zip(found, expected, strict=True)):
            if deserialize_message(was, type(now)) != now:  # every field, bit for bit
                divergences.append(f"{topic} differs from the re-run at its message {k + 1} of {len(found)}")
                break
    return Verification(
        result.tree,
        seed,
        trial,
        len(recorded),
        divergences[0] if divergences else None,
        tuple(compared),
        tuple(other),
        crcs,
    )


def bare_frames(reading_frames: dict[str, str], prefix: str, robots: int) -> bool:
    """Whether a bag's readings (``reading_frames``: the first ground reading's frame id by topic) name each
    robot by its bare namespace ``footbot_<i>``, as bags recorded before robot frames were namespaced do."""
    return any(reading_frames.get(f"{prefix}/{ns}/ground") == ns for ns in robot_namespaces(robots))


class _Published:
    """What the trial graph publishes, built from a re-run by the nodes' own code (rclpy messages, compared
    field by field with the recording's, deserialised), by absolute topic. ``bare``: the readings name each
    robot by its bare namespace (``bare_frames``)."""

    def __init__(
        self,
        prefix: str,
        robots: int,
        config: Config,
        seed: int,
        trial: int,
        first_stamp: Any,
        bare: bool = False,
    ) -> None:

        self.prefix = prefix
        self.namespaces = robot_namespaces(robots)
        self.frames = robot_frames(prefix, self.namespaces)
        self.reading_frames = list(self.namespaces) if bare else [base for _, base in self.frames]
        self.previous: Any = None  # the step before's poses, for odometry
        self.config = config
        self.seed = seed
        self.trial = trial
        self.base_ns = 0 if first_stamp is None else first_stamp.sec * 1_000_000_000 + first_stamp.nanosec
        self.step_ns = round(config.step_dt * 1e9)
        self.index = 0
        self.actions = ["stop"] * robots
        self.headers: list[Any] = []
        self.messages: dict[str, list[Any]] = {}

    def _add(self, topic: str, message: Any) -> None:
        # rclpy: the recording wing is ROS-free; only replaying through the nodes loads ROS
        from rclpy.serialization import deserialize_message, serialize_message

        # through CDR and back, as a subscriber sees it: float32 fields rounded as on the wire
        self.messages.setdefault(topic, []).append(
            deserialize_message(serialize_message(message), type(message))
        )

    def step(self, world: LockstepChain) -> None:
        # rclpy: the recording wing is ROS-free; only replaying through the nodes loads ROS
        from builtin_interfaces.msg import Time
        from rosgraph_msgs.msg import Clock

        # the nodes' modules load rclpy too
        from swarm_sim.nodes import visualisation
        from swarm_sim.nodes.simulator import (
            frame_messages,
            regions_change,
            static_frames,
            step_messages,
            trial_start_message,
        )

        at = self.base_ns + self.index * self.step_ns
        stamp = Time(sec=at // 1_000_000_000, nanosec=at % 1_000_000_000)
        p = self.prefix
        if self.index == 0:  # the trial's start: its markers and its latched announcement
            self.wheel_speed = world.p.wheel_speed * visualisation.MM
            self._add(f"{p}/markers", visualisation.arena_markers(self.config, world.trial, stamp))
            start = trial_start_message(
                world, stamp, self.seed, self.trial, len(self.namespaces), self.config
            )
            self._add(f"{p}/trial_start", start)
            self._add("/tf_static", static_frames(stamp, self.frames))
        elif regions_change(world):  # a later trial of the chain on other regions: their markers
            self._add(f"{p}/markers", visualisation.arena_markers(self.config, world.trial, stamp))
        self.index += 1
        self._add("/clock", Clock(clock=stamp))
        messages = step_messages(
            world, stamp, self.seed, self.namespaces, self.actions, self.config, self.reading_frames
        )
        odometry, transforms, self.previous = frame_messages(
            world, stamp, self.previous, self.frames, self.config.step_dt
        )
        self._add("/tf", transforms)
        for ns, odom in zip(self.namespaces, odometry, strict=True):
            self._add(f"{p}/{ns}/odom", odom)
        self._add(f"{p}/swarm_state", messages.state)
        self._add(f"{p}/poses", messages.poses)
        self._add(f"{p}/robot_markers", messages.robot_markers)
        for ns, pose, ground, readings in zip(
            self.namespaces, messages.pose, messages.ground, messages.readings, strict=True
        ):
            self._add(f"{p}/{ns}/pose", pose)
            self._add(f"{p}/{ns}/ground", ground)
            self._add(f"{p}/{ns}/range_and_bearing", readings)
        self.headers = [ground.header for ground in messages.ground]

    def answers(self, world: LockstepChain, outcomes: Sequence[Any]) -> None:
        # rclpy: the recording wing is ROS-free; only replaying through the nodes loads ROS
        from bt_controller.nodes.footbot_controller import answer_messages

        for i, (ns, outcome) in enumerate(zip(self.namespaces, outcomes, strict=True)):
            status, wheels = answer_messages(outcome, self.headers[i], i, self.wheel_speed)
            if status is not None:
                self._add(f"{self.prefix}/{ns}/tree_status", status)
            self._add(f"{self.prefix}/{ns}/wheels", wheels)
        self.actions = [ACTIONS[int(o.action)] for o in outcomes]
