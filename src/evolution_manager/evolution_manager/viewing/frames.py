"""A trial as frames (poses, actions, messages, fitness so far), from a tree or from a bag.

``frames_from_tree`` runs the trial in-process through the compiled kernels, recorded step by step
(``swarm_sim.roads.recording``, equal frame for frame to the node graph's trial); ``frames_from_bag`` reads a
trial bag written by ``trial --bag`` (or the main job's ``best_trial.bag``). Both give a ``TrialFrames``:
**one frame per sensing step** (8 a second), holding the poses the simulator published on ``/swarm_state`` at
that step, the action driving each robot's wheels after it, the messages heard at it, whether each robot
carries food and its deliveries after it, the last tick and the fitness so far (each objective scored with the
values of that step as if the trial ended there; undefined before the initial values are taken). No ROS here:
bags are read with ``evolution_manager.recording.bags``.
"""

from __future__ import annotations

import json
import math
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from bt_controller.interpreters import N_COUNTS
from bt_controller.robot import timeline
from evolution_manager.errors import AnimationError
from swarm_sim.core import world
from swarm_sim.model import DEFAULT, N_PROBES, Piece
from swarm_sim.roads import record_trial

if TYPE_CHECKING:
    from bt_controller.language import Library
    from swarm_sim.model import Config, Params, SwarmLayout


@dataclass(frozen=True)
class TrialFrames:
    """One trial, frame by frame (one frame per sensing step)."""

    tree: str
    seed: int
    trial: int
    gap: float
    arena_half: float
    nest_radius: float
    robot_radius: float
    steps: np.ndarray
    """(T,) sensing step of each frame."""
    poses: np.ndarray
    """(T, n, 3): x, y (mm) and heading (rad) of every robot, as published on /swarm_state."""
    actions: np.ndarray
    """(T, n): the action driving each robot's wheels after this step (index into ACTIONS; -1: not yet
    ticked, standing still)."""
    ticks: np.ndarray
    """(T,): the last tick at or before this step (-1 before the first)."""
    links: tuple[np.ndarray, ...]
    """Per frame, (k, 2) int: (receiver, sender) of every message heard at this step."""
    fitness: np.ndarray
    """(T, ``world.N_OBJECTIVES``): every objective so far (NaN before the initial values)."""
    carrying: np.ndarray
    """(T, n, kinds) bool: whether each robot carries food of each kind after this step (its answer)."""
    deliveries: np.ndarray
    """(T, n, kinds) int: each robot's deliveries of each kind in the trial after this step."""
    trees: tuple[str, ...] = ()
    """Each robot's tree text, robot 0 first (a heterogeneous swarm's differ; empty: not known)."""
    regions: tuple[Piece, ...] = ()
    """The trial's regions (``Config.arena_entry``) when they are not the papers' arena (``gap`` is then
    NaN); empty for the papers' arena, drawn from ``gap`` and ``nest_radius``."""
    faulty: np.ndarray | None = None
    """(T, n) bool: whether each robot is faulty at this step (a bag with ``/faults``; None: not known)."""
    swapped: np.ndarray | None = None
    """(T, n) bool: whether each robot runs a tree a live adaptation swapped in (a bag with
    ``/adaptation``; None: not known)."""
    notes: tuple[str, ...] = ()
    """Per frame, the live adaptation's last events as lines (empty: none)."""
    objective: str = ""
    """The objective a live adaptation measured (its panel shows it; empty: none)."""

    @property
    def n_robots(self) -> int:
        return int(self.poses.shape[1])

    @property
    def heterogeneous(self) -> bool:
        """Whether the robots ran different trees."""
        return len(set(self.trees)) > 1

    def to_json(self) -> dict:
        """A compact JSON form (poses in whole mm and centiradians) for the repertoire explorer."""
        return {
            "tree": self.tree,
            "seed": self.seed,
            "trial": self.trial,
            "gap": None if math.isnan(self.gap) else self.gap,
            "arena_half": self.arena_half,
            "nest_radius": self.nest_radius,
            "robot_radius": self.robot_radius,
            "steps": [int(s) for s in self.steps],
            "x": np.rint(self.poses[:, :, 0]).astype(int).tolist(),
            "y": np.rint(self.poses[:, :, 1]).astype(int).tolist(),
            "h": np.rint(self.poses[:, :, 2] * 100).astype(int).tolist(),
            "actions": self.actions.astype(int).tolist(),
            "ticks": [int(t) for t in self.ticks],
            "links": [[int(v) for v in pair] for frame in self.links for pair in [frame.ravel()]],
            "fitness": [[None if math.isnan(v) else round(float(v), 4) for v in row] for row in self.fitness],
            "carrying": self.carrying.any(axis=2).astype(int).tolist(),
            "deliveries": self.deliveries.sum(axis=2).astype(int).tolist(),
            **({"trees": list(self.trees)} if self.heterogeneous else {}),
            **({"regions": [piece._asdict() for piece in self.regions]} if self.regions else {}),
        }


def arena_fields(config: Config, trial: int) -> dict[str, Any]:
    """The arena of ``trial`` as ``TrialFrames`` draws it: the gap between nest and food, the arena's and the
    nest's size and the robots' radius (mm), and the trial's regions when they are a layout of the task's
    own."""
    return {
        "gap": config.gap(trial),
        "arena_half": config.arena_half,
        "nest_radius": config.nest_radius,
        "robot_radius": config.robot_radius,
        "regions": config.arena_entry(trial) if config.layout else (),
    }


def _fitness_so_far(
    initial: np.ndarray,
    current: np.ndarray,
    probes: np.ndarray,
    deliveries: np.ndarray,
    food_scale: float,
    p: Params,
) -> np.ndarray:
    """Every objective as if the trial ended now: from the smoothed values, the probes at the trial's first
    step and now (``probes``, n x 2 x ``N_PROBES``: ``world.take_probes``) and the deliveries so far."""
    n = initial.shape[0]
    counts, motion = np.zeros((n, N_COUNTS), np.int64), np.zeros((n, 2), np.int64)
    values = world.trial_values(initial, current, counts, motion, probes, deliveries, food_scale, p)
    return values[: world.N_OBJECTIVES]


def frames_from_tree(
    tree: str | SwarmLayout,
    seed: int,
    trial: int = 0,
    config: Config | None = None,
    library: Library | None = None,
) -> TrialFrames:
    """Run trial ``trial`` of ``seed`` with ``tree`` on every robot (or a swarm layout's tree on each robot)
    through the compiled kernels, recorded
    step by step (``swarm_sim.roads.recording``: the same frames as the node graph and the reference road
    give, tested frame for frame); its chain's earlier trials run first, the frames are trial ``trial``'s
    steps. ``library``: the primitive library the tree's names come from."""
    config = config or DEFAULT
    recorded = record_trial(tree, seed, trial, config, library)
    return TrialFrames(
        tree=recorded.tree,
        seed=seed,
        trial=trial,
        **arena_fields(config, trial),
        steps=recorded.steps,
        poses=recorded.poses,
        actions=recorded.actions,
        ticks=recorded.ticks,
        links=tuple(recorded.links),
        fitness=recorded.fitness,
        carrying=recorded.carrying,
        deliveries=recorded.deliveries,
        trees=recorded.trees,
    )


def _links_shape(links: np.ndarray) -> np.ndarray:
    """(k, 2) links sorted by receiver, then sender (a bag holds them in arrival order)."""
    if not links.size:
        return np.zeros((0, 2), np.int64)
    pairs = links.reshape(-1, 2)
    return pairs[np.lexsort((pairs[:, 1], pairs[:, 0]))]


def frames_from_bag(path: Path | str) -> TrialFrames:
    """The frames of the trial recorded in the bag at ``path`` (``trial --bag``): trial K's steps only (the
    bag also holds the earlier trials of K's chain, run first), as ``frames_from_tree`` draws them."""
    # late: reading bags loads rosbags and mcap (about 0.1 s), only for a bag's frames
    from evolution_manager.recording.bags import BagError, check_crcs, read_bag
    from evolution_manager.recording.reproduce import RESULT_TOPIC, recorded_world

    try:
        check_crcs(path)  # a changed byte is refused, never drawn (as replay and replay --verify refuse it)
        messages = list(read_bag(path))
    except BagError as error:
        raise AnimationError(str(error)) from None
    start = next((m.message for m in messages if m.topic == "/trial_start"), None)
    if start is None:
        raise AnimationError(f"{path} holds no /trial_start: not a trial bag (record one with `trial --bag`)")
    result = next((m.message for m in messages if m.topic == RESULT_TOPIC), None)
    profile = getattr(result, "profile", "") or DEFAULT.profile  # bags recorded before profiles: the default
    try:
        config = recorded_world(start, profile)
    except BagError as error:
        raise AnimationError(str(error)) from None
    trial = int(start.trial)
    states = {
        m.message.step: m.message
        for m in messages
        if m.topic == "/swarm_state" and int(m.message.trial) == trial
    }
    if not states:
        raise AnimationError(f"{path} holds no /swarm_state messages: nothing to animate")
    n = int(start.robots)
    kinds = config.food_kinds
    steps = sorted(states)
    index = {s: k for k, s in enumerate(steps)}
    poses = np.array([[[q.x, q.y, q.theta] for q in states[s].poses] for s in steps], dtype=np.float64)
    wheels = np.full((len(steps), n), -1, dtype=np.int64)
    smoothed = np.full((len(steps), n, kinds + 2), np.nan)
    carrying = np.zeros((len(steps), n, kinds), dtype=np.bool_)
    deliveries = np.zeros((len(steps), n, kinds), dtype=np.int64)
    heard: list[list[tuple[int, int]]] = [[] for _ in steps]
    tick_at: dict[int, int] = {}
    for m in messages:
        parts = m.topic.split("/")
        if len(parts) != 3 or not parts[1].startswith("footbot_"):
            continue
        robot, kind, msg = int(parts[1].split("_")[1]), parts[2], m.message
        if kind == "tree_status":
            tick_at[int(msg.step)] = int(msg.tick)
            continue
        if kind not in ("wheels", "range_and_bearing"):  # e.g. pose (PoseStamped): no step
            continue
        k = index.get(int(msg.step))
        if k is None:
            continue
        if kind == "wheels":
            wheels[k, robot] = int(msg.action)  # the action's index (wheel speeds are in m/s since issue 13)
            # (bags before foraging have no carrying and deliveries, before food kinds no other kinds)
            others = list(getattr(msg, "smoothed_other_food", []))
            smoothed[k, robot] = (msg.smoothed_nest, msg.smoothed_food, msg.smoothed_density, *others)
            carrying[k, robot] = (
                bool(getattr(msg, "carrying", False)),
                *getattr(msg, "carrying_other_food", []),
            )
            deliveries[k, robot] = (
                int(getattr(msg, "deliveries", 0)),
                *getattr(msg, "other_food_deliveries", []),
            )
        elif kind == "range_and_bearing":
            heard[k].extend((robot, int(r.sender)) for r in msg.readings)

    p = config.params()
    entry, food_scale = config.arena_arrays(trial)
    probes = np.zeros((n, 2, N_PROBES))
    world.take_all_probes(poses[0][:, 0], poses[0][:, 1], entry, probes, 0, p)  # at the trial's first step
    ticks, actions = [], np.full((len(steps), n), -1, np.int64)
    fitness = np.full((len(steps), world.N_OBJECTIVES), np.nan)
    # the robots enter trial K driving as the chain's last tick before it set them (model: motors carry over)
    earlier = [s for s in tick_at if s < steps[0]]
    tick, initial = (tick_at[max(earlier)] if earlier else -1), None
    for k, s in enumerate(steps):
        tick = tick_at.get(s, tick)
        ticks.append(tick)
        if tick >= 0:
            actions[k] = wheels[k]
        if timeline.is_initial(config.timeline, s):
            initial = smoothed[k]
        if initial is not None:
            world.take_all_probes(poses[k][:, 0], poses[k][:, 1], entry, probes, 1, p)
            fitness[k] = _fitness_so_far(initial, smoothed[k], probes, deliveries[k], food_scale, p)
    faulty, swapped, notes = _live_marks(messages, steps, n)
    measured = next((m.message.objective for m in messages if m.topic == "/adaptation"), "")
    label = result.tree if result is not None else ""
    # a heterogeneous swarm's result keeps the JSON list of its robots' trees (SwarmLayout.label)
    trees = tuple(json.loads(label)) if label.lstrip().startswith("[") else (label,) * n if label else ()
    if (
        notes
    ):  # a live adaptation: the trees changed during the trial (its notes say when), the label is the last
        trees = ()
    return TrialFrames(
        tree=label,
        seed=int(start.seed),
        trial=trial,
        **arena_fields(config, trial),
        steps=np.array(steps),
        poses=poses,
        actions=actions,
        ticks=np.array(ticks),
        links=tuple(_links_shape(np.array(h, np.int64)) for h in heard),
        fitness=fitness,
        carrying=carrying,
        deliveries=deliveries,
        trees=trees,
        faulty=faulty,
        swapped=swapped,
        notes=notes,
        objective=measured,
    )


def _live_marks(
    messages: list[Any], steps: list[int], n: int
) -> tuple[np.ndarray | None, np.ndarray | None, tuple[str, ...]]:
    """A live adaptation's marks per frame (``adapt-live``'s bag): each robot faulty or not (``/faults``),
    swapped or not, and the last events as lines (``/adaptation``); (None, None, ()) for a bag without
    them."""
    faults = sorted(
        (int(m.message.step), [bool(k) for k in m.message.kinds]) for m in messages if m.topic == "/faults"
    )
    events = [m.message for m in messages if m.topic == "/adaptation"]
    if not faults and not events:
        return None, None, ()
    faulty = np.zeros((len(steps), n), dtype=np.bool_)
    swapped = np.zeros((len(steps), n), dtype=np.bool_)
    original = list(events[0].trees) if events else []
    lines: list[str] = []
    shown: list[str] = []
    notes: list[str] = []
    f = e = 0
    current = [False] * n
    running = list(original)
    for k, step in enumerate(steps):
        while f < len(faults) and faults[f][0] <= step:
            current = faults[f][1]
            f += 1
        while e < len(events) and int(events[e].step) <= step:
            event = events[e]
            e += 1
            if event.kind == "swap":
                running = list(event.trees)
                robots = ",".join(str(r) for r in event.robots)
                what = f"trial {event.trial}" if event.trial else "best tried"
                lines.append(f"swap ({what}): robots {robots} get bin {[int(b) for b in event.bin]}")
            elif event.kind == "window":
                target = "" if math.isnan(event.target) else f" / target {event.target:.3f}"
                lines.append(f"{event.phase}: {event.objective} {event.measure:.3f}{target}")
            elif event.kind == "fault":
                lines.append(f"fault: {event.note}")
            else:
                lines.append(f"done: {event.note}")
            shown = lines[-4:]
        faulty[k] = current[:n]
        swapped[k] = [bool(original) and running[i] != original[i] for i in range(n)]
        notes.append("\n".join(shown))
    return faulty, swapped, tuple(notes)
