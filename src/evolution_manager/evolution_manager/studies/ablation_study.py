"""``experiment --study ablation``: what the 8-block QD library's advantage comes from (issue 38).

    ws/run evolution_manager experiment --study ablation --primitives-from experiments/foraging \\
        --runs 10 --out experiments/foraging-ablation

Every arm is a high-level run on the foraging task with the foraging study's hierarchical settings (its
profile, trials and scenario; ``--evaluations`` individuals, the study's 25,000 by default), over a library of
its own (``libraries/<name>.json``, the ``library`` command's format, each primitive's ``source`` saying where
it came from):

- ``elite8``: the study's ``qd8`` library as it is (the best primitive of each block), copied, not rebuilt:
  the reference;
- ``random8``: for each family and block, one primitive drawn uniformly from every tree that the block holds
  in any of the study's QD runs of that family, instead of the best (simplified as the ``library`` command
  simplifies its winners);
- ``unevolved8``: random trees never evolved (``bt_controller.language.random_trees.random_tree``), each with
the node
  count of the ``elite8`` primitive of its name;
- ``padded1``: the study's ``qd1`` library (one primitive per family), each primitive copied to eight names,
  so that the node set has ``elite8``'s 48 names;
- ``me8``: MAP-Elites (``qd``) instead of GP at the high level, over the ``elite8`` library.

Seeds: run ``r`` of arm ``a`` gets ``derive_seed(--seed, RUN_STUDY, ABLATION_STAGE, RUNS_KEY, a, r)``; the
draws of the library of arm ``a`` come from ``numpy.random.default_rng(derive_seed(--seed, RUN_STUDY,
ABLATION_STAGE, LIBRARIES_KEY, a))``, recorded in the plan; neither depends on ``--runs``, so ``--runs`` grows
a study (``planning.more_runs``) without touching its libraries or its runs.

The report (``report.md``, ``runs.csv`` with ``arm, run, seed, best_fitness, heldout_best_fitness``) gives
each arm's held-out and in-run best fitness (median with its 95 % percentile bootstrap interval, interquartile
range) and tests each ablation arm against ``elite8`` on the held-out best fitness (``foraging_tables.tests``:
Shapiro-Wilk, then two-sided Welch's t or Mann-Whitney U, the tested difference with its bootstrap interval,
Cohen's d and Vargha-Delaney A), Holm-corrected over those four tests, one family.
"""

from __future__ import annotations

import argparse
import csv
import io
import os
import statistics as stats
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import cast

import numpy as np

from bt_controller.draws import RUN_STUDY, derive_seed
from bt_controller.language import (
    LIBRARY_FORMAT,
    Library,
    LibraryError,
    library_from_json,
    load_library,
    parse,
    random_tree,
)
from evolution_manager.errors import EvolutionError, UsageError
from evolution_manager.evolution.libraries import (
    BLOCKS,
    FAMILIES,
    Item,
    RunRepertoires,
    block_of,
    library_entry_tree,
    read_run,
    variant,
)
from evolution_manager.evolution.run_config import RunConfig
from evolution_manager.files import read_json, write_atomic, write_json
from evolution_manager.studies import foraging_tables, intervals
from evolution_manager.studies.planning import (
    finished_foraging_runs,
    foraging_study_plan,
    primitives_study_document,
    primitives_study_forager,
)
from swarm_sim.tasks import task_named

ABLATION_STAGE = 5
"""The stage index of this study's seeds (the foraging study uses 0 to 3, the replication study 4)."""
RUNS_KEY = 0
LIBRARIES_KEY = 1
"""Below ``ABLATION_STAGE``: the runs' seeds, and the seeds of the libraries' draws."""

BLOCKS_PER_GRID = 8


@dataclass(frozen=True)
class AblationArm:
    """One arm: its high-level algorithm and the library it evolves over."""

    name: str
    algorithm: str
    library: str
    what: str


ARMS: tuple[AblationArm, ...] = (
    AblationArm(
        "elite8", "gp", "elite8", "the study's qd8 library (best primitive of each block): reference"
    ),
    AblationArm(
        "random8", "gp", "random8", "a primitive drawn at random from each block instead of the best"
    ),
    AblationArm("unevolved8", "gp", "unevolved8", "random unevolved trees of the elite8 primitives' sizes"),
    AblationArm("padded1", "gp", "padded1", "the study's qd1 library, each primitive copied to 8 names"),
    AblationArm("me8", "qd", "elite8", "MAP-Elites instead of GP at the high level over elite8"),
)
REFERENCE = "elite8"
"""The arm every other arm is tested against."""

LIBRARIES: dict[str, str] = {
    "elite8": "copied from the foraging study's libraries/qd8.json",
    "random8": "a tree drawn uniformly from each family's block over the study's QD runs, simplified",
    "unevolved8": "bt_controller.language.random_trees.random_tree of each elite8 primitive's node count",
    "padded1": "the foraging study's libraries/qd1.json, each primitive copied to eight names",
}
"""Library name -> how it is made."""

DRAWN = ("random8", "unevolved8")
"""The libraries made by random draws (each from a generator of its own seed, in the plan)."""

METRIC = "held-out best fitness"
"""The metric the tests are made on (``foraging_tables.METRICS``)."""

CSV_HEADER = ["arm", "run", "seed", "best_fitness", "heldout_best_fitness"]


def _source_plan(source: Path) -> dict:
    try:
        document = foraging_study_plan(source)
    except (EvolutionError, OSError):  # unreadable: said as for another kind of folder
        raise UsageError(
            f"--primitives-from {source} is not a foraging study folder (experiment.json)"
        ) from None
    for name in ("qd8", "qd1"):
        if not (source / "libraries" / f"{name}.json").exists():
            raise UsageError(f"--primitives-from {source} has no libraries/{name}.json yet")
    return document


def library_seed(seed: int, arm_index: int) -> int:
    """The seed of the generator that draws the library of arm ``arm_index``'s name."""
    return derive_seed(seed, RUN_STUDY, ABLATION_STAGE, LIBRARIES_KEY, arm_index)


def plan_study(
    args: argparse.Namespace, scenarios: str, design: str | None
) -> tuple[dict, list, dict[str, int]]:
    """The study's plan document, its one stage and the budget of every run, from the command line."""
    if args.primitives_from is None:
        raise UsageError("--study ablation needs --primitives-from FOLDER, a foraging study's folder")
    source_folder = Path(args.primitives_from)
    source = _source_plan(source_folder)
    for option, value in (("profile", args.profile), ("trials", args.trials)):
        if value is not None and value != source[option]:
            raise UsageError(f"--{option} {value} differs from the primitives' study ({source[option]})")
    scenario_seed = source["scenario_seed"] if source["design"] == "shared" else None
    qd_runs = [str(entry["dir"]) for entry in source["primitives"] if entry["config"]["algorithm"] == "qd"]
    index = {arm.name: a for a, arm in enumerate(ARMS)}
    libraries: dict[str, dict[str, object]] = {name: {"how": how} for name, how in LIBRARIES.items()}
    for name in DRAWN:
        libraries[name]["seed"] = library_seed(args.seed, index[name])
    libraries["elite8"]["from"] = ["libraries/qd8.json"]
    libraries["padded1"]["from"] = ["libraries/qd1.json"]
    libraries["random8"]["from"] = qd_runs
    libraries["unevolved8"]["from"] = ["libraries/qd8.json"]
    plan = [
        {
            "arm": arm.name,
            "algorithm": arm.algorithm,
            "library": arm.library,
            "dir": f"arms/{arm.name}/run{r:02d}",
            "evaluations": args.evaluations,
            "seed": derive_seed(args.seed, RUN_STUDY, ABLATION_STAGE, RUNS_KEY, a, r),
        }
        for a, arm in enumerate(ARMS)
        for r in range(args.runs)
    ]
    document, budgets = primitives_study_document(
        "ablation", source_folder, source, args, scenarios, scenario_seed, libraries, "plan", plan
    )
    out = Path(args.out).absolute()
    primitives_folder = source_folder.absolute()

    def foragers() -> list[tuple[RunConfig, str]]:
        built = {
            name: ablation_library(name, out / "libraries", primitives_folder, libraries[name])
            for name in LIBRARIES
        }
        return [
            primitives_study_forager(
                entry,
                str(entry["algorithm"]),
                source,
                scenarios,
                scenario_seed,
                built[str(entry["library"])].label,
                built[str(entry["library"])].digest,
            )
            for entry in plan
        ]

    return document, [foragers], budgets


def ablation_library(name: str, folder: Path, source: Path, spec: Mapping[str, object]) -> Library:
    """The library ``name`` of the study whose libraries are in ``folder``: the file when an earlier session
    made it, else made from the foraging study in ``source`` (``spec``: its plan entry, with the seed of its
    draws) and written, its primitives' source runs relative to ``folder``."""
    path = Path(folder) / f"{name}.json"
    if path.exists():
        try:
            return load_library(path)
        except LibraryError as error:
            raise EvolutionError(f"{error}; remove it to make it again") from None
    try:
        elite = load_library(source / "libraries" / "qd8.json")
        if name == "elite8":
            entries = copied(elite, source / "libraries", folder, name)
        elif name == "padded1":
            entries = padded(load_library(source / "libraries" / "qd1.json"), source / "libraries", folder)
        elif name == "unevolved8":
            seed = int(str(spec["seed"]))
            entries = unevolved(elite, np.random.default_rng(seed), seed)
        elif name == "random8":
            runs = [
                read_run(source / str(rel)) for rel in cast("list[str]", spec["from"])
            ]  # the plan entry's runs
            entries = drawn(runs, BLOCKS_PER_GRID, np.random.default_rng(int(str(spec["seed"]))), folder)
        else:
            raise EvolutionError(f"no library {name!r} in the ablation study")
    except LibraryError as error:
        raise EvolutionError(str(error)) from None
    document = {"format": LIBRARY_FORMAT, "primitives": entries}
    folder.mkdir(parents=True, exist_ok=True)
    write_json(path, document)
    return library_from_json(document, str(path))


def _moved(source: Mapping[str, object] | None, old: Path, new: Path) -> dict[str, object]:
    """A primitive's ``source`` with its run, relative to the folder ``old``, made relative to ``new``."""
    moved = dict(source or {})
    if "run" in moved:
        moved["run"] = os.path.relpath(os.path.normpath(Path(old).absolute() / str(moved["run"])), new)
    return moved


def copied(library: Library, old: Path, new: Path, arm: str) -> list[dict[str, object]]:
    """The entries of ``library`` (a file in the folder ``old``) as they stand in the folder ``new``: the same
    names and trees (so the same digest), the source runs relative to ``new``, and where the copy came
    from."""
    origin = os.path.relpath(Path(old).absolute() / Path(library.label).name, new)
    return [
        {
            "name": p.name,
            "tree": p.text,
            "source": {**_moved(p.source, old, new), "ablation": {"arm": arm, "copied_from": origin}},
        }
        for p in library.primitives
    ]


def padded(library: Library, old: Path, new: Path) -> list[dict[str, object]]:
    """A 1-block library padded to ``BLOCKS_PER_GRID`` copies of each primitive: ``F1`` becomes ``F1`` to
    ``F8``, every copy the same tree, so that the node set has as many names as an 8-block library's."""
    origin = os.path.relpath(Path(old).absolute() / Path(library.label).name, new)
    entries: list[dict[str, object]] = []
    for p in library.primitives:
        family = p.name.rstrip("0123456789")
        for k in range(1, BLOCKS_PER_GRID + 1):
            ablation = {"arm": "padded1", "copied_from": origin, "copy_of": p.name, "copy": k}
            entries.append(
                {
                    "name": f"{family}{k}",
                    "tree": p.text,
                    "source": {**_moved(p.source, old, new), "ablation": ablation},
                }
            )
    return entries


def unevolved(library: Library, rng: np.random.Generator, seed: int) -> list[dict[str, object]]:
    """For each primitive of ``library``, in order, a random tree (``random_tree``) of its node count under
    its name, drawn from ``rng`` (made from ``seed``, which the sources record), its leaves of the node set
    the primitives were evolved with (the ``primitives`` task's: no ``got_food``)."""
    nodes = task_named("primitives").nodes
    entries: list[dict[str, object]] = []
    for p in library.primitives:
        size = parse(p.text).size
        tree = random_tree(rng, size, conditions=nodes.conditions, actions=nodes.actions)
        source = {
            "ablation": {
                "arm": "unevolved8",
                "generator": "bt_controller.language.random_trees.random_tree, the primitives task's nodes",
                "rng": f"numpy.random.default_rng({seed}), drawn in the library's order",
                "nodes": size,
                "size_of": {"name": p.name, "tree": p.text},
            }
        }
        entries.append({"name": p.name, "tree": str(tree), "source": source})
    return entries


def drawn(
    runs: Sequence[RunRepertoires], blocks: int, rng: np.random.Generator, folder: Path
) -> list[dict[str, object]]:
    """For each family and block (``libraries.build_library``'s families, blocks and names), one tree drawn
    uniformly from ``rng`` among every item of that block in every run of ``runs`` (the runs in order, each
    repertoire in its file's order), simplified as a library entry; its source as ``build_library`` writes
    it, the run relative to ``folder``, with the draw."""
    bins = BLOCKS[blocks]
    entries: list[dict[str, object]] = []
    for objective, family in FAMILIES.items():
        offering = [run for run in runs if objective in run.items]
        pools: dict[int, list[tuple[RunRepertoires, Item]]] = {}
        for run in offering:
            for item in run.items[objective]:
                block = block_of(item.bin, run.shape[objective], bins)
                pools.setdefault(variant(block, bins), []).append((run, item))
        for k in range(1, blocks + 1):
            pool = pools.get(k, [])
            if not pool:
                continue  # an empty block in every run: no primitive, as in build_library
            pick = int(rng.integers(len(pool)))
            run, item = pool[pick]
            source = {
                "run": os.path.relpath(Path(run.path).absolute(), folder),
                "algorithm": run.algorithm,
                "seed": run.seed,
                "profile": run.profile,
                "objective": objective,
                "blocks": blocks,
                "block": list(block_of(item.bin, run.shape[objective], bins)),
                "bin": list(item.bin),
                "tree": item.tree,
                "nodes": item.nodes,
                "fitness": item.fitness,
                "derated_fitness": item.derated,
                "evaluation": item.evaluation,
                "heldout_fitness": run.heldout[objective].get((item.bin, item.tree)),
                "ablation": {"arm": "random8", "pool": len(pool), "drawn": pick},
            }
            entries.append({"name": f"{family}{k}", "tree": library_entry_tree(item.tree), "source": source})
    return entries


def rows(root: Path) -> list[dict[str, str]]:
    """One ``runs.csv`` row per finished run of the study in ``root``, in the plan's order."""
    return [
        {
            "arm": entry["arm"],
            "run": str(int(Path(entry["dir"]).name.removeprefix("run"))),
            "seed": str(entry["seed"]),
            "best_fitness": repr(best),
            "heldout_best_fitness": "" if held is None else repr(held),
        }
        for entry, best, held in finished_foraging_runs(root, "ablation", "plan")
    ]


def _quartiles(values: Sequence[float]) -> tuple[float, float]:
    if len(values) == 1:
        return values[0], values[0]
    q1, _, q3 = stats.quantiles(values, n=4, method="inclusive")
    return q1, q3


def comparisons(table: Sequence[Mapping[str, str]]) -> list[foraging_tables.Test]:
    """Each ablation arm against ``REFERENCE`` on ``METRIC``, where both have runs, Holm over these alone."""
    scored = foraging_tables.scores_from_rows(table)
    only = {METRIC: scored[METRIC]}
    pairs = [(arm.name, REFERENCE) for arm in ARMS if arm.name != REFERENCE]
    return foraging_tables.tests(only, pairs)


def tables_from_rows(table: Sequence[Mapping[str, str]]) -> tuple[str, str]:
    """The report's per-arm table and its comparisons with ``elite8``, from ``runs.csv`` rows alone."""
    what = {arm.name: arm.what for arm in ARMS}
    lines = [
        "| arm | what | runs | held-out best: median [95 % CI] | IQR | in-run best: median [95 % CI] | IQR |",
        "|---|---|---|---|---|---|---|",
    ]
    for arm in dict.fromkeys(row["arm"] for row in table):
        mine = [row for row in table if row["arm"] == arm]
        cells = []
        for column in ("heldout_best_fitness", "best_fitness"):
            values = [float(row[column]) for row in mine if row[column] != ""]
            if not values:
                cells += ["n/a", "n/a"]
                continue
            q1, q3 = _quartiles(values)
            interval = foraging_tables.median_interval(values)
            cells += [
                foraging_tables.with_interval(stats.median(values), interval, sign=False),
                f"[{q1:.3f}, {q3:.3f}]",
            ]
        lines.append(f"| {arm} | {what.get(arm, '')} | {len(mine)} | {' | '.join(cells)} |")
    tests = comparisons(table)
    if not tests:
        return "\n".join(lines) + "\n", "No ablation arm and elite8 both have held-out scores yet.\n"
    found = [
        foraging_tables.family_text(tests)
        + " Each row is unpaired: Shapiro-Wilk on each arm chooses a two-sided Welch's t-test or "
        "Mann-Whitney U. 'estimate [95 % CI]': the difference the test is about (the arm minus elite8), "
        f"with a percentile bootstrap interval ({intervals.RESAMPLES:,} resamples, each arm resampled on its "
        f"own, `numpy.random.default_rng({foraging_tables.BOOTSTRAP_SEED})` for each interval, not adjusted "
        "for the family). Cohen's d (pooled standard deviation) and Vargha-Delaney A (the arm's run beats "
        "elite8's).\n",
        "| comparison | n | medians | test | tested difference | estimate [95 % CI] | p | p (Holm) "
        "| Cohen's d | A | verdict |",
        "|---|---|---|---|---|---|---|---|---|---|---|",
    ]
    for t in tests:
        r = t.row
        d = "n/a" if r.cohens_d is None else f"{r.cohens_d:.2f}"
        verdict = "higher" if t.favours_first else "lower" if t.favours_second else "no difference shown"
        found.append(
            f"| {r.first} vs {r.second} | {r.n_first}/{r.n_second} | {t.median_first:.3f} / "
            f"{t.median_second:.3f} | {r.test} | {t.effect} | "
            f"{foraging_tables.with_interval(t.estimate, t.interval)} | {foraging_tables.p_text(r.p_value)} "
            f"| {foraging_tables.p_text(r.p_holm)} | {d} | {r.vargha_delaney_a:.2f} | {verdict} |"
        )
    return "\n".join(lines) + "\n", "\n".join(found) + "\n"


def write_runs_csv(root: Path, table: Sequence[Mapping[str, str]]) -> Path:
    """``runs.csv`` of the rows ``table``."""
    buffer = io.StringIO()
    writer = csv.DictWriter(buffer, CSV_HEADER, lineterminator="\n")
    writer.writeheader()
    writer.writerows(table)
    path = Path(root) / "runs.csv"
    write_atomic(path, buffer.getvalue())
    return path


def build_report(root: Path) -> Path:
    """Write ``runs.csv`` and ``report.md`` of the ablation study in ``root``; return the report's path."""
    root = Path(root)
    table = rows(root)
    if not table:
        raise EvolutionError(f"{root} has no finished runs yet")
    document = read_json(root / "experiment.json")
    assert isinstance(document, dict)  # rows() read it
    write_runs_csv(root, table)
    per_arm, compared = tables_from_rows(table)
    libraries = "\n".join(
        f"- `{name}` ([libraries/{name}.json](libraries/{name}.json)): {entry['how']}"
        + (f"; drawn from `numpy.random.default_rng({entry['seed']})`" if "seed" in entry else "")
        for name, entry in document["libraries"].items()
    )
    text = (
        "# Ablations of the hierarchical advantage\n\n"
        f"{len(table)} of {len(document['plan'])} runs finished: {document['runs']} per arm, "
        f"{document['evaluations']} individuals each, on the foraging task with the settings of the "
        f"foraging study in `{document['primitives_from']}` ({document['trials']} trials, "
        f"{document['scenarios']} scenarios, {document['design']} design, the `{document['profile']}` "
        f"profile); study seed {document['seed']}. One row per run in [runs.csv](runs.csv). Fitness: "
        "deliveries per robot per trial of each run's best forager, in-run (the training scenario) and "
        "held-out (5 fresh scenarios of 10 trials).\n\n"
        "- Reproduce: `ws/run evolution_manager experiment --study ablation --primitives-from "
        f"{document['primitives_from']} --runs {document['runs']} --evaluations {document['evaluations']} "
        f"--seed {document['seed']} --out {root.name}`\n\n"
        f"## Libraries\n\n{libraries}\n\n"
        "Each primitive's `source` in its library file says where it came from. elite8 over GP is the "
        "configuration of the foraging study's hier-qd8 arm, and me8 that of its foragers-qd arm, with seeds "
        "of their own.\n\n"
        "## Arms\n\n"
        "Per arm, the median over its runs with its 95 % percentile bootstrap interval (the runs resampled, "
        f"{intervals.RESAMPLES:,} times, `numpy.random.default_rng({foraging_tables.BOOTSTRAP_SEED})` for "
        "each interval) and the interquartile range.\n\n"
        f"{per_arm}\n"
        "## Each ablation against elite8 (held-out best fitness)\n\n"
        f"{compared}"
    )
    path = root / "report.md"
    write_atomic(path, text)
    return path


__all__ = [
    "ARMS",
    "CSV_HEADER",
    "LIBRARIES",
    "REFERENCE",
    "ablation_library",
    "build_report",
    "comparisons",
    "copied",
    "drawn",
    "library_seed",
    "padded",
    "plan_study",
    "rows",
    "tables_from_rows",
    "unevolved",
]
