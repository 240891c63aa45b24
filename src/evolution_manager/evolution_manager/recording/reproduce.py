"""Check that a recorded trial reproduces: re-run it from its seed and compare it with the recording.

A trial's bag (``trial --bag``) begins with ``/trial_start`` (seed, trial index and the trial's length in
ticks) and ends with ``/trial_result`` (the tree, with any primitives written out, or for a heterogeneous
swarm the JSON list of the robots' trees, ``swarm_sim.swarm_layout.SwarmLayout.label``; the model's profile
and every value); ``/swarm_state`` holds the exact poses, and each robot's carrying flag and deliveries, of
every step of the trial's chain up to the trial (the earlier trials of the chain are run, and recorded,
first). A graph run under a namespace (``/swarm_a/trial_start``, ...) is read the same way. The trial is
re-run in-process exactly as the node graph runs it (``swarm_sim.lockstep.run_with_controllers``), under the
recorded profile and trial length, and every recorded pose, carrying flag, delivery count and value is
compared with the re-run's, bit for bit (a bag recorded before foraging has none of these to compare). A
heterogeneous swarm's trial is re-run with each robot's own tree.
"""

from __future__ import annotations

import json
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any

from bt_controller.errors import TreeError
from bt_controller.timeline import PROFILES
from bt_controller.tree import Node, parse
from evolution_manager.recording.bags import BagError, read_bag
from swarm_sim.config import DEFAULT, Config, config_from_dict, default_config
from swarm_sim.lockstep import LockstepChain, run_with_controllers
from swarm_sim.result_messages import named_values
from swarm_sim.swarm_layout import LayoutError, layout_of_label
from swarm_sim.trial_data import VALUE_NAMES

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

    @property
    def reproduced(self) -> bool:
        return self.first_divergence is None

    def summary(self) -> str:
        what = f"trial {self.trial} of seed {self.seed} with {self.tree}"
        if self.reproduced:
            return f"reproduced: {what}: {self.steps_compared} steps of poses and every value identical"
        return f"NOT reproduced: {what}: {self.first_divergence}"


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
    """Re-run the trial recorded in the bag at ``path`` and compare it with the recording."""
    starts, results, states = [], [], []
    for message in read_bag(path):
        name = "/" + message.topic.rsplit("/", 1)[-1]  # the topic's name below the graph's namespace
        if name == "/trial_start":
            starts.append(message.message)
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
            tree: Node | list[Node] = layout_of_label(result.tree, DEFAULT.n_robots).parsed()
        else:
            tree = parse(result.tree)
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
        carried = ([bool(c) for c in world.carrying], [int(d) for d in world.deliveries])
        if not divergences and world.step in cargo and cargo[world.step] != carried:
            divergences.append(f"the carrying flags or deliveries differ at step {world.step}")

    config = recorded_world(start, profile)
    record = run_with_controllers(tree, seed, trial, config, on_step=compare)
    if not divergences and sorted(recorded) != visited:
        divergences.append(f"/swarm_state has {len(recorded)} steps; the trial has {len(visited)}")
    try:
        recorded_values = named_values(result)  # bags recorded before the six primitives: the paper's values
    except ValueError as error:
        raise BagError(f"{RESULT_TOPIC}: {error}") from None
    for name, value in zip(VALUE_NAMES, record.values, strict=True):
        was = recorded_values.get(name)
        if not divergences and was is not None and was != value:
            divergences.append(f"{name} was {was!r}, the re-run gives {value!r}")
    return Verification(result.tree, seed, trial, len(recorded), divergences[0] if divergences else None)
