"""Transfer in the foraging study's report: each arm's best forager scored in the authors' ARGoS simulation.

For every homogeneous arm (``foraging_study.ARMS``), the run with the highest in-run best fitness gives its
best forager (``summary.json``'s ``best_tree``, as evolved, primitives by name). The ARGoS harness's driver
evaluates it in the authors' 2024 foraging build (``--build foraging``: 100 s trials, five per run and two
runs per seed; deliveries per robot per trial) on seeds ``1..20``, the arm's library given to it as their
sub-behaviours file (``swarm_sim.validation.transfer.subs_text``), which their loop functions expand as ours
do (each name to ``success`` of its tree). It is set beside our held-out score of the same tree (5 fresh
scenarios of 10 trials).

The driver's rows are kept in the study folder, one raw file per library (``argos_raw_<library>.tsv``,
``argos_raw_flat.tsv`` for the flat node set: the driver keeps one sub-behaviours file per raw file), with
the sub-behaviours files beside them (``argos_subs_<library>.txt``); rows already there are not run again,
so the section is rebuilt without ARGoS once they are there.

The heterogeneous arms are not transferred: the harness's builds give every robot the tree of one
chromosome file, so a swarm with a tree per robot has no counterpart there.
"""

from __future__ import annotations

import math
import statistics as stats
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Protocol

from bt_controller.language import LibraryError, load_library
from evolution_manager.errors import UsageError
from evolution_manager.files import write_atomic
from swarm_sim.errors import UsageError as SimUsageError
from swarm_sim.validation import transfer

DEFAULT_SEEDS: tuple[int, ...] = tuple(range(1, 21))
"""The ARGoS seeds a report reads a forager's rows for unless told others (the report command's 1-20)."""

FLAT = "flat"
"""The raw file's name for foragers without a library."""


@dataclass(frozen=True)
class Forager:
    """An arm's best forager."""

    arm: str
    run: int
    tree: str
    best_fitness: float
    heldout: float | None
    library: str
    """The arm's library name, or "" for the flat node set."""


class ArmRunLike(Protocol):
    """What is read of a finished arm run (``foraging_study.ArmRun``)."""

    @property
    def arm(self) -> str: ...
    @property
    def index(self) -> int: ...
    @property
    def best_fitness(self) -> float: ...
    @property
    def heldout_best_fitness(self) -> float | None: ...
    @property
    def best_tree(self) -> str: ...


def best_foragers(runs: Sequence[ArmRunLike], libraries: dict[str, str]) -> list[Forager]:
    """Per arm named in ``libraries`` (arm -> library name, "" for none), in the runs' order of arms, the
    finished run of highest best fitness (the lower run index on ties) and its best tree."""
    picked: dict[str, Forager] = {}
    for run in runs:
        if run.arm not in libraries:
            continue
        known = picked.get(run.arm)
        if known is None or run.best_fitness > known.best_fitness:
            picked[run.arm] = Forager(
                run.arm,
                run.index,
                run.best_tree,
                run.best_fitness,
                run.heldout_best_fitness,
                libraries[run.arm],
            )
    return list(picked.values())


def _raw(root: Path, library: str) -> Path:
    return Path(root) / f"argos_raw_{library or FLAT}.tsv"


def _subs(root: Path, library: str) -> Path:
    return Path(root) / f"argos_subs_{library}.txt"


def measure(
    root: Path, foragers: Sequence[Forager], driver: str | None, seeds: Sequence[int], jobs: int = 1
) -> None:
    """Evaluate in ARGoS's foraging build every (forager, seed) not yet in its library's raw file.
    UsageError when the harness, its build or a library is missing, or the driver fails."""
    root = Path(root)
    try:
        for library in dict.fromkeys(f.library for f in foragers):
            trees = [f.tree for f in foragers if f.library == library]
            have = transfer.read_foraging_raw(_raw(root, library))
            if all((tree, s) in have for tree in trees for s in seeds):
                continue
            subs = None
            if library:
                try:
                    primitives = load_library(root / "libraries" / f"{library}.json").primitives
                except LibraryError as error:
                    raise UsageError(str(error)) from None
                subs = _subs(root, library)
                write_atomic(subs, transfer.subs_text((p.name, p.text) for p in primitives))
            harness = transfer.ArgosHarness.from_environment(driver)
            harness.run(trees, seeds, _raw(root, library), jobs, root, build="foraging", subs=subs)
    except SimUsageError as error:
        raise UsageError(str(error)) from None
    finally:
        (root / "transfer_trees.txt").unlink(missing_ok=True)


@dataclass(frozen=True)
class Scored:
    """A forager with ARGoS's deliveries per robot per trial over the seeds."""

    forager: Forager
    argos: float
    argos_sem: float
    argos_n: int


def scored(root: Path, foragers: Sequence[Forager], seeds: Sequence[int]) -> tuple[list[Scored], int]:
    """The foragers with every seed in their raw file, with ARGoS's mean and standard error; and how many
    foragers lack rows."""
    done = []
    for f in foragers:
        try:
            rows = transfer.read_foraging_raw(_raw(root, f.library))
        except SimUsageError as error:
            raise UsageError(str(error)) from None
        values = [rows[(f.tree, s)] for s in seeds if (f.tree, s) in rows]
        if len(values) == len(seeds):
            sem = stats.stdev(values) / math.sqrt(len(values)) if len(values) > 1 else 0.0
            done.append(Scored(f, stats.fmean(values), sem, len(values)))
    return done, len(foragers) - len(done)


def section(rows: Sequence[Scored], missing: int, seeds: Sequence[int], swarm_arms: Sequence[str]) -> str:
    """The report's section: each arm's best forager here and in ARGoS."""
    seed_text = transfer.seeds_text(seeds)
    lines = [
        "\n## Transfer: each arm's best forager in the authors' ARGoS\n",
        "Each homogeneous arm's best forager (the run of highest in-run fitness) scored in the authors' 2024 "
        f"foraging code (through the project's harness, `--build foraging`; seeds {seed_text}, each ten "
        "100 s trials on fresh start poses, wheel gains and message drops, the arm's library given as "
        "their sub-behaviours file) beside our held-out score of the same tree (5 fresh scenarios of 10 "
        "trials). Deliveries per robot per trial; ARGoS: mean ± standard error over the seeds; its rows "
        "in `argos_raw_<library>.tsv`.\n",
    ]
    if missing:
        lines.append(
            f"**{missing} best foragers are not yet scored in ARGoS** and are left out (`report DIR "
            "--argos-eval DRIVER` scores them).\n"
        )
    lines += [
        "| arm | run | library | in-run best | held-out | ARGoS | held-out - ARGoS |",
        "|---|---|---|---|---|---|---|",
    ]
    for r in rows:
        f = r.forager
        held = "n/a" if f.heldout is None else f"{f.heldout:.3f}"
        diff = "n/a" if f.heldout is None else f"{f.heldout - r.argos:+.3f}"
        lines.append(
            f"| {f.arm} | {f.run} | {f.library or 'none'} | {f.best_fitness:.3f} | {held} "
            f"| {r.argos:.3f} ± {r.argos_sem:.3f} | {diff} |"
        )
    if swarm_arms:
        lines.append(
            f"\nNot transferred: {', '.join(swarm_arms)} (heterogeneous swarms): the harness's builds give "
            "every robot the same chromosome, so a tree per robot has no counterpart there."
        )
    return "\n".join(lines) + "\n"


__all__ = ["Forager", "Scored", "best_foragers", "measure", "scored", "section"]
