"""``experiment --study replication``: the 2024 comparison replicated at the level of libraries.

    ws/run evolution_manager experiment --study replication --primitives-from experiments/foraging \\
        --runs 3 --out experiments/foraging-replication

The foraging study builds one library per kind from all its primitive runs, so that its ten runs per arm
share one library and measure only the high-level GP's variance. Here each seed of the primitive runs gives
its own library (``docs/algorithms.md``, "Library-level replication"): library ``qd8-sK`` from run ``K`` of
each of the six QD primitive runs, ``gpfnd8-sK`` from GP_fnd's run ``K`` (8 blocks per grid, the ``library``
command's rules), and ``--runs`` hierarchical GP runs of 100 s foraging trials on each (``arms/<library>/``).
The primitive runs are read from the foraging study ``--primitives-from``, whose profile, trials, scenario
design and seed this study takes; seeds: run ``r`` on library ``l`` gets ``derive_seed(--seed, RUN_STUDY,
REPLICATION_STAGE, l, r)``.

The report (``report.md``, ``runs.csv`` with ``arm, library, seed, best_fitness, heldout_best_fitness,
argos_best_fitness``) gives each library's runs, then QD against GP_fnd libraries on the held-out best
fitness, the in-run one and the ARGoS score: a linear mixed model with the library as a random intercept
(statsmodels ``MixedLM``), its estimate with a 95 % confidence interval, and an equivalence test (two
one-sided tests on that estimate, at ``EQUIVALENCE_MARGIN``). The ARGoS score is every run's best forager
in the authors' 2024 foraging build, its library given as their sub-behaviours file (the foraging study's
transfer, ``foraging_transfer``): ``report DIR --argos-eval DRIVER`` scores the runs not yet scored, and
the rows stay in ``argos_raw_<library>.tsv``, so a later report needs no ARGoS. The best-of-seeds condition
(``pooled_rows``): the foraging study's own runs over its libraries built from every seed, read from the
folder the plan names, listed beside the per-seed libraries and left out of the model.
"""

from __future__ import annotations

import argparse
import csv
import io
import warnings
from collections.abc import Iterable, Sequence
from pathlib import Path
from statistics import median

import numpy as np

from bt_controller.draws import RUN_STUDY, derive_seed
from evolution_manager.errors import EvolutionError, UsageError
from evolution_manager.evolution.run_config import RunConfig
from evolution_manager.files import read_json, write_atomic
from evolution_manager.studies import foraging_transfer, intervals
from evolution_manager.studies.foraging_study import PRIMITIVES, load_arm_runs, study_library
from evolution_manager.studies.planning import (
    finished_foraging_runs,
    foraging_study_plan,
    primitives_study_document,
    primitives_study_forager,
)
from swarm_sim.validation import transfer

REPLICATION_STAGE = 4
"""The stage index of this study's seeds (the foraging study uses 0 to 3), so that no run of it shares a
seed with a run of the foraging study of the same ``--seed``."""

KINDS: tuple[tuple[str, str], ...] = (("qd8", "qd"), ("gpfnd8", "gp-fnd"))
"""Library kind -> the algorithm of the primitive runs it is built from (8 blocks per grid each)."""

BLOCKS = 8

EQUIVALENCE_MARGIN = 0.1
"""Deliveries per robot per trial within which QD and GP_fnd libraries count as equivalent (about 4 % of an
ideal robot's 2.6): chosen before any run, as small as the study's ten runs per arm could hope to resolve."""

ARGOS = "argos_best_fitness"
"""The best forager's deliveries per robot per trial in the authors' ARGoS, the mean over the ARGoS seeds."""

CSV_HEADER = ["arm", "library", "seed", "best_fitness", "heldout_best_fitness", ARGOS]

SCORES = (
    ("heldout_best_fitness", "held-out best fitness"),
    ("best_fitness", "in-run best fitness"),
    (ARGOS, "ARGoS score of the best forager"),
)
"""The scores the mixed model compares QD and GP_fnd libraries on: ``runs.csv``'s column and its name."""


def plan_study(
    args: argparse.Namespace, scenarios: str, design: str | None
) -> tuple[dict, list, dict[str, int]]:
    """The study's plan document, its one stage and the budget of every run, from the command line."""
    if args.primitives_from is None:
        raise UsageError("--study replication needs --primitives-from FOLDER, a foraging study's folder")
    source_folder = Path(args.primitives_from)
    source = foraging_study_plan(source_folder)
    for option, value in (("profile", args.profile), ("trials", args.trials)):
        if value is not None and value != source[option]:
            raise UsageError(f"--{option} {value} differs from the primitives' study ({source[option]})")
    scenario_seed = source["scenario_seed"] if source["design"] == "shared" else None
    primitive_runs = [
        (RunConfig.from_json(entry["config"]), str(entry["dir"])) for entry in source["primitives"]
    ]
    seeds = sorted({int(Path(rel).name.removeprefix("run")) for _, rel in primitive_runs})
    libraries: dict[str, dict] = {}
    for kind, algorithm in KINDS:
        for k in seeds:
            runs = [
                rel
                for made, rel in primitive_runs
                if made.algorithm == algorithm and rel.endswith(f"run{k:02d}")
            ]
            expected = len(PRIMITIVES) if algorithm == "qd" else 1
            if len(runs) != expected:
                raise UsageError(
                    f"{source_folder} has {len(runs)} {algorithm} primitive runs of seed {k}, not {expected}"
                )
            libraries[f"{kind}-s{k}"] = {"kind": kind, "from": runs, "blocks": BLOCKS}
    arms = [
        {
            "arm": f"hier-{name}",
            "library": name,
            "dir": f"arms/{name}/run{r:02d}",
            "evaluations": args.evaluations,
            "seed": derive_seed(args.seed, RUN_STUDY, REPLICATION_STAGE, index, r),
        }
        for index, name in enumerate(libraries)
        for r in range(args.runs)
    ]
    document, budgets = primitives_study_document(
        "replication", source_folder, source, args, scenarios, scenario_seed, libraries, "arms", arms
    )
    out = Path(args.out).absolute()
    primitives_folder = source_folder.absolute()

    def foragers() -> list[tuple[RunConfig, str]]:
        planned = []
        for entry in arms:
            spec = libraries[entry["library"]]
            path = out / "libraries" / f"{entry['library']}.json"
            library = study_library(path, [primitives_folder / rel for rel in spec["from"]], spec["blocks"])
            digest = library.digest
            planned.append(
                primitives_study_forager(entry, "gp", source, scenarios, scenario_seed, str(path), digest)
            )
        return planned

    return document, [foragers], budgets


def foragers(root: Path) -> list[tuple[dict, foraging_transfer.Forager]]:
    """Every finished forager run of the study in ``root``, in the plan's order: its plan entry and its best
    forager (the tree as evolved, primitives by name, over the run's library)."""
    found = []
    for entry, best, held in finished_foraging_runs(root, "replication", "arms"):
        summary = read_json(Path(root) / entry["dir"] / "summary.json")
        assert isinstance(summary, dict)  # finished_foraging_runs has just read it as a finished run's
        tree = summary["objectives"]["foraging"]["best_tree"]
        run = int(entry["dir"].rsplit("run", 1)[1])
        found.append(
            (entry, foraging_transfer.Forager(entry["arm"], run, tree, best, held, entry["library"]))
        )
    return found


def rows(
    root: Path,
    argos_seeds: Sequence[int] = foraging_transfer.DEFAULT_SEEDS,
    found: Sequence[tuple[dict, foraging_transfer.Forager]] | None = None,
) -> list[dict[str, str]]:
    """One ``runs.csv`` row per finished forager run of the study in ``root``, in the plan's order; its
    ARGoS score where its library's raw file holds every one of ``argos_seeds`` for its best tree.
    ``found``: ``foragers(root)`` where the caller has it already."""
    if found is None:
        found = foragers(root)
    argos = {
        (r.forager.library, r.forager.run): r.argos
        for r in foraging_transfer.scored(root, [f for _, f in found], argos_seeds)[0]
    }
    return [
        {
            "arm": entry["arm"],
            "library": entry["library"],
            "seed": str(entry["seed"]),
            "best_fitness": repr(f.best_fitness),
            "heldout_best_fitness": "" if f.heldout is None else repr(f.heldout),
            ARGOS: repr(argos[f.library, f.run]) if (f.library, f.run) in argos else "",
        }
        for entry, f in found
    ]


def pooled_rows(
    document: dict, argos_seeds: Sequence[int] = foraging_transfer.DEFAULT_SEEDS
) -> list[dict[str, str]] | None:
    """The best-of-seeds condition: one ``runs.csv`` row per finished run of the foraging study the
    replication drew its primitives from (``document["primitives_from"]``, as the experiment read it) on
    its libraries built from every seed (arms ``hier-qd8``, ``hier-gpfnd8``; library named by its kind
    alone); the ARGoS score where that study's raw rows hold every seed for the run's best tree. None when
    that study's folder is not here."""
    folder = Path(document["primitives_from"])
    if not (folder / "experiment.json").exists():
        return None
    _, runs = load_arm_runs(folder)
    arms = {f"hier-{kind}": kind for kind, _ in KINDS}
    mine = [run for run in runs if run.arm in arms]
    found = [
        foraging_transfer.Forager(
            run.arm, run.index, run.best_tree, run.best_fitness, run.heldout_best_fitness, arms[run.arm]
        )
        for run in mine
    ]
    argos = {
        (r.forager.arm, r.forager.run): r.argos
        for r in foraging_transfer.scored(folder, found, argos_seeds)[0]
    }
    return [
        {
            "arm": run.arm,
            "library": arms[run.arm],
            "seed": str(run.seed),
            "best_fitness": repr(run.best_fitness),
            "heldout_best_fitness": ""
            if run.heldout_best_fitness is None
            else repr(run.heldout_best_fitness),
            ARGOS: repr(argos[run.arm, run.index]) if (run.arm, run.index) in argos else "",
        }
        for run in mine
    ]


def is_pooled(row: dict[str, str]) -> bool:
    """Whether a ``runs.csv`` row is of the best-of-seeds condition: its library is named by its kind alone
    (``qd8``), where a per-seed library carries its seed (``qd8-s3``)."""
    return row["library"] in dict(KINDS)


def mixed_comparison(
    table: Sequence[dict[str, str]], key: str
) -> tuple[float, float, float, float, int] | None:
    """GP_fnd libraries against QD libraries on ``key``: the mixed model's estimate (gpfnd8 minus qd8),
    its 95 % CI, the p-value, and the TOST p-value of equivalence within ``EQUIVALENCE_MARGIN``; None with
    fewer than two libraries of a kind. Per-seed libraries only: the best-of-seeds rows are another
    condition."""
    # statsmodels, pandas, scipy.stats: seconds to import, only when the model is fitted
    import statsmodels.formula.api as smf
    from pandas import DataFrame
    from scipy import stats

    data = [
        (float(row[key]), float(row["library"].startswith("gpfnd8")), row["library"])
        for row in table
        if row[key] != "" and not is_pooled(row)
    ]
    kinds = {(gp, library) for _, gp, library in data}
    if sum(1 for gp, _ in kinds if gp) < 2 or sum(1 for gp, _ in kinds if not gp) < 2:
        return None
    frame = DataFrame(data, columns=["value", "gpfnd", "library"])
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # a near-zero library variance: the fit stands, its note does not
        fit = smf.mixedlm("value ~ gpfnd", frame, groups=frame["library"]).fit(reml=True)
    estimate, error = float(fit.params["gpfnd"]), float(fit.bse["gpfnd"])
    low, high = estimate - 1.959964 * error, estimate + 1.959964 * error
    # TOST on the Wald statistic: both one-sided tests must reject a difference beyond the margin.
    p_lower = 1.0 - stats.norm.cdf((estimate + EQUIVALENCE_MARGIN) / error)
    p_upper = stats.norm.cdf((estimate - EQUIVALENCE_MARGIN) / error)
    return estimate, low, high, float(fit.pvalues["gpfnd"]), max(p_lower, p_upper)


def _heldout(rows: Iterable[dict[str, str]]) -> list[float]:
    """The held-out best fitness of each of ``rows`` that has one."""
    return [float(row["heldout_best_fitness"]) for row in rows if row["heldout_best_fitness"]]


def tables_from_rows(table: Sequence[dict[str, str]]) -> tuple[str, str]:
    """The report's per-library table and its QD-against-GP_fnd verdicts, from ``runs.csv`` rows."""
    lines = [
        "| library | runs | best fitness (median) | held-out best fitness (median) | ARGoS (median, runs) |",
        "|---|---|---|---|---|",
    ]
    for library in dict.fromkeys(row["library"] for row in table):
        mine = [row for row in table if row["library"] == library]
        best = median(float(row["best_fitness"]) for row in mine)
        held = _heldout(mine)
        held_text = f"{median(held):.4g}" if held else "n/a"
        argos = [float(row[ARGOS]) for row in mine if row.get(ARGOS)]
        argos_text = f"{median(argos):.4g} ({len(argos)})" if argos else "n/a"
        name = f"{library} (every seed)" if is_pooled(mine[0]) else library
        lines.append(f"| {name} | {len(mine)} | {best:.4g} | {held_text} | {argos_text} |")
    verdicts = []
    for key, name in SCORES:
        result = mixed_comparison(table, key)
        if result is None:
            verdicts.append(f"- {name}: fewer than two libraries of a kind have this score; no model yet.")
            continue
        estimate, low, high, p, p_tost = result
        equivalent = "equivalent" if p_tost <= 0.05 else "not shown equivalent"
        verdicts.append(
            f"- {name}: GP_fnd libraries minus QD libraries {estimate:+.3f} deliveries per robot per trial "
            f"(95 % CI {low:+.3f} to {high:+.3f}), p = {p:.3g}; TOST at +/-{EQUIVALENCE_MARGIN}: "
            f"p = {p_tost:.3g}, {equivalent}."
        )
    return "\n".join(lines) + "\n", "\n".join(verdicts) + "\n"


AGREEMENT_WIDTH = 0.1
"""The width, in deliveries per robot per trial, beyond which ``agreement_from_rows`` names a run."""


def agreement_from_rows(table: Sequence[dict[str, str]]) -> str:
    """The report's line on ARGoS against our held-out score, run by run, from ``runs.csv`` rows (a run is
    named by its arm and seed): the mean absolute difference over the per-seed runs that have both, the
    largest, and the runs beyond ``AGREEMENT_WIDTH``. The two are estimates on different trials (ARGoS's
    seeds, our held-out scenarios), so a difference is the two estimates' noise as well as any disagreement
    of the models."""
    differences = [
        (f"{row['arm']}, seed {row['seed']}", float(row[ARGOS]) - float(row["heldout_best_fitness"]))
        for row in table
        if row.get(ARGOS) and row["heldout_best_fitness"] and not is_pooled(row)
    ]
    if not differences:
        return "No run has both an ARGoS score and a held-out score yet.\n"
    sizes = [abs(d) for _, d in differences]
    beyond = [f"{name} ({d:+.3f})" for name, d in differences if abs(d) > AGREEMENT_WIDTH]
    text = (
        f"ARGoS minus held-out, over the {len(differences)} runs that have both: mean absolute difference "
        f"{sum(sizes) / len(sizes):.3f}, largest {max(sizes):.3f} deliveries per robot per trial; "
        f"{len(differences) - len(beyond)} of {len(differences)} within {AGREEMENT_WIDTH}"
    )
    return text + (f" (beyond it: {', '.join(beyond)}).\n" if beyond else ".\n")


POOLED_INTERVAL_SEED = 2024
"""The bootstrap generator's seed for each best-of-seeds interval (``numpy.random.default_rng``)."""


def pooled_from_rows(table: Sequence[dict[str, str]]) -> str:
    """The report's best-of-seeds lines from ``runs.csv`` rows: per kind with best-of-seeds runs, its
    held-out median with a 95 % bootstrap interval, beside the per-seed libraries' held-out medians."""
    lines = []
    for kind, _ in KINDS:
        pooled = _heldout(r for r in table if r["library"] == kind)
        if not pooled:
            continue
        bounds = intervals.interval(pooled, "median", np.random.default_rng(POOLED_INTERVAL_SEED))
        ci = "" if bounds is None else f" (95 % CI {bounds[0]:.3f} to {bounds[1]:.3f})"
        by_library: dict[str, list[dict[str, str]]] = {}
        for r in table:
            if r["library"].startswith(f"{kind}-s"):
                by_library.setdefault(r["library"], []).append(r)
        per_seed = [median(held) for mine in by_library.values() if (held := _heldout(mine))]
        line = f"- {kind} from every seed: held-out median {median(pooled):.3f}{ci}, {len(pooled)} runs"
        if per_seed:
            below = sum(1 for m in per_seed if m < median(pooled))
            line += (
                f"; the {len(per_seed)} per-seed {kind} libraries' held-out medians range from "
                f"{min(per_seed):.3f} to {max(per_seed):.3f} (median {median(per_seed):.3f}), "
                f"{below} of them below it"
            )
        lines.append(line + ".")
    return "\n".join(lines) + "\n" if lines else "No best-of-seeds runs with held-out scores.\n"


def build_report(
    root: Path,
    argos_eval: str | None = None,
    argos_seeds: Sequence[int] = foraging_transfer.DEFAULT_SEEDS,
    argos_jobs: int = 1,
) -> Path:
    """Write ``runs.csv`` and ``report.md`` of the replication study in ``root``; return the report's path.
    ``argos_eval``: the ARGoS harness's driver, to score first every finished run's best forager not yet
    scored on ``argos_seeds``."""
    root = Path(root)
    found = foragers(root)
    if argos_eval is not None:
        foraging_transfer.measure(root, [f for _, f in found], argos_eval, argos_seeds, argos_jobs)
    table = rows(root, argos_seeds, found)
    if not table:
        raise EvolutionError(f"{root} has no finished forager runs yet")
    document = read_json(root / "experiment.json")
    assert isinstance(document, dict)  # foragers(root) has just read it as this study's plan
    pooled = pooled_rows(document, argos_seeds)
    if pooled:
        table += pooled
    if pooled is None:
        pooled_text = (
            f"The foraging study `{document['primitives_from']}` is not here (relative to the folder the "
            "report runs in), so its runs are not shown.\n"
        )
    else:
        pooled_text = pooled_from_rows(table)
    buffer = io.StringIO()
    writer = csv.DictWriter(buffer, CSV_HEADER, lineterminator="\n")
    writer.writeheader()
    writer.writerows(table)
    write_atomic(root / "runs.csv", buffer.getvalue())
    per_library, verdicts = tables_from_rows(table)
    unscored = sum(1 for row in table if not row[ARGOS] and not is_pooled(row))
    per_seed_runs = sum(1 for row in table if not is_pooled(row))
    seeds = transfer.seeds_text(argos_seeds)
    text = (
        "# Library-level replication of the 2024 comparison\n\n"
        f"{per_seed_runs} finished forager runs (hierarchical GP, 100 s foraging trials), one row per run in "
        "[runs.csv](runs.csv). Each library is built from one seed of the primitive runs. The rows "
        '"(every seed)" are the best-of-seeds condition: the foraging study\'s runs over its libraries '
        "built from all the primitive runs (their ARGoS score where that study measured it: its best run "
        "per arm), also in runs.csv, library named by its kind alone; the model below leaves them out.\n\n"
        "## Per library\n\n"
        f"{per_library}\n"
        "## Best-of-seeds libraries\n\n"
        "Each kind's library from every seed against the per-seed libraries; the interval is a percentile "
        f"bootstrap of the median (10,000 resamples, `numpy.random.default_rng({POOLED_INTERVAL_SEED})`).\n\n"
        f"{pooled_text}\n"
        "## QD against GP_fnd libraries\n\n"
        "A linear mixed model: the score against the library's kind, with a random intercept per library "
        "(statsmodels MixedLM, REML); the estimate with its Wald 95 % confidence interval and p-value, and "
        f"two one-sided tests of equivalence within +/-{EQUIVALENCE_MARGIN} deliveries per robot per trial, "
        "chosen before the runs. The ARGoS score: each run's best forager in the authors' 2024 foraging code "
        f"(through the project's harness, `--build foraging`; seeds {seeds}, each ten 100 s trials, the "
        "run's library given as their sub-behaviours file), the mean deliveries per robot per trial over "
        "the seeds; rows in `argos_raw_<library>.tsv` (`report DIR --argos-eval DRIVER` "
        f"scores the runs not yet scored: {unscored} of {per_seed_runs} here).\n\n"
        f"{verdicts}\n"
        "## ARGoS against held-out, run by run\n\n"
        f"{agreement_from_rows(table)}"
    )
    write_atomic(root / "report.md", text)
    return root / "report.md"
