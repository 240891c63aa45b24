"""Trial animations: one trial as frames (poses, actions, messages, fitness so far), from a tree or a bag.

``frames_from_tree`` runs the trial in-process exactly as the node graph runs it
(``swarm_sim.lockstep.run_with_controllers``); ``frames_from_bag`` reads a trial bag written by
``trial --bag`` (or the main job's ``best_trial.bag``). Both give a ``TrialFrames``: **one frame per sensing
step** (8 a second; 176 for a trial), holding the poses the simulator published on ``/swarm_state`` at that
step, the action driving each robot's wheels after it, the messages heard at it, the last tick and the
fitness so far (each objective scored with the robots' smoothed values of that step as if the trial ended
there; undefined before the initial values are taken).

``render_frame`` draws one frame with Pillow: the arena as the paper's fig. 1 (nest disc at the centre, the
gap, the food region outside it), robots with heading and id, a trail, message links, and a side panel with
step, tick, fitness so far and each robot's action. ``write_animation`` writes a GIF (or an MP4 through
ffmpeg when it is installed). No ROS here: bags are read with ``evolution_manager.bags``.
"""

from __future__ import annotations

import dataclasses
import math
import shutil
import subprocess
import tempfile
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
from PIL import Image, ImageDraw

from bt_controller import timeline
from bt_controller.vocabulary import ACTIONS

from .errors import AnimationError

if TYPE_CHECKING:
    from swarm_sim.config import Config, Params
    from swarm_sim.lockstep import LockstepChain, RobotAnswer


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
    """(T, 3): density, nest, food so far (NaN before the initial values)."""

    @property
    def n_robots(self) -> int:
        return int(self.poses.shape[1])

    def to_json(self) -> dict:
        """A compact JSON form (poses in whole mm and centiradians) for the repertoire explorer."""
        return {
            "tree": self.tree,
            "seed": self.seed,
            "trial": self.trial,
            "gap": self.gap,
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
        }


def arena_fields(config: Config, trial: int) -> dict[str, float]:
    """The arena of ``trial`` as ``TrialFrames`` draws it: the gap between nest and food, the arena's and the
    nest's size and the robots' radius (mm)."""
    return {
        "gap": config.gap(trial),
        "arena_half": config.arena_half,
        "nest_radius": config.nest_radius,
        "robot_radius": config.robot_radius,
    }


def _fitness_so_far(initial: np.ndarray, current: np.ndarray, ground: np.ndarray, p: Params) -> np.ndarray:
    from swarm_sim import world

    counts = np.zeros((initial.shape[0], 8), dtype=np.int64)
    return world.trial_values(initial, current, ground, counts, p)[:3]


def frames_from_tree(tree: str, seed: int, trial: int = 0, config: Config | None = None) -> TrialFrames:
    """Run trial ``trial`` of ``seed`` with ``tree`` on every robot, in-process as the node graph runs it (its
    chain's earlier trials first); the frames are trial ``trial``'s steps."""
    from bt_controller.tree import parse
    from swarm_sim.config import DEFAULT
    from swarm_sim.lockstep import run_with_controllers

    config = config or DEFAULT
    p = config.params()
    steps: list[int] = []
    ticks: list[int] = []
    poses: list[np.ndarray] = []
    actions: list[np.ndarray] = []
    links: list[np.ndarray] = []
    fitness: list[np.ndarray] = []
    current = np.full(p.n_robots, -1, dtype=np.int64)
    last_tick = [-1]
    initial: list[np.ndarray] = []

    def on_answers(world: LockstepChain, answers: Sequence[RobotAnswer]) -> None:
        tick = timeline.tick_number(config.timeline, world.step) if world.ticks_now() else -1
        if tick >= 0:
            current[:] = [a.action for a in answers]
            last_tick[0] = tick
        if world.trial != trial:  # an earlier trial of the chain: it sets the state, it is not drawn
            return
        readings = world.readings()
        smoothed = np.array([a.smoothed for a in answers], dtype=np.float64)
        if timeline.is_initial(config.timeline, world.step):
            initial[:] = [smoothed]
        steps.append(world.step)
        poses.append(world.poses())
        actions.append(current.copy())
        ticks.append(last_tick[0])
        links.append(np.array([(i, int(s)) for i, r in enumerate(readings) for s in r.senders], np.int64))
        if not initial:
            fitness.append(np.full(3, np.nan))
        else:
            ground = np.array([[r.in_nest, r.on_food] for r in readings], dtype=np.bool_)
            fitness.append(_fitness_so_far(initial[0], smoothed, ground, p))

    run_with_controllers(parse(tree), seed, trial, config, on_answers=on_answers)
    return TrialFrames(
        tree=tree,
        seed=seed,
        trial=trial,
        **arena_fields(config, trial),
        steps=np.array(steps),
        poses=np.array(poses),
        actions=np.array(actions),
        ticks=np.array(ticks),
        links=tuple(_links_shape(lk) for lk in links),
        fitness=np.array(fitness),
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
    from evolution_manager.bags import BagError, read_bag
    from evolution_manager.reproduce import RESULT_TOPIC
    from swarm_sim.config import DEFAULT, default_config

    try:
        messages = list(read_bag(path))
    except BagError as error:
        raise AnimationError(str(error)) from None
    start = next((m.message for m in messages if m.topic == "/trial_start"), None)
    if start is None:
        raise AnimationError(f"{path} holds no /trial_start: not a trial bag (record one with `trial --bag`)")
    result = next((m.message for m in messages if m.topic == RESULT_TOPIC), None)
    profile = getattr(result, "profile", "") or DEFAULT.profile  # bags recorded before profiles: the default
    config = default_config(profile)
    trial = int(start.trial)
    states = {
        m.message.step: m.message
        for m in messages
        if m.topic == "/swarm_state" and int(m.message.trial) == trial
    }
    if not states:
        raise AnimationError(f"{path} holds no /swarm_state messages: nothing to animate")
    n = int(start.robots)
    steps = sorted(states)
    index = {s: k for k, s in enumerate(steps)}
    poses = np.array([[[q.x, q.y, q.theta] for q in states[s].poses] for s in steps], dtype=np.float64)
    wheels = np.full((len(steps), n), -1, dtype=np.int64)
    smoothed = np.full((len(steps), n, 3), np.nan)
    ground = np.zeros((len(steps), n, 2), dtype=np.bool_)
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
        if kind not in ("wheels", "ground", "range_and_bearing"):  # e.g. pose (PoseStamped): no step
            continue
        k = index.get(int(msg.step))
        if k is None:
            continue
        if kind == "wheels":
            wheels[k, robot] = int(msg.action)  # the action's index (wheel speeds are in m/s since issue 13)
            smoothed[k, robot] = (msg.smoothed_nest, msg.smoothed_food, msg.smoothed_density)
        elif kind == "ground":
            ground[k, robot] = (msg.in_nest, msg.on_food)
        elif kind == "range_and_bearing":
            heard[k].extend((robot, int(r.sender)) for r in msg.readings)
    p = config.params()
    ticks, actions, fitness = [], np.full((len(steps), n), -1, np.int64), np.full((len(steps), 3), np.nan)
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
            fitness[k] = _fitness_so_far(initial, smoothed[k], ground[k], p)
    return TrialFrames(
        tree=result.tree if result is not None else "",
        seed=int(start.seed),
        trial=trial,
        **arena_fields(config, trial),
        steps=np.array(steps),
        poses=poses,
        actions=actions,
        ticks=np.array(ticks),
        links=tuple(_links_shape(np.array(h, np.int64)) for h in heard),
        fitness=fitness,
    )


# ----------------------------------------------------------------------------------------------- drawing

ARENA_PX = 520
PANEL_PX = 250
TRAIL = 24  # frames of trail behind each robot
ROBOT_COLOURS = (
    (31, 119, 180), (214, 39, 40), (44, 160, 44), (148, 103, 189), (140, 86, 75),
    (227, 119, 194), (127, 127, 127), (188, 189, 34), (23, 190, 207),
)  # fmt: skip
NEST_COLOUR = (246, 214, 160)
FOOD_COLOUR = (196, 230, 180)
GAP_COLOUR = (250, 250, 250)


def to_pixels(frames: TrialFrames, x: float, y: float) -> tuple[float, float]:
    """Image coordinates of arena point (x, y) mm (y up in the arena, down in the image)."""
    scale = ARENA_PX / (2 * frames.arena_half)
    return (x + frames.arena_half) * scale, (frames.arena_half - y) * scale


def render_frame(frames: TrialFrames, k: int) -> Image.Image:
    """Frame ``k`` as a Pillow RGB image (arena on the left, values on the right)."""
    image = Image.new("RGB", (ARENA_PX + PANEL_PX, ARENA_PX), (255, 255, 255))
    draw = ImageDraw.Draw(image)
    scale = ARENA_PX / (2 * frames.arena_half)
    cx, cy = to_pixels(frames, 0.0, 0.0)
    draw.rectangle((0, 0, ARENA_PX - 1, ARENA_PX - 1), fill=FOOD_COLOUR, outline=(60, 60, 60), width=3)
    r_gap = (frames.nest_radius + frames.gap) * scale
    draw.ellipse((cx - r_gap, cy - r_gap, cx + r_gap, cy + r_gap), fill=GAP_COLOUR)
    r_nest = frames.nest_radius * scale
    draw.ellipse((cx - r_nest, cy - r_nest, cx + r_nest, cy + r_nest), fill=NEST_COLOUR)
    draw.text((cx - 12, cy - 5), "nest", fill=(120, 80, 20))
    draw.text((8, 8), f"food (gap {frames.gap:.0f} mm)", fill=(40, 100, 40))
    poses = frames.poses
    for i in range(frames.n_robots):
        trail = [to_pixels(frames, px, py) for px, py in poses[max(0, k - TRAIL) : k + 1, i, :2]]
        if len(trail) > 1:
            draw.line(trail, fill=_light(ROBOT_COLOURS[i % 9]), width=2)
    for receiver, sender in frames.links[k]:
        a = to_pixels(frames, *poses[k, receiver, :2])
        b = to_pixels(frames, *poses[k, sender, :2])
        draw.line((a, b), fill=(150, 150, 220), width=1)
    radius = max(3.0, frames.robot_radius * scale)
    for i in range(frames.n_robots):
        x, y = to_pixels(frames, *poses[k, i, :2])
        heading = poses[k, i, 2]
        draw.ellipse((x - radius, y - radius, x + radius, y + radius), fill=ROBOT_COLOURS[i % 9])
        tip = (x + 1.8 * radius * math.cos(heading), y - 1.8 * radius * math.sin(heading))
        draw.line(((x, y), tip), fill=(0, 0, 0), width=2)
        draw.text((x + radius + 1, y - radius - 9), str(i), fill=(0, 0, 0))
    panel = ARENA_PX + 10
    tick = int(frames.ticks[k])
    lines = [
        f"seed {frames.seed}, trial {frames.trial}",
        f"step {int(frames.steps[k])} of {int(frames.steps[-1])}",
        f"tick {tick if tick >= 0 else '-'}",
        "fitness so far:",
    ]
    from swarm_sim.world import OBJECTIVES

    for name, value in zip(OBJECTIVES, frames.fitness[k], strict=True):
        lines.append(f"  {name:8s} {'-' if math.isnan(value) else f'{value:.3f}'}")
    lines.append("actions:")
    y = 10
    for line in lines:
        draw.text((panel, y), line, fill=(0, 0, 0))
        y += 15
    for i in range(frames.n_robots):
        action = int(frames.actions[k, i])
        draw.rectangle((panel, y + 2, panel + 9, y + 11), fill=ROBOT_COLOURS[i % 9])
        draw.text((panel + 14, y), f"{i}: {ACTIONS[action] if action >= 0 else '(still)'}", fill=(0, 0, 0))
        y += 15
    return image


def _light(colour: tuple[int, int, int]) -> tuple[int, int, int]:
    return tuple(int(c + (255 - c) * 0.55) for c in colour)  # type: ignore[return-value]


def write_animation(frames: TrialFrames, out: Path | str, fps: int = 16) -> Path:
    """Write every frame to ``out``: an animated GIF, or an MP4 when ``out`` ends in .mp4 (needs ffmpeg)."""
    out = Path(out)
    suffix = out.suffix.lower()
    if suffix not in (".gif", ".mp4"):
        raise AnimationError(f"{out}: an animation is written as .gif or .mp4, not {suffix or 'no suffix'!r}")
    encoder = shutil.which("ffmpeg") or ""
    if suffix == ".mp4" and not encoder:
        raise AnimationError("writing .mp4 needs ffmpeg, which is not installed: write a .gif instead")
    out.parent.mkdir(parents=True, exist_ok=True)
    images = [render_frame(frames, k) for k in range(len(frames.steps))]
    if suffix == ".gif":
        paletted = [im.convert("P", palette=Image.Palette.ADAPTIVE, colors=64) for im in images]
        paletted[0].save(
            out, save_all=True, append_images=paletted[1:], duration=int(1000 / fps), loop=0, optimize=False
        )
        return out
    with tempfile.TemporaryDirectory(prefix="swarm-animation-") as folder:
        for k, image in enumerate(images):
            image.save(Path(folder) / f"{k:05d}.png")
        command = [encoder, "-y", "-loglevel", "error", "-framerate", str(fps), "-i", f"{folder}/%05d.png",
                   "-pix_fmt", "yuv420p", "-vf", "pad=ceil(iw/2)*2:ceil(ih/2)*2", str(out)]  # fmt: skip
        done = subprocess.run(command, capture_output=True, text=True, check=False)
        if done.returncode != 0:
            raise AnimationError(f"ffmpeg could not write {out}: {done.stderr.strip()[-300:]}")
    return out


# ---------------------------------------------------------------------------------------------- command


def _config_for(profile: str | None) -> Config:
    """The model configuration of ``profile`` (None: the default)."""

    from swarm_sim.config import DEFAULT, Config

    if profile is None:
        return DEFAULT
    if not any(f.name == "profile" for f in dataclasses.fields(Config)):
        raise AnimationError(f"--profile {profile}: this build of the model has no profiles")
    choice: dict[str, Any] = {"profile": profile}
    try:
        return dataclasses.replace(DEFAULT, **choice)
    except (ValueError, TypeError) as error:
        raise AnimationError(f"--profile {profile}: {error}") from None


def main(argv: Sequence[str] | None = None) -> int:
    """``animate``: one trial to an animated GIF (or MP4), from a tree and a seed or from a trial bag."""
    import argparse
    import sys
    import time

    parser = argparse.ArgumentParser(
        prog="animate",
        description="Render one trial to an animated GIF (.mp4 with ffmpeg): one frame per sensing step.",
    )
    source = parser.add_mutually_exclusive_group(required=True)
    source.add_argument("--tree", help="tree text, or a file holding it (the trial runs in-process)")
    source.add_argument("--bag", type=Path, help="a trial bag written by `trial --bag`")
    parser.add_argument("--seed", type=int, help="seed of the trial (with --tree)")
    parser.add_argument("--trial", type=int, default=0, help="trial index (with --tree; default 0)")
    parser.add_argument("--profile", help="model profile (with --tree; default: the model's default)")
    parser.add_argument("--out", type=Path, required=True, help="F.gif or F.mp4")
    parser.add_argument("--fps", type=int, default=16, help="frames per second (default 16: 2x real time)")
    args = parser.parse_args(argv)
    try:
        started = time.monotonic()
        if args.bag is not None:
            if args.seed is not None or args.profile is not None or args.trial != 0:
                raise AnimationError("--seed, --trial and --profile go with --tree; a bag holds its own")
            frames = frames_from_bag(args.bag)
        else:
            if args.seed is None:
                raise AnimationError("--tree needs --seed S")
            tree = _tree_text(args.tree)
            frames = frames_from_tree(tree, args.seed, args.trial, _config_for(args.profile))
        write_animation(frames, args.out, args.fps)
    except AnimationError as error:
        print(f"animate: error: {error}", file=sys.stderr)
        return 2
    except ValueError as error:  # a bad seed, trial or tree
        print(f"animate: error: {error}", file=sys.stderr)
        return 2
    seconds = time.monotonic() - started
    print(f"{args.out}: {len(frames.steps)} frames (one per sensing step) in {seconds:.1f} s")
    return 0


def _tree_text(source: str) -> str:
    from bt_controller.errors import TreeError
    from bt_controller.tree import parse, to_text

    path = Path(source)
    text = path.read_text(encoding="utf-8") if "(" not in source and path.is_file() else source
    try:
        return to_text(parse(text))
    except TreeError as error:
        raise AnimationError(f"--tree: {error}") from None
