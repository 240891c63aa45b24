"""The repertoire explorer: ``explorer.html`` in a run directory, one self-contained page (no server, no
network: it opens from ``file://``).

It shows each objective's 8 x 8 x 8 grid as the paper's fig. 7 (eight 8 x 8 heatmaps, one per conditionality
bin; movement across, rotation up), coloured by the best in-run fitness of each bin or, where the run's files
hold them, by held-out fitness. Clicking a bin (or opening ``explorer.html#objective=food&bin=3,4,2``) shows
its trees drawn, simplified and original, their fitness and descriptors, and the trial animation of the bin's
best tree, drawn on a canvas from poses stored in the page.

Animations: trial 0 of the evaluation's own seed under the run's model profile, run in-process exactly as the
node graph runs it (``frames.frames_from_tree``, through the compiled kernels), every ``STRIDE``-th sensing
step, for the best tree of every filled bin of the objectives the run evolved (other objectives' bins show the
one of the same evaluation when there is one, else the command that renders it). Poses are packed as bytes
(``_pack``) so that a 25,000-evaluation run's page stays well under 5 MB.

``ws/run evolution_manager explorer RUN_DIR`` (re)builds it; the run writer builds it for every run. With
``--library LIB.json`` the page also shows a library of the ``library`` command on the grids
(``library_view``: block boundaries, this run's primitives on their bins, other runs' beside the grid),
through a style and a script that only such a page holds (``explorer_page.LIBRARY_STYLE`` and
``LIBRARY_SCRIPT``): without it the page is byte for byte what it was before the option existed.

A composition run's or a team run's folder (``config.json``'s ``kind``) gets its swarms' page instead
(``swarm_explorer``).
"""

from __future__ import annotations

import html
import json
import math
import sys
import time
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

from bt_controller.language import Library, LibraryError, library_from_json, load_library
from evolution_manager.arguments import EXIT_IO, OneLineParser
from evolution_manager.errors import ExplorerError, WriteError
from evolution_manager.evolution.run_config import evaluation_seed
from evolution_manager.evolution.shown_trees import simplified as simplified_text
from evolution_manager.files import printable, write_atomic
from evolution_manager.viewing.explorer_page import LIBRARY_SCRIPT, LIBRARY_STYLE, PAGE
from evolution_manager.viewing.explorer_parts import STRIDE
from evolution_manager.viewing.explorer_parts import actions as _actions
from evolution_manager.viewing.explorer_parts import arena as _arena
from evolution_manager.viewing.explorer_parts import check_tree as _check_tree
from evolution_manager.viewing.explorer_parts import evaluation_seeds as _evaluation_seeds
from evolution_manager.viewing.explorer_parts import pack as _pack
from evolution_manager.viewing.explorer_parts import palette as _palette
from evolution_manager.viewing.explorer_parts import read_object as _read
from evolution_manager.viewing.frames import frames_from_tree
from evolution_manager.viewing.swarm_explorer import swarm_kind, write_swarm_explorer
from swarm_ros.safe_paths import refuse_links
from swarm_sim.model import DEFAULT, OBJECTIVES
from swarm_sim.tasks import task_from_record


def _held_out_scores(root: Path, config: dict) -> dict[tuple[str, str, str], float]:
    """The held-out fitness of each bin's best tree from the run's ``heldout.json`` (written at the end of a
    run, ``evolution.heldout``), by (objective, bin, tree); empty when the run has none or the file belongs
    to another configuration."""
    path = root / "heldout.json"
    if not path.exists():
        return {}
    document = _read(path)
    if document.get("config") != config:
        return {}
    scores = {}
    for objective, metrics in document.get("objectives", {}).items():
        for row in metrics.get("bins", []):
            held = row.get("heldout_fitness")
            if isinstance(held, (int, float)) and math.isfinite(held):
                scores[(objective, ",".join(str(b) for b in row["bin"]), row["tree"])] = float(held)
    return scores


def _group_copies(items: list[dict]) -> list[dict]:
    """A bin's trees with those that simplify to the same tree shown once: the first (fittest) stands for the
    group, with ``copies`` (how many trees of the bin it stands for) and ``copy_trees`` (the others, as
    evolved)."""
    groups: dict[str, dict] = {}
    for entry in items:
        first = groups.setdefault(entry["simplified"], {**entry, "copies": 0, "copy_trees": []})
        first["copies"] += 1
        if first is not entry and entry["tree"] != first["tree"]:
            first["copy_trees"].append(entry["tree"])
    return list(groups.values())


def _seed_of(item: dict, seeds: dict[int, int], run_seed: int) -> int:
    evaluation = item.get("evaluation")
    if isinstance(item.get("seed"), int):
        return int(item["seed"])
    if isinstance(evaluation, int) and evaluation in seeds:
        return seeds[evaluation]

    return evaluation_seed(run_seed, int(evaluation or 0))


Progress = Callable[[int, int], None] | None


def explorer_data(root: Path, animate: bool = True, progress: Progress = None) -> dict:
    """Everything the page shows, read from the run directory ``root``."""
    root = Path(root)
    config = _read(root / "config.json") if (root / "config.json").exists() else {}
    summary = _read(root / "summary.json") if (root / "summary.json").exists() else {}
    metrics = summary.get("objectives", {})
    evolved = [o for o, m in metrics.items() if isinstance(m, dict) and m.get("evolved")]
    if not evolved and config.get("objective"):
        evolved = [config["objective"]]
    run_seed = int(config.get("seed", 0) or 0)
    objectives: dict[str, dict] = {}
    simplified: dict[str, str] = {}
    held_out = _held_out_scores(root, config)
    library = _library(root, config)

    for objective in OBJECTIVES:
        path = root / f"repertoire_{objective}.json"
        if not path.exists():
            continue
        document = _read(path)
        bins: dict[str, list[dict]] = {}
        for k, item in enumerate(_items(document, path)):
            tree = item["tree"]
            if tree not in simplified:  # the repertoire file holds it (simplified when it was written)
                _check_tree(tree, library, f"{path}: item {k}: tree")
                shown = item.get("simplified")
                if shown is not None:
                    _check_tree(shown, library, f"{path}: item {k}: simplified tree")
                simplified[tree] = shown or simplified_text(tree, library)
            entry = {
                "tree": tree,
                "simplified": simplified[tree],
                "fitness": item["fitness"],
                "descriptors": item["descriptors"],
                "evaluation": item.get("evaluation"),
            }
            key = ",".join(str(b) for b in item["bin"])
            held = held_out.get((objective, key, tree))
            if held is not None:
                entry["held_out"] = held
            bins.setdefault(key, []).append(entry)
        for key, items in bins.items():
            items.sort(key=lambda e: -e["fitness"])
            bins[key] = _group_copies(items)
        objectives[objective] = {
            "evolved": objective in evolved,
            "shape": document.get("shape", [8, 8, 8]),
            "descriptors": document.get("descriptors", ["movement", "rotation", "conditionality"]),
            "coverage": document.get("coverage"),
            "qd_score": document.get("qd_score"),
            "bins": bins,
        }
    if not objectives:
        raise ExplorerError(f"{root} holds no repertoire_<objective>.json: not a run directory")
    animations: dict[str, dict] = {}
    # the run's model: its task's world under its profile (the arena the page draws)
    try:
        task = task_from_record(config.get("task"), f"{root / 'config.json'}: task")
        model = task.config(config.get("profile") or DEFAULT.profile)
    except ValueError as error:  # a task or profile the model cannot run: no trial to show
        if animate:
            raise ExplorerError(str(error)) from None
        model = DEFAULT
    if animate:
        seeds = _evaluation_seeds(root)
        wanted = []
        for grid in objectives.values():
            if grid["evolved"] or not evolved:
                for items in grid["bins"].values():
                    wanted.append(items[0])
        for done, entry in enumerate(wanted, 1):
            seed = _seed_of(entry, seeds, run_seed)
            key = f"{entry['simplified']}|{seed}"
            if key not in animations:
                # The simplified tree sets the same motors: the same trial, a little faster to run.
                frames = frames_from_tree(entry["simplified"], seed, 0, model, library)
                animations[key] = _pack(frames, STRIDE, list(objectives))
            entry["animation"] = key
            if progress is not None:
                progress(done, len(wanted))
        for grid in objectives.values():
            for items in grid["bins"].values():
                for entry in items:
                    key = f"{entry['simplified']}|{_seed_of(entry, seeds, run_seed)}"
                    if key in animations:
                        entry["animation"] = key
                    entry["seed"] = str(_seed_of(entry, seeds, run_seed))
    return {
        "run": config.get("label") or printable(root.name),  # a name's bytes that are not UTF-8 as \xNN
        "seed": str(run_seed),
        "evaluations": summary.get("evaluations"),
        "evolved": evolved,
        "objectives": objectives,
        "animations": animations,
        "arena": _arena(model),
        "actions": _actions(),
        "palette": _palette(),
    }


def _items(document: dict, path: Path) -> list[dict]:
    """The items of a repertoire document, each with the fields the page shows; ExplorerError naming the
    file and the item otherwise."""
    items = document.get("items", [])
    if not isinstance(items, list):
        raise ExplorerError(f"{path}: items must be a list, got {type(items).__name__}")
    for k, item in enumerate(items):
        missing = [
            f
            for f in ("tree", "bin", "fitness", "descriptors")
            if not isinstance(item, dict) or f not in item
        ]
        if missing:
            raise ExplorerError(
                f"{path}: item {k} has no {', '.join(missing)}: not a repertoire file of a run"
            )
    return items


def _library(root: Path, config: dict) -> Library | None:
    """The run's copy of its primitive library (``library.json``), or None for a run without one."""
    path = root / "library.json"
    if not config.get("library") or not path.exists():
        return None
    try:
        return library_from_json(_read(path), str(config["library"]))
    except LibraryError as error:
        raise ExplorerError(str(error)) from None


def _shown_objectives(root: Path) -> list[str]:
    """The objectives whose grids the page of run directory ``root`` shows (its repertoire files)."""

    return [o for o in OBJECTIVES if (root / f"repertoire_{o}.json").exists()]


def load_library_file(path: Path | str) -> Library:
    """The library in ``path`` (a file of the ``library`` command); ExplorerError naming the file and what
    is wrong."""
    try:
        return load_library(path)
    except LibraryError as error:
        raise ExplorerError(f"{error}; expected a library file written by the library command") from None


def library_view(library: Library, root: Path, objectives: Sequence[str]) -> dict:
    """What the page shows of ``library`` on the grids of run directory ``root`` (whose page shows
    ``objectives``): its block count and, per shown primitive objective, its primitives chosen from this
    run (``here``: marked on their bins) and from other runs (``other``: listed beside the grid).

    Each primitive must say where it came from as ``library`` writes it (``source`` with ``run``,
    ``objective``, ``blocks``, ``block``, ``bin``, ``fitness``); a primitive's run is this run when the
    paths resolve alike (a relative path against the current folder, as the ``library`` command that wrote
    it resolved it, or against the library file's folder, where such commands are often run).
    ExplorerError when a primitive lacks that, when the primitives disagree on the block
    count, or when none is of an objective this run shows."""
    # late: the library module loads DEAP and qdpy (about 0.1 s), only for a page with --library
    from evolution_manager.evolution.libraries import BLOCKS, FAMILIES, block_of, variant

    here_path = Path(root).resolve()
    label = library.label
    config = _read(Path(root) / "config.json") if (Path(root) / "config.json").exists() else {}
    config_seed = config.get("seed")
    grids: dict[str, tuple[tuple[int, ...], dict[str, set[str]]] | None] = {}
    checks: list[tuple[dict[str, Any], tuple[tuple[int, ...], dict[str, set[str]]] | None, str]] = []

    def is_here(run: str) -> bool:
        bases = [Path.cwd(), Path(label).parent]  # the label of a library read from a file is its path
        return any((base / run).resolve() == here_path for base in bases)

    blocks: set[int] = set()
    by_objective: dict[str, dict[str, list[dict]]] = {}
    for primitive in library.primitives:
        source: dict[str, Any] = dict(primitive.source or {})
        where = f"library {label}: primitive {primitive.name!r}"
        missing = [k for k in ("run", "objective", "blocks", "block", "bin", "fitness") if k not in source]
        if missing:
            raise ExplorerError(
                f"{where} has no source {', '.join(missing)}: the explorer shows libraries written by the "
                "library command (each primitive's source names its run, objective, blocks, block and bin)"
            )
        objective, count = source["objective"], source["blocks"]
        if objective not in FAMILIES or not primitive.name.startswith(FAMILIES[str(objective)]):
            raise ExplorerError(
                f"{where}: source objective {objective!r} does not match its name (expected "
                + ", ".join(f"{o} for {f}<k>" for o, f in FAMILIES.items())
                + ")"
            )
        if count not in BLOCKS:
            raise ExplorerError(
                f"{where}: source blocks {count!r}; expected one of {', '.join(map(str, BLOCKS))}"
            )
        blocks.add(int(count))
        bins, block = source["bin"], source["block"]
        if not (_is_index(bins) and _is_index(block)):
            raise ExplorerError(
                f"{where}: source bin and block must be 3 bin numbers, got {bins!r}, {block!r}"
            )
        if isinstance(source["fitness"], bool) or not isinstance(source["fitness"], (int, float)):
            raise ExplorerError(f"{where}: source fitness must be a number, got {source['fitness']!r}")
        grid_of = grids.setdefault(str(objective), _grid_trees(root, str(objective)))
        shape = grid_of[0] if grid_of is not None else (8, 8, 8)
        if not all(b < n for b, n in zip(bins, shape, strict=True)):
            raise ExplorerError(f"{where}: source bin {bins} is outside the grid {list(shape)}")
        inside = list(block_of(bins, shape, BLOCKS[int(count)]))
        if inside != list(block):
            raise ExplorerError(
                f"{where}: source bin {bins} is outside its block {list(block)} (with {count} blocks that "
                f"bin lies in block {inside}): the source does not describe the primitive"
            )
        here = is_here(str(source["run"]))
        if here:  # checked once the library is known to be of this run's objectives
            checks.append((source, grid_of, where))
        entry = {
            "name": primitive.name,
            "block": list(block),
            "variant": variant(block, BLOCKS[int(count)]),
            "bin": ",".join(str(b) for b in bins),
            "fitness": source["fitness"],
            "derated_fitness": source.get("derated_fitness"),
            "run": str(source["run"]),
        }
        side = "here" if here else "other"
        grid = by_objective.setdefault(str(objective), {"here": [], "other": []})
        grid[side].append(entry)
    if len(blocks) > 1:
        raise ExplorerError(
            f"library {label}: its primitives mix block counts {sorted(blocks)}; expected one"
        )
    covered = [o for o in FAMILIES if o in by_objective]
    if not set(covered) & set(objectives):
        raise ExplorerError(
            f"library {label} holds primitives of {', '.join(covered) or 'no objective'}; the run {root} "
            f"shows {', '.join(objectives) or 'no objective'}: none in common"
        )
    for source, grid_of, where in checks:
        _check_source_here(source, config_seed, grid_of, root, where)
    count = blocks.pop()
    rivals = _block_winners(root, BLOCKS[count])
    for o, grid in by_objective.items():
        for entry in grid["other"]:
            entry["here"] = rivals.get(o, {}).get(entry["variant"])
    return {
        "file": label,
        "blocks": count,
        "bins": BLOCKS[count],
        "objectives": {
            o: {"family": FAMILIES[o], **by_objective[o]} for o in objectives if o in by_objective
        },
    }


def _grid_trees(root: Path, objective: str) -> tuple[tuple[int, ...], dict[str, set[str]]] | None:
    """The shape of the run's grid of ``objective`` and the trees each filled bin holds (by "i,j,k"), or
    None when the run has no repertoire of it."""
    path = Path(root) / f"repertoire_{objective}.json"
    if not path.exists():
        return None
    document = _read(path)
    shape = document.get("shape", [8, 8, 8])
    if not (isinstance(shape, list) and len(shape) == 3 and all(isinstance(n, int) and n > 0 for n in shape)):
        raise ExplorerError(f"{path}: shape must be 3 positive integers, got {shape!r}")
    trees: dict[str, set[str]] = {}
    for item in _items(document, path):
        trees.setdefault(",".join(str(b) for b in item["bin"]), set()).add(str(item["tree"]))
    return tuple(shape), trees


def _check_source_here(
    source: dict[str, Any],
    seed: object,
    grid: tuple[tuple[int, ...], dict[str, set[str]]] | None,
    root: Path,
    where: str,
) -> None:
    """Refuse a primitive said to come from the run in ``root`` that this run does not hold: another seed,
    no repertoire of its objective, or its source bin empty or holding other trees (the run directory was
    replaced by another run since the library was built)."""
    rebuild = "the library was built from another run: rebuild it from this one, or show it with that run"
    if "seed" in source and seed is not None and source["seed"] != seed:
        raise ExplorerError(
            f"{where} comes from a run of seed {source['seed']}; the run {root} has seed {seed}: {rebuild}"
        )
    bin_key = ",".join(str(b) for b in source["bin"])
    if grid is None:
        raise ExplorerError(
            f"{where} comes from {source['objective']} of the run {root}, which has no repertoire of it: "
            f"{rebuild}"
        )
    trees = grid[1].get(bin_key)
    if not trees:
        raise ExplorerError(
            f"{where} comes from bin {bin_key} of {source['objective']} of the run {root}, which is empty "
            f"there: {rebuild}"
        )
    if "tree" in source and source["tree"] not in trees:
        raise ExplorerError(
            f"{where} comes from bin {bin_key} of {source['objective']} of the run {root}, which holds other "
            f"trees there: {rebuild}"
        )


def _block_winners(root: Path, bins: int) -> dict[str, dict[int, dict]]:
    """Per primitive objective and block variant, the tree the ``library`` command would take from the run
    in ``root`` (``libraries.best_in_run``: its bin, fitness and derated fitness): what lost to another
    run's; empty for a run the command cannot read (one evolved with a library, say)."""
    # late, as in library_view
    from evolution_manager.evolution.libraries import (
        LibraryBuildError,
        best_in_run,
        block_of,
        read_run,
        variant,
    )

    try:
        run = read_run(root)
    except LibraryBuildError:
        return {}
    winners: dict[str, dict[int, dict]] = {}
    for objective, items in run.items.items():
        grouped: dict[int, list] = {}
        for item in items:
            grouped.setdefault(variant(block_of(item.bin, run.shape[objective], bins), bins), []).append(item)
        for k, members in grouped.items():
            best = best_in_run(members)
            if best is not None:
                winners.setdefault(objective, {})[k] = {
                    "bin": ",".join(map(str, best.bin)),
                    "fitness": best.fitness,
                    "derated_fitness": best.derated,
                }
    return winners


def _is_index(value: object) -> bool:
    return (
        isinstance(value, list)
        and len(value) == 3
        and all(isinstance(v, int) and not isinstance(v, bool) and v >= 0 for v in value)
    )


def write_explorer(
    root: Path | str, animate: bool = True, progress: Progress = None, library: Path | str | None = None
) -> Path:
    """Build ``explorer.html`` in the run directory ``root``; return its path. With ``library`` (a file of
    the ``library`` command) the page also shows that library's primitives on the grids (``library_view``);
    without it the page is what it always was, byte for byte."""
    root = Path(root)
    try:  # the page's place: a link planted there is refused before the animations' minutes
        refuse_links(root / "explorer.html")
    except OSError as error:
        raise ExplorerError(str(error)) from None
    if (root / "explorer.html").is_dir():
        raise ExplorerError(f"{root / 'explorer.html'} is a folder: the page cannot be written there")
    kind = swarm_kind(root)
    if kind is not None:  # a composition or team run: its swarms' page
        if library is not None:
            raise ExplorerError(
                f"--library shows a library on a tree run's grids; {root} is a {kind} run (no tree grids)"
            )
        return write_swarm_explorer(root, animate, progress)
    shown = None
    if library is not None:
        chosen = load_library_file(library)  # its errors before the animations' minutes
        if _shown_objectives(root):  # else explorer_data says what the folder lacks
            shown = library_view(chosen, root, _shown_objectives(root))
    data = explorer_data(root, animate, progress)
    page = PAGE
    if shown is None:
        page = page.replace("__LIBRARY_STYLE__", "").replace("__LIBRARY_SCRIPT__", "")
    else:
        data["library"] = shown
        page = page.replace("__LIBRARY_STYLE__", LIBRARY_STYLE).replace("__LIBRARY_SCRIPT__", LIBRARY_SCRIPT)
    page = page.replace("__TITLE__", html.escape(f"Repertoire explorer: {data['run']}"))
    payload = json.dumps(data, separators=(",", ":"), allow_nan=False).replace("</", "<\\/")
    page = page.replace("__DATA__", payload)
    path = root / "explorer.html"
    write_atomic(path, page)
    return path


def main(argv: Sequence[str] | None = None) -> int:
    """``explorer RUN_DIR``: (re)build a run directory's explorer.html."""

    parser = OneLineParser(prog="explorer", description="Build RUN_DIR/explorer.html.")
    parser.add_argument(
        "run", type=Path,
        help="a run directory: a tree run's (with repertoire_<objective>.json files), a composition "
        "run's or a team run's (its swarms' page: swarm_explorer)",
    )  # fmt: skip
    parser.add_argument("--no-animations", action="store_true", help="leave the trial animations out")
    parser.add_argument(
        "--library", type=Path, metavar="LIB.json",
        help="also show this library (of the library command) on the grids: its block boundaries, its "
        "primitives from this run on their bins, those from other runs in a table",
    )  # fmt: skip
    args = parser.parse_args(argv)
    started = time.monotonic()

    def progress(done: int, total: int) -> None:
        if done == total or done % 25 == 0:
            print(f"\ranimations {done}/{total}", end="", file=sys.stderr, flush=True)

    try:
        path = write_explorer(args.run, not args.no_animations, progress, args.library)
    except ExplorerError as error:
        print(f"explorer: error: {error}", file=sys.stderr)
        return 2
    except WriteError as error:  # a full disk, a read-only folder
        print(f"explorer: error: {error}", file=sys.stderr)
        return EXIT_IO
    print(file=sys.stderr)
    size = path.stat().st_size
    print(f"{printable(path)}: {size / 1e6:.2f} MB in {time.monotonic() - started:.1f} s")
    return 0


__all__ = ["ExplorerError", "explorer_data", "library_view", "load_library_file", "write_explorer"]
