"""``animate``: one trial as an animated GIF (or MP4), from a tree and a seed or from a trial bag; the frames
come from ``evolution_manager.viewing.frames``.

``render_frame`` draws one frame with Pillow: the arena as the paper's fig. 1 (nest disc at the centre, the
gap, the food region outside it), robots with heading and id (a robot carrying food with a green ring), a
trail, message links, and a side panel with step, tick, fitness so far (the paper's three objectives, or
foraging with the deliveries so far in a foraging trial) and each robot's action; in a heterogeneous swarm
each robot's tree is named by a letter beside its action, and the letters' trees are written out below; a
live adaptation's bag (``adapt-live``) crosses its faulty robots, rings those running a swapped-in tree and
lists its last windows and swaps.
``write_animation`` writes a GIF (or an MP4 through ffmpeg when it is installed).
"""

from __future__ import annotations

import functools
import importlib.util
import math
import shutil
import subprocess
import sys
import tempfile
import textwrap
import time
from collections.abc import Sequence
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np
from PIL import Image, ImageDraw, ImageFont

from bt_controller.errors import TreeError
from bt_controller.interpreters import NetworkError, controller_text, load_network
from bt_controller.language import ACTIONS, library_option, parse, to_text
from evolution_manager.arguments import Parser, int_in, non_negative_int, positive_int, seed_in_range
from evolution_manager.errors import AnimationError, UsageError
from evolution_manager.viewing.frames import TrialFrames, frames_from_bag, frames_from_tree
from evolution_manager.viewing.palette import (
    FAULT_COLOUR,
    FOOD_COLOUR,
    GAP_COLOUR,
    NEST_COLOUR,
    REGION_COLOURS,
    ROBOT_COLOURS,
    SWAP_COLOUR,
    carry_colour,
)
from swarm_ros.safe_paths import check_output, describe, replace_file
from swarm_sim.model import OBJECTIVES, PAPER_OBJECTIVES, LayoutError, label_point, load_layout
from swarm_sim.tasks import DEFAULT_TASK, FORAGING, TaskSpec, add_task_option, task_named

if TYPE_CHECKING:
    from bt_controller.language import Library
    from swarm_sim.model import Config, SwarmLayout


# ----------------------------------------------------------------------------------------------- drawing

ARENA_PX = 520
PANEL_PX = 250
TRAIL = 24  # frames of trail behind each robot


DEJAVU = Path("/usr/share/fonts/truetype/dejavu/DejaVuSans.ttf")
MAX_FPS = 100
"""The most frames per second: a GIF counts each frame's time in hundredths of a second."""
"""DejaVu Sans from Debian's fonts-dejavu-core (ws/setup installs it); matplotlib ships the same file."""


@functools.cache
def text_font(size: int = 12) -> ImageFont.FreeTypeFont:
    """DejaVu Sans at ``size`` pixels for the pictures' text (Pillow's built-in bitmap font drops spaces at
    small sizes): Debian's file, else the copy inside matplotlib."""
    path = DEJAVU
    if not path.is_file():
        spec = importlib.util.find_spec("matplotlib")
        locations = spec.submodule_search_locations if spec else None
        path = Path(next(iter(locations or []), "")) / "mpl-data" / "fonts" / "ttf" / "DejaVuSans.ttf"
    try:
        return ImageFont.truetype(str(path), size)
    except OSError:
        raise AnimationError(
            f"no DejaVu Sans font for the pictures' text (looked for {DEJAVU} and matplotlib's copy): "
            "install Debian's fonts-dejavu-core (ws/setup does)"
        ) from None


def to_pixels(frames: TrialFrames, x: float, y: float) -> tuple[float, float]:
    """Image coordinates of arena point (x, y) mm (y up in the arena, down in the image)."""
    scale = ARENA_PX / (2 * frames.arena_half)
    return (x + frames.arena_half) * scale, (frames.arena_half - y) * scale


def _draw_regions(draw: ImageDraw.ImageDraw, frames: TrialFrames, font: ImageFont.FreeTypeFont) -> None:
    """A layout's regions (``TrialFrames.regions``): food pieces, then nest pieces over them, each
    labelled."""
    scale = ARENA_PX / (2 * frames.arena_half)
    draw.rectangle((0, 0, ARENA_PX - 1, ARENA_PX - 1), fill=GAP_COLOUR, outline=(60, 60, 60), width=3)
    for kind, (colour, ink) in REGION_COLOURS.items():
        for piece in frames.regions:
            if piece.kind != kind:
                continue
            px, py = to_pixels(frames, piece.x, piece.y)
            r = piece.radius * scale
            if piece.shape == "disc":
                draw.ellipse((px - r, py - r, px + r, py + r), fill=colour)
            elif piece.shape == "beyond":  # everything but the circle, drawn as a ring out to the corners
                reach = 2 * ARENA_PX
                draw.ellipse(
                    (px - reach, py - reach, px + reach, py + reach), outline=colour, width=int(reach - r)
                )
            else:
                _, edge = to_pixels(frames, 0.0, piece.radius if piece.shape == "above" else -piece.radius)
                box = (
                    (3, 3, ARENA_PX - 4, edge)
                    if piece.shape == "above"
                    else (3, edge, ARENA_PX - 4, ARENA_PX - 4)
                )
                draw.rectangle(box, fill=colour)
            lx, ly = to_pixels(frames, *label_point(piece))
            draw.text((lx - 12, ly - 5), kind, font=font, fill=ink)


def render_frame(frames: TrialFrames, k: int) -> Image.Image:
    """Frame ``k`` as a Pillow RGB image (arena on the left, values on the right)."""
    image = Image.new("RGB", (ARENA_PX + PANEL_PX, ARENA_PX), (255, 255, 255))
    draw = ImageDraw.Draw(image)
    font = text_font()
    scale = ARENA_PX / (2 * frames.arena_half)
    cx, cy = to_pixels(frames, 0.0, 0.0)
    if frames.regions:
        _draw_regions(draw, frames, font)
    else:
        draw.rectangle((0, 0, ARENA_PX - 1, ARENA_PX - 1), fill=FOOD_COLOUR, outline=(60, 60, 60), width=3)
        r_gap = (frames.nest_radius + frames.gap) * scale
        draw.ellipse((cx - r_gap, cy - r_gap, cx + r_gap, cy + r_gap), fill=GAP_COLOUR)
        r_nest = frames.nest_radius * scale
        draw.ellipse((cx - r_nest, cy - r_nest, cx + r_nest, cy + r_nest), fill=NEST_COLOUR)
        draw.text((cx - 12, cy - 5), "nest", font=font, fill=(120, 80, 20))
        draw.text((8, 8), f"food (gap {frames.gap:.0f} mm)", font=font, fill=(40, 100, 40))
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
        for f in np.flatnonzero(frames.carrying[k, i]):  # carrying food: a ring per kind, in its ink
            ring = radius + 3 + 3 * int(f)
            ink = carry_colour(int(f))
            draw.ellipse((x - ring, y - ring, x + ring, y + ring), outline=ink, width=3)
        if frames.swapped is not None and frames.swapped[k, i]:  # runs a tree a live adaptation swapped in
            ring = radius + 7
            draw.ellipse((x - ring, y - ring, x + ring, y + ring), outline=SWAP_COLOUR, width=2)
        draw.ellipse((x - radius, y - radius, x + radius, y + radius), fill=ROBOT_COLOURS[i % 9])
        if frames.faulty is not None and frames.faulty[k, i]:  # faulty: a red cross
            draw.line((x - radius, y - radius, x + radius, y + radius), fill=FAULT_COLOUR, width=3)
            draw.line((x - radius, y + radius, x + radius, y - radius), fill=FAULT_COLOUR, width=3)
        tip = (x + 1.8 * radius * math.cos(heading), y - 1.8 * radius * math.sin(heading))
        draw.line(((x, y), tip), fill=(0, 0, 0), width=2)
        draw.text((x + radius + 1, y - radius - 9), str(i), font=font, fill=(0, 0, 0))
    panel = ARENA_PX + 10
    tick = int(frames.ticks[k])
    shown = shown_objectives(frames)
    lines = [
        f"seed {frames.seed}, trial {frames.trial}",
        f"step {int(frames.steps[k])} of {int(frames.steps[-1])}",
        f"tick {tick if tick >= 0 else '-'}",
    ]
    if "foraging" in shown:  # a foraging trial: the swarm's deliveries so far and how many robots carry food
        delivered, carrying = int(frames.deliveries[k].sum()), int(frames.carrying[k].any(axis=1).sum())
        lines.append(f"deliveries {delivered}, carrying {carrying}")
    lines.append("fitness so far:")

    for name, value in zip(OBJECTIVES, frames.fitness[k], strict=True):
        if name in shown:
            lines.append(f"  {name:8s} {'-' if math.isnan(value) else f'{value:.3f}'}")
    lines.append("actions:")
    y = 10
    for line in lines:
        draw.text((panel, y), line, font=font, fill=(0, 0, 0))
        y += 15
    letters = tree_letters(frames)
    for i in range(frames.n_robots):
        action = int(frames.actions[k, i])
        draw.rectangle((panel, y + 2, panel + 9, y + 11), fill=ROBOT_COLOURS[i % 9])
        draw.text(
            (panel + 14, y),
            f"{i}{' ' + letters[i] if letters else ''}: {ACTIONS[action] if action >= 0 else '(still)'}",
            font=font,
            fill=(0, 0, 0),
        )
        y += 15
    if letters:
        for line in tree_legend(frames):
            draw.text((panel, y), line, font=font, fill=(0, 0, 0))
            y += 15
    if frames.notes and frames.notes[k]:  # a live adaptation: its last events
        y += 5
        draw.text((panel, y), "adaptation (x faulty, o swapped):", font=font, fill=SWAP_COLOUR)
        y += 15
        for line in frames.notes[k].split("\n"):
            for part in textwrap.wrap(line, 36) or [""]:
                draw.text((panel, y), part, font=font, fill=(0, 0, 0))
                y += 15
    return image


def tree_letters(frames: TrialFrames) -> list[str]:
    """Each robot's tree as a letter (A: the first robot's tree, B: the next different one, ...), for a
    heterogeneous swarm; empty for one tree on every robot."""
    if not frames.heterogeneous:
        return []
    distinct = list(dict.fromkeys(frames.trees))
    return [chr(ord("A") + distinct.index(tree)) for tree in frames.trees]


LEGEND_CHARS = 34
"""Characters of tree text on one line of the panel."""


def tree_legend(frames: TrialFrames) -> list[str]:
    """The panel's lines naming each letter's tree (up to three lines each, one when there are many trees;
    cut with an ellipsis)."""
    distinct = list(dict.fromkeys(frames.trees))
    most = 3 if len(distinct) <= 4 else 1
    lines = ["trees:"]
    for index, tree in enumerate(distinct):
        chunks = textwrap.wrap(tree, LEGEND_CHARS - 3, break_on_hyphens=False) or [""]
        if len(chunks) > most:
            chunks = [*chunks[: most - 1], chunks[most - 1][: LEGEND_CHARS - 4] + "..."]
        lines.append(f"{chr(ord('A') + index)}: {chunks[0]}")
        lines.extend(f"   {chunk}" for chunk in chunks[1:])
    return lines


def shown_objectives(frames: TrialFrames) -> tuple[str, ...]:
    """The objectives a frame's panel shows: a live adaptation's objective, foraging in a foraging trial (the
    task's 200 ticks), else the paper's three."""
    if frames.objective in OBJECTIVES:
        return (frames.objective,)
    foraging = len(frames.steps) >= FORAGING.trials.ticks * 4  # 800 steps (816 under clean)
    return ("foraging",) if foraging else PAPER_OBJECTIVES


def _light(colour: tuple[int, int, int]) -> tuple[int, int, int]:
    red, green, blue = (int(c + (255 - c) * 0.55) for c in colour)
    return red, green, blue


def check_animation_output(out: Path) -> str:
    """The encoder ``out`` needs ("" for a GIF, ffmpeg's path for an MP4); ``AnimationError`` for another
    suffix, or an MP4 without ffmpeg. ``main`` asks before anything is simulated or read."""
    suffix = out.suffix.lower()
    if suffix not in (".gif", ".mp4"):
        raise AnimationError(f"{out}: an animation is written as .gif or .mp4, not {suffix or 'no suffix'!r}")
    encoder = shutil.which("ffmpeg") or ""
    if suffix == ".mp4" and not encoder:
        raise AnimationError("writing .mp4 needs ffmpeg, which is not installed: write a .gif instead")
    return encoder


def write_animation(frames: TrialFrames, out: Path | str, fps: int = 16, every: int = 1) -> Path:
    """Write every ``every``-th frame (the first included) to ``out``: an animated GIF, or an MP4 when
    ``out`` ends in .mp4 (needs ffmpeg). A foraging trial's 800 frames make a GIF of about 12 MB;
    ``every=4`` (one frame per tick) about a quarter of that."""
    for name, value, unit in (("--fps", fps, "frames per second"), ("--every", every, "sensing steps")):
        if value < 1:
            raise AnimationError(f"{name} must be a whole number of {unit} >= 1, got {value}")
    out = Path(out)
    suffix = out.suffix.lower()
    encoder = check_animation_output(out)
    try:  # written beside ``out``, then renamed over it: a link at ``out`` is refused, never followed
        out.parent.mkdir(parents=True, exist_ok=True)
        images = [render_frame(frames, k) for k in range(0, len(frames.steps), every)]
        if suffix == ".gif":
            paletted = [im.convert("P", palette=Image.Palette.ADAPTIVE, colors=64) for im in images]
            duration = int(1000 / fps)

            def save(temporary: Path) -> None:
                paletted[0].save(
                    temporary, format="GIF", save_all=True, append_images=paletted[1:], duration=duration,
                    loop=0, optimize=False,
                )  # fmt: skip

            replace_file(out, save)
            return out
        with tempfile.TemporaryDirectory(prefix="swarm-animation-") as folder:
            for k, image in enumerate(images):
                image.save(Path(folder) / f"{k:05d}.png")

            def encode(temporary: Path) -> None:
                pad = "pad=ceil(iw/2)*2:ceil(ih/2)*2"
                command = [encoder, "-y", "-loglevel", "error", "-framerate", str(fps), "-i",
                           f"{folder}/%05d.png", "-pix_fmt", "yuv420p", "-vf", pad,
                           str(temporary)]  # fmt: skip
                done = subprocess.run(command, capture_output=True, text=True, check=False)
                if done.returncode != 0:
                    raise AnimationError(f"ffmpeg could not write {out}: {done.stderr.strip()[-300:]}")

            replace_file(out, encode)
    except OSError as error:  # a read-only or full place, a planted link
        raise AnimationError(describe(out, error)) from None
    return out


# ---------------------------------------------------------------------------------------------- command


def _config_for(profile: str | None, task: TaskSpec | None = None) -> Config:
    """The model configuration of ``task``'s world (None: the default task) under ``profile`` (None: the
    model's default)."""
    try:
        return (task_named(DEFAULT_TASK) if task is None else task).config(profile)
    except (ValueError, TypeError) as error:
        raise AnimationError(f"--profile {profile}: {error}") from None


def main(argv: Sequence[str] | None = None) -> int:
    """``animate``: one trial to an animated GIF (or MP4), from a tree and a seed or from a trial bag."""
    parser = Parser(
        prog="animate",
        description="Render one trial to an animated GIF (.mp4 with ffmpeg): one frame per sensing step.",
    )
    source = parser.add_mutually_exclusive_group(required=True)
    source.add_argument("--tree", help="tree text, or a file holding it (the trial runs in-process)")
    source.add_argument(
        "--network",
        type=Path,
        metavar="FILE",
        help='every robot\'s network: {"weights": [56 numbers]} (the trial runs in-process)',
    )
    source.add_argument("--bag", type=Path, help="a trial bag written by `trial --bag`")
    source.add_argument(
        "--swarm",
        type=Path,
        metavar="FILE",
        help='a tree per robot: {"trees": [...]} (the trial runs in-process)',
    )
    parser.add_argument(
        "--seed", type=seed_in_range, help="seed of the trial, in [0, 2**63 - 1] (with --tree or --swarm)"
    )
    parser.add_argument(
        "--trial", type=non_negative_int, default=0, help="trial index (with --tree; default 0)"
    )
    parser.add_argument("--profile", help="model profile (with --tree; default: the model's default)")
    add_task_option(parser, default=None, what="; with --tree or --swarm")
    parser.add_argument(
        "--library", type=Path, help="with --tree or --swarm: a primitive library whose names the trees use"
    )
    parser.add_argument("--out", type=Path, required=True, help="F.gif or F.mp4 (new, unless --force)")
    parser.add_argument("--force", action="store_true", help="overwrite an --out that exists")
    parser.add_argument(
        "--fps",
        type=int_in(1, MAX_FPS, "a number of frames per second"),
        default=16,
        help=f"frames per second, 1 to {MAX_FPS} (default 16: 2x real time)",
    )
    parser.add_argument(
        "--every",
        type=positive_int,
        default=1,
        metavar="K",
        help="one frame every K sensing steps (default 1; 4: one per tick, a quarter of the file)",
    )
    try:
        args = parser.parse_args(argv)
    except UsageError as error:
        print(f"animate: error: {error}", file=sys.stderr)
        return 2
    try:
        started = time.monotonic()
        try:  # a link, a folder, a file there: refused before anything is simulated or read
            check_output(args.out, args.force)
        except OSError as error:
            raise AnimationError(str(error)) from None
        check_animation_output(args.out)  # .gif, or .mp4 with ffmpeg there
        if args.bag is not None:
            if any(v is not None for v in (args.seed, args.profile, args.task, args.library)) or args.trial:
                raise AnimationError(
                    "--seed, --trial, --profile, --task and --library go with --tree or --swarm; a bag holds "
                    "its own"
                )
            frames = frames_from_bag(args.bag)
        else:
            if args.seed is None:
                given = "--tree" if args.tree is not None else "--network" if args.network else "--swarm"
                raise AnimationError(f"{given} needs --seed S")
            config = _config_for(args.profile, args.task)
            library = _library(args.library)
            tree = (
                _tree_text(args.tree, library)
                if args.tree is not None
                else _network_text(args.network)
                if args.network is not None
                else _swarm(args.swarm, config, library)
            )
            frames = frames_from_tree(tree, args.seed, args.trial, config, library)
        write_animation(frames, args.out, args.fps, args.every)
    except AnimationError as error:
        print(f"animate: error: {error}", file=sys.stderr)
        return 2
    except ValueError as error:  # a bad seed, trial or tree
        print(f"animate: error: {error}", file=sys.stderr)
        return 2
    seconds = time.monotonic() - started
    count = len(range(0, len(frames.steps), args.every))
    each = "one per sensing step" if args.every == 1 else f"one every {args.every} sensing steps"
    print(f"{args.out}: {count} frames ({each}) in {seconds:.1f} s")
    return 0


def _library(path: Path | None) -> Library | None:

    return library_option(path, AnimationError)


def _swarm(path: Path, config: Config, library: Library | None = None) -> SwarmLayout:

    try:
        return load_layout(path, config.n_robots, library)
    except LayoutError as error:
        raise AnimationError(f"--swarm: {error}") from None


def _network_text(path: Path) -> str:
    try:
        return controller_text(load_network(path))
    except NetworkError as error:
        raise AnimationError(f"--network: {error}") from None


def _tree_text(source: str, library: Library | None = None) -> str:

    path = Path(source)
    text = path.read_text(encoding="utf-8") if "(" not in source and path.is_file() else source
    try:
        parsed = parse(text, library=library)
        return to_text(parsed) if library is None else library.fold(parsed)
    except TreeError as error:
        raise AnimationError(f"--tree: {error}") from None
