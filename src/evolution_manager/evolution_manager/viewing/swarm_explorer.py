"""The swarm explorer: ``explorer.html`` of a composition run (``evolution.compositions``, ``evolve
--swarm-from``) or a team run (``evolution.teams``, ``evolve --team K``), one self-contained page as the tree
explorer's (``explorer``), which hands such a run to :func:`write_swarm_explorer`.

A composition run's page shows its grid of compositions by the run's behaviour space (MAP-Elites' archive,
``repertoire_compositions.json``; for a GA, which keeps none, or a MAP-Elites run not yet finished, every
evaluated composition of ``evaluations.csv`` binned alike, the fittest of each bin), coloured by in-run
fitness (the run's files hold no held-out score per bin); and its marked swarms from ``summary.json``: the
best swarm, the validated choice, the homogeneous baseline and the baseline's validated choice, each with
its held-out score. A team run has no grid: the page shows its best team and validated choice.

Each swarm shows its values (fitness, held-out and validation fitness, the run's behaviour axes: the
deliveries of each kind for a multi-food run binned by deliveries), each distinct tree once (simplified, the
original kept, as the tree page draws them) with the robots that run it and, for a composition, the
repertoire cell it is (source run, objective, bin, fitness), and the trial animation of the swarm: trial 0
of its evaluation's seed (the run's scenario seed for a swarm no logged evaluation scored: the baseline),
through the compiled kernels (``frames.frames_from_tree`` with a swarm layout, the simplified trees), packed
as the tree page packs poses (``explorer_parts.pack``), robots coloured by the tree they run.

Only the run folder's files are read (``config.json``, ``cells.json``, ``evaluations.csv``, ``summary.json``,
``repertoire_compositions.json``, ``library.json``); nothing is evaluated beyond the animations' trials.
A damaged file is refused in one line naming it (``ExplorerError``).
"""

from __future__ import annotations

import csv
import hashlib
import html
import json
import math
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any

from evolution_manager.errors import ConfigError, ExplorerError, RunDirectoryError
from evolution_manager.evolution.run_folder import COMPOSITIONS, TEAMS
from evolution_manager.evolution.shown_trees import simplified as simplified_text
from evolution_manager.files import printable, write_atomic
from evolution_manager.viewing.explorer_page import SWARM_PAGE
from evolution_manager.viewing.explorer_parts import (
    STRIDE,
    actions,
    arena,
    check_tree,
    pack,
    palette,
    read_object,
)
from evolution_manager.viewing.frames import frames_from_tree
from swarm_sim.model import SwarmLayout

if TYPE_CHECKING:
    from bt_controller.language import Library

KINDS = (COMPOSITIONS, TEAMS)
"""The ``kind`` values of ``config.json`` whose page this module builds."""

Progress = Callable[[int, int], None] | None

ANIMATION_BYTES = 4_000_000
"""The packed poses (base64) a page stores for its grid's bins at most; the marked swarms' come on top."""


def swarm_kind(root: Path) -> str | None:
    """``compositions`` or ``teams`` when ``root`` holds the ``config.json`` of such a run; None otherwise (a
    tree run, or no run: the tree explorer says what it lacks)."""
    path = Path(root) / "config.json"
    if not path.is_file():
        return None
    kind = read_object(path).get("kind")
    return str(kind) if kind in KINDS else None


class _Trees:
    """The page's table of trees: each distinct tree text once, with its simplified text (indices keep a
    grid of hundreds of nine-robot swarms small)."""

    def __init__(self, library: Library | None) -> None:
        self.library = library
        self.rows: list[dict[str, str]] = []
        self.index: dict[str, int] = {}

    def add(self, text: object, where: str) -> int:
        if not isinstance(text, str) or text not in self.index:
            check_tree(text, self.library, where)
            assert isinstance(text, str)
            self.index[text] = len(self.rows)
            self.rows.append({"tree": text, "simplified": simplified_text(text, self.library)})
        return self.index[text]


def _number(value: object, where: str) -> float | None:
    if value is None:
        return None
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
        raise ExplorerError(f"{where} must be a number, got {value!r}")
    return float(value)


def _numbers(values: object, count: int, where: str) -> list[float] | None:
    if values is None:
        return None
    if not isinstance(values, list) or len(values) != count:
        raise ExplorerError(f"{where} must be a list of {count} numbers, got {values!r}")
    return [float(_number(v, where) or 0.0) for v in values]


def _rows(path: Path) -> list[dict[str, str]]:
    """The rows of a run's ``evaluations.csv`` (none when it has none)."""
    if not path.exists():
        return []
    try:
        with open(path, newline="") as handle:
            rows = list(csv.DictReader(handle))
    except (OSError, csv.Error, UnicodeDecodeError) as error:
        raise ExplorerError(f"{path} is not a readable CSV file: {error}") from None
    for k, row in enumerate(rows, 2):
        if not (row.get("evaluation") or "").isdigit() or not (row.get("seed") or "").isdigit():
            raise ExplorerError(f"{path}: line {k} has no evaluation and seed numbers: not a run's log")
    return rows


class _Page:
    """What one swarm page is built from: the run's trees, swarms, animations."""

    def __init__(self, root: Path, n_robots: int, objective: str, axes: Sequence[str], library: Any) -> None:
        self.root = root
        self.n_robots = n_robots
        self.objective = objective
        self.axes = list(axes)
        self.trees = _Trees(library)
        self.wanted: list[tuple[dict, tuple[str, ...], int]] = []

    def swarm(self, trees: Sequence[object], seed: int, where: str, **values: Any) -> dict:
        """A swarm as the page shows it: robot ``i`` runs ``trees[i]``; its robots grouped by the tree they
        run (``groups``, in the order of their first robot: each the tree's index in the page's table and its
        robots; ``robots``: each robot's group); ``values``: what else its table shows (a composition's cell
        of each robot, a team's sub-group of each robot)."""
        indices = [self.trees.add(t, f"{where}: robot {i}'s tree") for i, t in enumerate(trees)]
        groups: list[dict] = []
        order: dict[int, int] = {}
        robots = []
        for robot, tree in enumerate(indices):
            if tree not in order:
                order[tree] = len(groups)
                groups.append({"tree": tree, "robots": []})
            groups[order[tree]]["robots"].append(robot)
            robots.append(order[tree])
        entry = {"groups": groups, "robots": robots, "seed": str(seed), **values}
        layout = tuple(self.trees.rows[t]["simplified"] for t in indices)
        self.wanted.append((entry, layout, seed))
        return entry

    def animate(self, model: Any, library: Any, progress: Progress) -> dict[str, dict]:
        """The wanted swarms' trials (trial 0 of each one's seed), packed; each swarm so animated names its
        animation. The marked swarms first, then the grid's bins from the fittest down while the packed poses
        stay within ``ANIMATION_BYTES`` (a foraging trial's are about 36 kB: a full grid's would be 18 MB)."""
        animations: dict[str, dict] = {}
        stored = 0

        def rank(k: int) -> tuple[int, float]:
            entry = self.wanted[k][0]
            fitness = entry.get("fitness")
            return ("title" not in entry, -fitness if fitness is not None else math.inf)

        order = sorted(range(len(self.wanted)), key=rank)
        for done, k in enumerate(order, 1):
            entry, layout, seed = self.wanted[k]
            key = hashlib.sha256(json.dumps([layout, seed]).encode()).hexdigest()[:16]
            if key not in animations and ("title" in entry or stored < ANIMATION_BYTES):
                # The simplified trees set the same motors: the same trial, a little faster to run.
                frames = frames_from_tree(SwarmLayout(layout), seed, 0, model, library)
                animations[key] = pack(frames, STRIDE, [self.objective])
                stored += len(animations[key]["data"])
            if key in animations:
                entry["animation"] = key
            if progress is not None:
                progress(done, len(self.wanted))
        return animations


def _genome(value: object, cells: int, robots: int, where: str) -> list[int]:
    if (
        not isinstance(value, list)
        or len(value) != robots
        or not all(isinstance(c, int) and not isinstance(c, bool) and 0 <= c < cells for c in value)
    ):
        raise ExplorerError(f"{where} must be {robots} cell indices below {cells}, got {value!r}")
    return list(value)


def _composition_data(root: Path, config_document: dict, page_of: Callable[..., _Page]) -> tuple:
    # late: the run modules load DEAP and qdpy, only for a swarm run's page
    from evolution_manager.evolution.compositions import (
        Cell,
        CompositionConfig,
        CompositionDirectory,
        bin_of,
        cells_digest,
    )

    config = CompositionConfig.from_json(config_document)
    model = config.world()
    library = CompositionDirectory(root).read_library(config)
    space = config.space
    path = root / "cells.json"
    try:
        cells = [Cell.from_json(c) for c in read_object(path)["cells"]]
    except (KeyError, TypeError, ValueError) as error:
        raise ExplorerError(f"{path} is damaged: {error!r}; expected the run's cell list") from None
    if cells_digest(cells) != config.cells_digest:
        raise ExplorerError(f"{path} is not the cell list the run started with (its digest differs)")
    page = page_of(model.n_robots, config.objective, space.names, library)
    n = model.n_robots
    cell_rows = [
        {"index": k, "source": printable(Path(c.source).name) or c.source, "path": c.source,
         "objective": c.objective, "bin": ",".join(map(str, c.bin)), "fitness": c.fitness}
        for k, c in enumerate(cells)
    ]  # fmt: skip
    rows = _rows(root / "evaluations.csv")
    first_seed: dict[str, int] = {}
    first_row: dict[str, dict[str, str]] = {}
    for row in rows:
        first_seed.setdefault(row.get("genome") or "", int(row["seed"]))
        first_row.setdefault(row.get("genome") or "", row)

    def logged(genome: list[int]) -> dict[str, Any]:
        """The evaluation that first scored ``genome`` and its logged values of the run's axes (what a
        validated choice's in-run fitness is), or nothing when the log lacks it."""
        row = first_row.get(" ".join(map(str, genome)))
        if row is None:
            return {}
        try:
            values = [float(row[a]) for a in space.names]
        except (KeyError, TypeError, ValueError):
            return {"evaluation": int(row["evaluation"])}
        finite = all(math.isfinite(v) for v in values)
        return {"evaluation": int(row["evaluation"]), **({"values": values} if finite else {})}

    by_evaluation = {int(row["evaluation"]): int(row["seed"]) for row in rows}

    def seed_of(genome: list[int], evaluation: object) -> int:
        if isinstance(evaluation, int) and evaluation in by_evaluation:
            return by_evaluation[evaluation]
        return first_seed.get(" ".join(map(str, genome)), config.scenario_seed)

    def composition(genome: list[int], where: str, evaluation: object = None, **values: Any) -> dict:
        return page.swarm(
            [cells[c].tree for c in genome],
            seed_of(genome, evaluation),
            where,
            cells=genome,
            evaluation=evaluation if isinstance(evaluation, int) else None,
            **values,
        )

    # the grid: MAP-Elites' archive, else every evaluated composition binned alike
    bins: dict[str, dict] = {}
    archive = root / "repertoire_compositions.json"
    axes = len(space.names)
    if archive.exists():
        source = "archive"
        document = read_object(archive)
        items = document.get("items")
        if not isinstance(items, list):
            raise ExplorerError(f"{archive}: items must be a list: not a composition run's archive")
        for k, item in enumerate(items):
            where = f"{archive}: item {k}"
            if not isinstance(item, dict) or not all(f in item for f in ("bin", "genome", "fitness")):
                raise ExplorerError(
                    f"{where} has no bin, genome and fitness: not a composition run's archive"
                )
            place = item["bin"]
            if not (
                isinstance(place, list)
                and len(place) == 3
                and all(isinstance(b, int) and not isinstance(b, bool) and 0 <= b < 8 for b in place)
            ):
                raise ExplorerError(f"{where}: bin must be 3 bin numbers from 0 to 7, got {place!r}")
            fitness = _number(item["fitness"], f"{where}: fitness")
            if fitness is None:
                raise ExplorerError(f"{where}: fitness must be a number, got None")
            key = ",".join(str(b) for b in place)
            bins[key] = composition(
                _genome(item["genome"], len(cells), n, f"{where}: genome"),
                where,
                item.get("evaluation"),
                fitness=fitness,
                values=_numbers(item.get("descriptors"), axes, f"{where}: descriptors"),
            )
    else:
        source = "evaluated"
        best: dict[str, tuple[float, dict[str, str]]] = {}
        for row in rows:
            if (row.get(config.objective) or "") == "":
                continue  # a failed evaluation
            try:
                fitness = float(row[config.objective])
                values = [float(row[a]) for a in space.names]
                if not all(math.isfinite(v) for v in (fitness, *values)):
                    raise ValueError("not finite")
                key = ",".join(map(str, bin_of(space.scaled(values))))
            except (KeyError, TypeError, ValueError):
                raise ExplorerError(
                    f"{root / 'evaluations.csv'}: evaluation {row['evaluation']} has no finite numbers for "
                    f"{config.objective} and {', '.join(space.names)} in their ranges: not this run's log"
                ) from None
            if key not in best or fitness > best[key][0]:
                best[key] = (fitness, row)
        for key, (fitness, row) in best.items():
            where = f"{root / 'evaluations.csv'}: evaluation {row['evaluation']}"
            try:
                genome = [int(c) for c in (row.get("genome") or "").split()]
            except ValueError:
                genome = []
            bins[key] = composition(
                _genome(genome, len(cells), n, f"{where}: genome"),
                where,
                int(row["evaluation"]),
                fitness=fitness,
                values=[float(row[a]) for a in space.names],
            )
    summary = _summary(root)
    marked: dict[str, dict] = {}
    where = f"{root / 'summary.json'}"
    if isinstance(summary.get("best"), dict):
        best_swarm = summary["best"]
        marked["best"] = composition(
            _genome(best_swarm.get("genome"), len(cells), n, f"{where}: best genome"),
            f"{where}: best",
            best_swarm.get("evaluation"),
            title="the run's best swarm",
            fitness=_number(best_swarm.get("fitness"), f"{where}: best fitness"),
            values=_numbers(best_swarm.get("descriptors"), axes, f"{where}: best descriptors"),
            held_out=_number(summary.get("heldout_best_fitness"), f"{where}: heldout_best_fitness"),
            held_out_values=_numbers(
                summary.get("heldout_descriptors"), axes, f"{where}: heldout_descriptors"
            ),
        )
    for name, chosen, title in _validated_of(summary, "validated", "the run's validated choice"):
        genome = _genome(chosen.get("genome"), len(cells), n, f"{where}: {name} genome")
        found = logged(genome)
        marked[name] = composition(
            genome,
            f"{where}: {name}",
            found.get("evaluation"),
            title=title,
            **_validated_values(chosen, axes, f"{where}: {name}"),
            **({"values": found["values"]} if "values" in found else {}),
        )
    homogeneous = summary.get("homogeneous")
    if isinstance(homogeneous, dict):
        cell = homogeneous.get("cell")
        marked["homogeneous"] = composition(
            _genome([cell] * n, len(cells), n, f"{where}: homogeneous cell"),
            f"{where}: homogeneous",
            title="the homogeneous baseline (the fittest cell on every robot, on the run's scenario)",
            fitness=_number(homogeneous.get("fitness"), f"{where}: homogeneous fitness"),
            values=_numbers(homogeneous.get("descriptors"), axes, f"{where}: homogeneous descriptors"),
            held_out=_number(homogeneous.get("heldout_best_fitness"), f"{where}: homogeneous held-out"),
            held_out_values=_numbers(homogeneous.get("heldout_descriptors"), axes, f"{where}: homogeneous"),
        )
        for name, chosen, title in _validated_of(
            homogeneous, "homogeneous-validated", "the homogeneous baseline's validated choice"
        ):
            marked[name] = composition(
                _genome(chosen.get("genome"), len(cells), n, f"{where}: homogeneous validated genome"),
                f"{where}: homogeneous validated",
                title=title,
                **_validated_values(chosen, axes, f"{where}: homogeneous validated"),
            )
    grid = {
        "source": source,
        "shape": [8, 8, 8],
        "bins": bins,
        "coverage": summary.get("coverage"),
        "qd_score": summary.get("qd_score"),
        "qd_scores": summary.get("qd_scores_archive") or summary.get("qd_scores_evaluated"),
    }
    about = {
        "algorithm": config.algorithm,
        "label": config.label,
        "task": config.task.name,
        "seed": str(config.seed),
        "scenario_seed": str(config.scenario_seed),
        "cells": cell_rows,
        "sources": [printable(Path(s).name) or s for s in config.sources],
    }
    return page, model, library, grid, marked, about, summary


def _validated_of(summary: dict, name: str, title: str) -> list[tuple[str, dict, str]]:
    chosen = summary.get("validated")
    return [(name, chosen, title)] if isinstance(chosen, dict) else []


def _validated_values(chosen: dict, axes: int, where: str) -> dict:
    return {
        "fitness": _number(chosen.get("fitness"), f"{where} fitness"),
        "validation_fitness": _number(chosen.get("validation_fitness"), f"{where} validation_fitness"),
        "held_out": _number(chosen.get("heldout_best_fitness"), f"{where} heldout_best_fitness"),
        "held_out_values": _numbers(chosen.get("heldout_descriptors"), axes, f"{where} heldout_descriptors"),
    }


def _summary(root: Path) -> dict:
    path = root / "summary.json"
    return read_object(path) if path.exists() else {}


def _team_data(root: Path, config_document: dict, page_of: Callable[..., _Page]) -> tuple:
    # late: the team module loads DEAP, only for a team run's page
    from evolution_manager.evolution.teams import DESCRIPTORS, TeamConfig, robot_groups

    config = TeamConfig.from_json(config_document)
    model = config.world()
    n = model.n_robots
    groups = list(robot_groups(n, config.team))
    page = page_of(n, config.objective, DESCRIPTORS, None)
    rows = _rows(root / "evaluations.csv")
    by_evaluation = {int(row["evaluation"]): int(row["seed"]) for row in rows}
    first_seed: dict[str, int] = {}
    for row in rows:
        first_seed.setdefault(row.get("trees") or "", int(row["seed"]))
    where = f"{root / 'summary.json'}"

    def team(trees: object, name: str, evaluation: object = None, **values: Any) -> dict:
        if not isinstance(trees, list) or len(trees) != config.team:
            raise ExplorerError(f"{where}: {name} trees must be a list of {config.team} trees, got {trees!r}")
        if isinstance(evaluation, int) and evaluation in by_evaluation:
            seed = by_evaluation[evaluation]
        else:
            seed = first_seed.get(json.dumps(trees), config.scenario_seed)
        return page.swarm(
            [trees[g] for g in groups],
            seed,
            f"{where}: {name}",
            subgroups=groups,
            evaluation=evaluation if isinstance(evaluation, int) else None,
            **values,
        )

    summary = _summary(root)
    marked: dict[str, dict] = {}
    best = summary.get("best")
    if isinstance(best, dict):
        marked["best"] = team(
            best.get("trees"),
            "best",
            best.get("evaluation"),
            title="the run's best team",
            fitness=_number(best.get("fitness"), f"{where}: best fitness"),
            values=_numbers(best.get("descriptors"), len(DESCRIPTORS), f"{where}: best descriptors"),
            held_out=_number(summary.get("heldout_best_fitness"), f"{where}: heldout_best_fitness"),
            held_out_objectives=_objectives(
                summary.get("heldout_objectives"), f"{where}: heldout_objectives"
            ),
        )
    chosen = summary.get("validated")
    if isinstance(chosen, dict):
        marked["validated"] = team(
            chosen.get("trees"),
            "validated",
            title="the run's validated choice",
            fitness=_number(chosen.get("fitness"), f"{where}: validated fitness"),
            validation_fitness=_number(chosen.get("validation_fitness"), f"{where}: validation_fitness"),
            held_out=_number(chosen.get("heldout_best_fitness"), f"{where}: validated held-out"),
            held_out_objectives=_objectives(chosen.get("heldout_objectives"), f"{where}: validated held-out"),
        )
    if not marked:
        raise ExplorerError(
            f"{root} holds no summary.json with a best team: a team run's page shows its best team "
            "(the run writes summary.json when its first team is evaluated)"
        )
    about = {
        "algorithm": config.algorithm,
        "label": config.label,
        "task": config.task.name,
        "seed": str(config.seed),
        "scenario_seed": str(config.scenario_seed),
        "team": config.team,
        "robot_groups": groups,
    }
    return page, model, None, None, marked, about, summary


def _objectives(value: object, where: str) -> dict[str, float] | None:
    if value is None:
        return None
    if not isinstance(value, dict):
        raise ExplorerError(f"{where} must map each objective to a number, got {value!r}")
    return {str(k): float(_number(v, f"{where}: {k}") or 0.0) for k, v in value.items()}


def swarm_explorer_data(root: Path, animate: bool = True, progress: Progress = None) -> dict:
    """Everything the swarm page of the composition or team run in ``root`` shows, read from its files."""
    root = Path(root)
    document = read_object(root / "config.json")
    kind = document.get("kind")
    if kind not in KINDS:
        raise ExplorerError(
            f"{root / 'config.json'}: kind {kind!r}; the swarm page shows {' or '.join(KINDS)}"
        )

    def page_of(n_robots: int, objective: str, axes: Sequence[str], library: Any) -> _Page:
        return _Page(root, n_robots, objective, axes, library)

    try:
        build = _composition_data if kind == COMPOSITIONS else _team_data
        page, model, library, grid, marked, about, summary = build(root, document, page_of)
    except ConfigError as error:
        raise ExplorerError(f"{root / 'config.json'}: {error}") from None
    except RunDirectoryError as error:  # the run's library copy
        raise ExplorerError(str(error)) from None
    if grid is not None and not grid["bins"] and not marked:
        raise ExplorerError(
            f"{root} holds no evaluated composition (no archive, no scored row in evaluations.csv, no "
            "summary.json): nothing to show yet"
        )
    animations = page.animate(model, library, progress) if animate else {}
    return {
        "kind": kind,
        "run": printable(root.name),
        **about,
        "evaluations": summary.get("evaluations"),
        "finished": summary.get("finished"),
        "objective": page.objective,
        "axes": page.axes,
        "robots": page.n_robots,
        "grid": grid,
        "marked": marked,
        "trees": page.trees.rows,
        "objectives": {page.objective: {}},  # what the packed frames hold (explorer_parts.pack)
        "animations": animations,
        "animation_bytes": ANIMATION_BYTES,
        "arena": arena(model),
        "actions": actions(),
        "palette": palette(),
    }


def write_swarm_explorer(root: Path | str, animate: bool = True, progress: Progress = None) -> Path:
    """Build ``explorer.html`` of the composition or team run in ``root`` (its place already checked for
    links by ``explorer.write_explorer``); return its path."""
    root = Path(root)
    data = swarm_explorer_data(root, animate, progress)
    what = "Composition explorer" if data["kind"] == COMPOSITIONS else "Team explorer"
    page = SWARM_PAGE.replace("__TITLE__", html.escape(f"{what}: {data['run']}"))
    payload = json.dumps(data, separators=(",", ":"), allow_nan=False).replace("</", "<\\/")
    page = page.replace("__DATA__", payload)
    path = root / "explorer.html"
    write_atomic(path, page)
    return path


__all__ = ["KINDS", "swarm_explorer_data", "swarm_kind", "write_swarm_explorer"]
