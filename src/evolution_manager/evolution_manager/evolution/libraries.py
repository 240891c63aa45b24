"""Primitive libraries made from the repertoires of evolved primitives (the ``library`` command).

The authors' 2024 follow-up builds its named primitives from the final grids of their six primitives
(``docs/algorithms.md``, "Primitive libraries from repertoires"; their code at a73e4af:
``charts/sub-behaviours.py:26-66``, ``analysis.py:1296-1358``). This module does the same from our run
directories (``repertoire_<objective>.json``, ``config.json`` and ``heldout.json`` of ``evolve`` or
``experiment`` runs), and writes a library that ``--library`` reads (``bt_controller.language.library``):

1. **Families.** Each primitive objective has a family name (``FAMILIES``; the primitive's own objective as
   the authors' ARGoS code measures it, ``docs/validation/README.md``): density ``increaseDensity``, nest
   ``gotoNest``, food ``gotoFood``, idensity ``reduceDensity``, inest ``goAwayFromNest``, ifood
   ``goAwayFromFood``. A run gives the repertoire of each primitive objective it evolved (GP_o and QD_o one,
   GP_fnd each of its set).
2. **Blocks.** The 8 x 8 x 8 grid (movement, rotation, conditionality) is cut into ``bins``^3 blocks, bins =
   1, 2 or 4 for 1, 8 or 64 blocks. Block (a, b, c) is variant ``k = a bins^2 + b bins + c + 1``: for 8 blocks
   the authors' 4a + 2b + c + 1 (``charts/sub-behaviours.py:47``), so variants 1-4 are the movement < 0 half;
   1 block is variant 1; 64 blocks (which the authors add only in 593fc03, 2025) number the same way. The
   primitive of family F and block k is named ``F<k>``; a block that no run fills has no primitive.
3. **Within a run** (one seed) the block's tree is the item of highest *derated* fitness f (1 - max(0,
   len - 10) / 990), len the number of nodes of the tree as evolved (``operators.derating``): the authors
   take the best item per cell and then the best cell, both by derated fitness (foraging.md section 4 item
   3). Exact ties go to the first item in the repertoire file's order (our choice; the authors' is not
   stated).
4. **Across runs** the runs' winners are compared by *raw* fitness under the ``paper`` profile (the authors'
   rule, foraging.md item 4, artefact A5), by derated fitness under ``clean`` (section 6). Exact ties go to
   the run named first. Every run must have the same profile.
5. **Simplified.** The winner is simplified with ``bt_controller.language.simplify`` (the same motors on every
tick;
   the authors strip redundancy likewise, ``redundancy.py:1871-1908``, which also keeps motors and not
   conditionality), and its draw keys are dropped: in a composed tree each use of a primitive is a copy
   whose probabilistic nodes then draw with their own pre-order index, independently of every other copy,
   as the authors' separate copies do. (A copy's draws cannot be those of the tree as evolved in any case:
   the ``success`` around it moves every index.)

Each entry's ``source`` records the run directory, its algorithm, seed and profile, the objective, bin and
block, the tree as evolved, its number of nodes, fitness and derated fitness, evaluation index, and its
held-out fitness when the run's ``heldout.json`` scored it (it scores each bin's fittest tree; a bin whose
derated-best tree is another has none: ``null``).
"""

from __future__ import annotations

import math
import sys
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path

from bt_controller.errors import TreeError
from bt_controller.language import (
    LIBRARY_FORMAT,
    Library,
    library_from_json,
    parse,
    simplify_if_small,
    to_text,
    without_draw_keys,
)
from evolution_manager.arguments import EXIT_IO, EXIT_USAGE, Parser
from evolution_manager.errors import EvolutionError, RunDirectoryError, UsageError, WriteError
from evolution_manager.evolution.operators import selection_fitness
from evolution_manager.evolution.run import RunDirectory
from evolution_manager.files import read_json, read_json_object, write_json
from swarm_ros.safe_paths import check_output
from swarm_sim.model import FAMILIES
from swarm_sim.tasks import DEFAULT_TASK, TaskSpec, task_label, task_named

BLOCKS: dict[int, int] = {1: 1, 8: 2, 64: 4}
"""Blocks per grid -> bins per descriptor (``bins``^3 blocks)."""


class LibraryBuildError(EvolutionError):
    """Runs that cannot make a library; the message names the run or file and what was expected."""


@dataclass(frozen=True)
class Item:
    """One tree of a run's repertoire of one objective."""

    bin: tuple[int, ...]
    tree: str
    fitness: float
    nodes: int
    """Nodes of the tree as evolved: what the derating counts."""
    evaluation: int | None

    @property
    def derated(self) -> float:
        """The fitness selection compares (``operators.selection_fitness``)."""
        return selection_fitness(self.fitness, self.nodes)


@dataclass(frozen=True)
class RunRepertoires:
    """What one run directory offers a library: its configuration and, per primitive objective it evolved,
    the items of its repertoire in the file's order and the held-out fitness of the trees ``heldout.json``
    scored (keyed by bin and tree)."""

    path: Path
    seed: int
    algorithm: str
    profile: str
    shape: dict[str, tuple[int, ...]]
    items: dict[str, tuple[Item, ...]]
    heldout: dict[str, dict[tuple[tuple[int, ...], str], float]]
    task: TaskSpec = field(default_factory=lambda: task_named(DEFAULT_TASK))
    """The run's task (``swarm_sim.tasks``), which its raw fitness depends on."""


def read_run(path: Path) -> RunRepertoires:
    """The repertoires of the primitive objectives the run in ``path`` evolved; LibraryBuildError naming
    the run and what is missing or damaged."""
    directory = RunDirectory(Path(path))
    if not directory.started():
        raise LibraryBuildError(f"{path} is not a run directory (no config.json)")
    try:
        config = directory.read_config()
    except RunDirectoryError as error:
        raise LibraryBuildError(str(error)) from None
    if config.library:
        raise LibraryBuildError(
            f"{path} was evolved with a primitive library ({config.library}); a library's trees name no "
            "primitives: give runs of the primitives themselves"
        )
    objectives = [o for o in config.objectives if o in FAMILIES]
    if not objectives:
        raise LibraryBuildError(
            f"{path} evolved {', '.join(config.objectives)}, no primitive objective "
            f"(expected one of {', '.join(FAMILIES)})"
        )
    heldout_document = _heldout(directory, config.to_json())
    shapes, items, heldout = {}, {}, {}
    for objective in objectives:
        file = directory.repertoire(objective)
        if not file.exists():
            raise LibraryBuildError(
                f"{path} has no repertoire of {objective} ({file.name}); a finished evolve or experiment run "
                "writes one"
            )
        try:
            shapes[objective], items[objective] = _repertoire(file, objective)
        except (RunDirectoryError, TreeError, ValueError, TypeError, KeyError) as error:
            raise LibraryBuildError(f"{file} is damaged: {error}") from None
        heldout[objective] = _heldout_fitness(heldout_document, objective)
    return RunRepertoires(
        Path(path), config.seed, config.algorithm, config.profile, shapes, items, heldout, config.task
    )


def _repertoire(file: Path, objective: str) -> tuple[tuple[int, ...], tuple[Item, ...]]:
    document = read_json_object(file)
    if document.get("objective") != objective:
        raise ValueError(f"it holds objective {document.get('objective')!r}, expected {objective!r}")
    shape = tuple(document["shape"])
    if len(shape) != 3 or not all(isinstance(n, int) and n > 0 for n in shape):
        raise ValueError(f"shape must be 3 positive integers, got {document['shape']!r}")
    items = []
    for k, raw in enumerate(document["items"]):
        where = f"item {k}: "
        index = tuple(raw["bin"])
        if len(index) != 3 or not all(
            isinstance(i, int) and 0 <= i < n for i, n in zip(index, shape, strict=True)
        ):
            raise ValueError(f"{where}bin {raw['bin']!r} is outside the grid {list(shape)}")
        fitness = raw["fitness"]
        if isinstance(fitness, bool) or not isinstance(fitness, (int, float)) or not math.isfinite(fitness):
            raise ValueError(f"{where}fitness must be a number, got {fitness!r}")
        text = raw["tree"]
        if not isinstance(text, str):
            raise ValueError(f"{where}tree must be tree text, got {type(text).__name__}")
        evaluation = raw.get("evaluation")
        items.append(Item(index, text, float(fitness), parse(text).size, evaluation))
    return shape, tuple(items)


def _heldout(directory: RunDirectory, config: dict) -> dict | None:
    """The run's ``heldout.json`` when it belongs to the run's configuration, else None."""
    path = directory.root / "heldout.json"
    if not path.exists():
        return None
    try:
        document = read_json(path)
    except RunDirectoryError as error:
        raise LibraryBuildError(str(error)) from None
    return document if isinstance(document, dict) and document.get("config") == config else None


def _heldout_fitness(document: dict | None, objective: str) -> dict[tuple[tuple[int, ...], str], float]:
    if document is None:
        return {}
    bins = document.get("objectives", {}).get(objective, {}).get("bins", [])
    return {
        (tuple(b["bin"]), b["tree"]): b["heldout_fitness"]
        for b in bins
        if b.get("heldout_fitness") is not None
    }


def block_of(index: Sequence[int], shape: Sequence[int], bins: int) -> tuple[int, ...]:
    """The block (a, b, c) of grid bin ``index`` when each descriptor's ``shape[d]`` bins are cut into
    ``bins`` equal blocks."""
    return tuple(i * bins // n for i, n in zip(index, shape, strict=True))


def variant(block: Sequence[int], bins: int) -> int:
    """The variant number of ``block``: ``a bins^2 + b bins + c + 1`` (4a + 2b + c + 1 for 8 blocks)."""
    a, b, c = block
    return a * bins * bins + b * bins + c + 1


def best_in_run(items: Sequence[Item]) -> Item | None:
    """The item of highest derated fitness (the first of exact ties), or None for no items."""
    best = None
    for item in items:
        if best is None or item.derated > best.derated:
            best = item
    return best


def best_across_runs(winners: Sequence[Item | None], profile: str) -> int | None:
    """The index of the run whose winner the library takes: highest raw fitness under ``paper`` (A5),
    highest derated fitness under ``clean``; the first of exact ties; None when no run has a winner."""
    best = None
    for k, item in enumerate(winners):
        if item is None:
            continue
        value = item.fitness if profile == "paper" else item.derated
        if best is None or value > best[0]:
            best = (value, k)
    return None if best is None else best[1]


def library_entry_tree(text: str) -> str:
    """The tree text a library stores for a winner given as evolved: simplified, without draw keys."""
    return to_text(without_draw_keys(simplify_if_small(parse(text))))


def build_library(runs: Sequence[RunRepertoires], blocks: int, label: str = "library") -> Library:
    """The library of the primitives of ``runs`` with ``blocks`` blocks per grid (module docstring)."""
    if blocks not in BLOCKS:
        raise LibraryBuildError(f"blocks must be one of {', '.join(map(str, BLOCKS))}, got {blocks}")
    if not runs:
        raise LibraryBuildError("no runs given")
    profiles = sorted({run.profile for run in runs})
    if len(profiles) > 1:
        named = ", ".join(f"{run.path} ({run.profile})" for run in runs)
        raise LibraryBuildError(f"the runs mix profiles {' and '.join(profiles)}: {named}; give runs of one")
    profile = profiles[0]
    tasks = sorted({task_label(run.task) for run in runs})
    if len({run.task for run in runs}) > 1:
        named = ", ".join(
            f"{run.path} ({task_label(run.task)}, {run.task.trial_seconds:g} s)" for run in runs
        )
        raise LibraryBuildError(
            f"the runs mix tasks, {' and '.join(tasks)}: {named}; their fitness is not comparable: give runs "
            "of one task"
        )
    bins = BLOCKS[blocks]
    for run in runs:
        for objective, shape in run.shape.items():
            if any(n % bins for n in shape):
                raise LibraryBuildError(
                    f"{run.path}: the grid of {objective} is {'x'.join(map(str, shape))}, which {blocks} "
                    "blocks do not divide evenly"
                )
    entries: list[dict[str, object]] = []
    for objective, family in FAMILIES.items():
        offering = [run for run in runs if objective in run.items]
        if not offering:
            continue
        per_run: list[dict[int, list[Item]]] = []
        for run in offering:
            grouped: dict[int, list[Item]] = {}
            for item in run.items[objective]:
                block = block_of(item.bin, run.shape[objective], bins)
                grouped.setdefault(variant(block, bins), []).append(item)
            per_run.append(grouped)
        for k in range(1, blocks + 1):
            winners = [best_in_run(grouped.get(k, ())) for grouped in per_run]
            chosen = best_across_runs(winners, profile)
            if chosen is None:
                continue  # an empty block in every run: no primitive
            run, winner = offering[chosen], winners[chosen]
            assert winner is not None  # best_across_runs chose a run with a winner
            held = run.heldout[objective].get((winner.bin, winner.tree))
            source = {
                "run": str(run.path),
                "algorithm": run.algorithm,
                "seed": run.seed,
                "profile": profile,
                "objective": objective,
                "blocks": blocks,
                "block": list(block_of(winner.bin, run.shape[objective], bins)),
                "bin": list(winner.bin),
                "tree": winner.tree,
                "nodes": winner.nodes,
                "fitness": winner.fitness,
                "derated_fitness": winner.derated,
                "evaluation": winner.evaluation,
                "heldout_fitness": held,
            }
            tree = library_entry_tree(winner.tree)
            entries.append({"name": f"{family}{k}", "tree": tree, "source": source})
    if not entries:
        named = ", ".join(str(run.path) for run in runs)
        raise LibraryBuildError(
            f"the repertoires of {named} hold no tree (every block is empty), so the library would have 0 "
            "primitives: give runs whose repertoires have filled bins"
        )
    return library_from_json({"format": LIBRARY_FORMAT, "primitives": entries}, label)


def build_parser() -> Parser:
    parser = Parser(
        prog="library",
        description="Build a primitive library (JSON, for --library) from the repertoires of runs that "
        "evolved the six primitives: per primitive and block of its grid, the authors' choice of tree, "
        "simplified.",
    )
    parser.add_argument(
        "--from", dest="runs", type=Path, nargs="+", required=True, metavar="RUN_DIR",
        help="run directories of evolve or experiment (their repertoire_<objective>.json); one profile",
    )  # fmt: skip
    parser.add_argument(
        "--blocks", type=int, default=8, metavar="1|8|64",
        help="blocks per grid: one primitive per block and family (default 8, the authors' qd8)",
    )  # fmt: skip
    parser.add_argument(
        "--out", type=Path, required=True, metavar="LIB.json", help="the library file (new, unless --force)"
    )
    parser.add_argument("--force", action="store_true", help="overwrite an --out that exists")
    return parser


def library_command(argv: Sequence[str] | None = None) -> int:
    """Run ``library``; return the exit status."""
    try:
        args = build_parser().parse_args(argv)
        if args.blocks not in BLOCKS:
            raise UsageError(f"--blocks must be 1, 8 or 64, got {args.blocks}")
        try:  # the workspace's rule for outputs: a link never, a file there only with --force
            check_output(args.out, args.force)
        except OSError as error:
            raise UsageError(str(error)) from None
        if not args.out.parent.is_dir():
            raise UsageError(f"--out {args.out}: no folder {args.out.parent}")
        named = [str(p) for p in args.runs]
        twice = sorted({p for p in named if named.count(p) > 1})
        if twice:
            raise UsageError(f"--from names {twice[0]} twice")
        runs = [read_run(path) for path in args.runs]
        library = build_library(runs, args.blocks, str(args.out))
    except (UsageError, EvolutionError) as error:
        print(f"library: error: {error}", file=sys.stderr)
        return EXIT_USAGE
    try:
        write_json(args.out, library.as_json())
    except (WriteError, OSError) as error:
        print(f"library: error: {args.out} cannot be written: {error}", file=sys.stderr)
        return EXIT_IO
    counts = {family: 0 for family in FAMILIES.values()}
    for primitive in library.primitives:
        counts[primitive.name.rstrip("0123456789")] += 1
    shown = ", ".join(f"{family} {n}" for family, n in counts.items() if n)
    print(
        f"{args.out}: {len(library.primitives)} primitives ({shown}) from {len(runs)} runs, "
        f"{args.blocks} blocks"
    )
    return 0


def main() -> None:
    """Console entry point of ``library``."""
    sys.exit(library_command())


if __name__ == "__main__":
    main()
