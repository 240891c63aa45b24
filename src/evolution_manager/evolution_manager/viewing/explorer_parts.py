"""What both explorer pages share (``explorer``: a tree run's repertoires; ``swarm_explorer``: a composition
or team run's swarms): files read strictly, tree texts checked, each evaluation's seed, a trial's frames
packed as bytes for the page (``pack``), and the arena, actions and colours the page draws with."""

from __future__ import annotations

import base64
import csv
import math
from collections.abc import Sequence
from pathlib import Path

import numpy as np

from bt_controller.errors import TreeError
from bt_controller.language import ACTIONS, MAX_FOOD_KINDS, Library, LibraryError, parse
from bt_controller.validate import strict_json
from evolution_manager.errors import ExplorerError
from evolution_manager.viewing.frames import TrialFrames
from evolution_manager.viewing.palette import (
    GAP_COLOUR,
    REGION_COLOURS,
    ROBOT_COLOURS,
    carry_colour,
    hex_colour,
)
from swarm_sim.model import OBJECTIVES, Config

STRIDE = 2
"""One animation frame per this many sensing steps."""


def read_object(path: Path) -> dict:
    try:  # strict: NaN, Infinity and a key given twice are refused (the page could not be written)
        data = strict_json(path.read_text())
    except (OSError, ValueError) as error:
        raise ExplorerError(f"{path} is not a readable JSON file: {error}") from None
    if not isinstance(data, dict):
        raise ExplorerError(f"{path} does not hold a JSON object")
    return data


def check_tree(text: object, library: Library | None, where: str) -> None:
    """Refuse a tree text that does not parse (as ``library``, ``adapt`` and ``--swarm-from`` refuse it),
    naming where it is and why."""

    if not isinstance(text, str):
        raise ExplorerError(f"{where} must be tree text, got {type(text).__name__}")
    try:
        parse(text, library=library)
    except (TreeError, LibraryError) as error:
        raise ExplorerError(
            f"{where} does not parse: {error}; expected tree text of the run's nodes"
        ) from None


def evaluation_seeds(root: Path) -> dict[int, int]:
    path = root / "evaluations.csv"
    if not path.exists():
        return {}
    with open(path, newline="") as handle:
        return {
            int(row["evaluation"]): int(row["seed"])
            for row in csv.DictReader(handle)
            if row.get("evaluation", "").isdigit() and row.get("seed", "").isdigit()
        }


def pack(frames: TrialFrames, stride: int, objectives: Sequence[str]) -> dict:
    """One animation as bytes, base64: per kept frame, per robot x and y ((mm + arena_half) * 10, u16) and
    heading (u8, 256 steps a turn); then each of ``objectives`` so far (the page's, in its order; u16, value *
    10000, at most 65534; 65535: not yet); the last tick (u16, 65535: none); each robot's action (u8, 255:
    none); the food kinds each robot carries (u8, bit k for kind k + 1). Little-endian, packed (no
    padding)."""

    columns = [OBJECTIVES.index(o) for o in objectives]
    keep = list(range(0, len(frames.steps), stride))
    if keep[-1] != len(frames.steps) - 1:
        keep.append(len(frames.steps) - 1)
    rows = np.asarray(keep)
    poses = np.asarray(frames.poses, dtype=np.float64)[rows]
    fitness = np.asarray(frames.fitness, dtype=np.float64)[rows][:, columns]
    ticks = np.asarray(frames.ticks)[rows]
    actions = np.asarray(frames.actions)[rows]
    carried = np.asarray(frames.carrying, dtype=np.uint8)  # steps x robots x food kinds
    carrying = (carried << np.arange(carried.shape[2], dtype=np.uint8)).sum(axis=2)[rows]
    robots = poses.shape[1]
    # One record per kept frame; a dtype given as a list of fields is packed, as struct's "<" formats.
    record = np.dtype(
        [
            ("pose", [("x", "<u2"), ("y", "<u2"), ("heading", "u1")], (robots,)),
            ("fitness", "<u2", (len(columns),)),
            ("tick", "<u2"),
            ("action", "u1", (robots,)),
            ("carrying", "u1", (robots,)),
        ]
    )
    packed = np.zeros(len(rows), dtype=record)
    half, turn = frames.arena_half, 2 * math.pi
    # np.rint rounds halves to even, as Python's round does, and np.mod is Python's % on floats.
    packed["pose"]["x"] = np.rint((poses[:, :, 0] + half) * 10)
    packed["pose"]["y"] = np.rint((poses[:, :, 1] + half) * 10)
    packed["pose"]["heading"] = np.rint(np.mod(poses[:, :, 2], turn) / turn * 256) % 256
    scaled = np.minimum(np.rint(np.nan_to_num(fitness) * 10000), 65534)  # foraging may pass 6.5534: capped
    packed["fitness"] = np.where(np.isnan(fitness), 65535, scaled)
    packed["tick"] = np.where(ticks < 0, 65535, ticks)
    packed["action"] = np.where(actions < 0, 255, actions)
    packed["carrying"] = carrying
    out = packed.tobytes()
    return {
        "seed": str(frames.seed),  # a string: seeds reach 2**63, beyond JavaScript's exact integers
        "trial": frames.trial,
        "gap": None if math.isnan(frames.gap) else frames.gap,
        **({"regions": [piece._asdict() for piece in frames.regions]} if frames.regions else {}),
        "steps": [int(frames.steps[k]) for k in keep],
        "data": base64.b64encode(out).decode("ascii"),
    }


def arena(model: Config) -> dict:
    """The run's arena as the page draws it (mm); a trial's own regions travel with its animation."""
    return {
        "half": model.arena_half,
        "nest_radius": model.nest_radius,
        "robot_radius": model.robot_radius,
        "range": model.message_range,
        "robots": model.n_robots,
    }


def palette() -> dict:
    """The colours of ``palette`` as the page draws them: robots, region kinds (fill and ink, in drawing
    order), the ring of each carried food kind, and the ground outside every region."""
    return {
        "robots": [hex_colour(c) for c in ROBOT_COLOURS],
        "regions": {kind: [hex_colour(c) for c in colours] for kind, colours in REGION_COLOURS.items()},
        "carry": [hex_colour(carry_colour(k)) for k in range(MAX_FOOD_KINDS)],
        "gap": hex_colour(GAP_COLOUR),
    }


def actions() -> list[str]:

    return list(ACTIONS)


__all__ = ["STRIDE", "actions", "arena", "check_tree", "evaluation_seeds", "pack", "palette", "read_object"]
