"""``experiment --study qd-schedule``: what the 2023 MAP-Elites schedule changes in the 2024 study's
primitives.

    ws/run evolution_manager experiment --study qd-schedule --primitives-from experiments/foraging \\
        --runs 5 --out experiments/qd-schedule

The foraging study evolves its QD primitives on the 2023 schedule (an initial batch of 100, then batches of
50), where the authors' 2024 runs use an initial batch of 25 and batches of 25 (their a73e4af; the same
25,000 individuals, the grid updated twice as often). This study runs the first ``--runs`` QD primitive runs
of the foraging study ``--primitives-from`` again on the authors' schedule, every other setting the same: the
same objective, budget, run seed, trials, profile and scenario, so that run ``r`` here pairs with run ``r``
there (``runs/<objective>/run<r>``).

The report (``report.md``, ``runs.csv``: ``objective``, ``run``, ``schedule``, ``seed`` and the run's best,
held-out best, coverage, QD score and held-out QD score) gives per objective and metric the median of each
schedule, the median paired difference (2024 minus 2023) with its 95 % bootstrap interval, and a paired test
(``significance.compare_paired``: Shapiro-Wilk on the differences, then a paired t-test or Wilcoxon
signed-rank), Holm-corrected over the family of every objective and metric.
"""

from __future__ import annotations

import argparse
import csv
import dataclasses
import io
from collections.abc import Sequence
from pathlib import Path

import numpy as np

from evolution_manager.errors import EvolutionError, UsageError
from evolution_manager.evolution.run_config import RunConfig
from evolution_manager.files import read_json, write_atomic
from evolution_manager.studies.foraging_study import PRIMITIVES
from evolution_manager.studies.intervals import interval
from evolution_manager.studies.planning import PLAN_FILE, foraging_study_plan
from evolution_manager.studies.significance import Comparison, compare_paired, holm, markdown_table

STUDY = "qd-schedule"
INIT_BATCH_2024 = 25
BATCH_2024 = 25
"""The authors' 2024 MAP-Elites schedule (a73e4af): an initial batch of 25, then batches of 25."""
SCHEDULES = ("2023", "2024")
METRICS: tuple[tuple[str, str], ...] = (
    ("best_fitness", "best fitness"),
    ("heldout_best_fitness", "held-out best fitness"),
    ("coverage", "coverage"),
    ("qd_score", "QD score"),
    ("heldout_qd_score", "held-out QD score"),
)
CSV_HEADER = ["objective", "run", "schedule", "seed", *(key for key, _ in METRICS)]


def plan_study(
    args: argparse.Namespace, scenarios: str, design: str | None
) -> tuple[dict, list, dict[str, int]]:
    """The study's plan document, its one stage and the budget of every run, from the command line."""
    if args.primitives_from is None:
        raise UsageError("--study qd-schedule needs --primitives-from FOLDER, a foraging study's folder")
    source_folder = Path(args.primitives_from)
    source = foraging_study_plan(source_folder)
    given = {"profile": args.profile, "trials": args.trials, "evaluations": args.evaluations}
    for option, value in given.items():
        if value is not None and value != source[option]:
            raise UsageError(f"--{option} {value} differs from the primitives' study ({source[option]})")
    if scenarios != source["scenarios"] or (design is not None and design != source["design"]):
        raise UsageError("--scenarios and --design: the study takes the primitives' study's; leave them out")
    planned: list[tuple[RunConfig, str]] = []
    entries = []
    for entry in source["primitives"]:
        made = RunConfig.from_json(entry["config"])
        index = int(Path(entry["dir"]).name.removeprefix("run"))
        if made.algorithm != "qd" or index >= args.runs:
            continue
        again = dataclasses.replace(
            made, qd=dataclasses.replace(made.qd, init_batch=INIT_BATCH_2024, batch=BATCH_2024)
        )
        folder = f"runs/{made.objective}/run{index:02d}"
        planned.append((again, folder))
        entries.append({"objective": made.objective, "run": index, "dir": folder, "from": entry["dir"],
                        "config": again.to_json()})  # fmt: skip
    if len(entries) != args.runs * len(PRIMITIVES):
        raise UsageError(
            f"{source_folder} has {len(entries)} QD primitive runs below index {args.runs}, not "
            f"{args.runs * len(PRIMITIVES)} ({len(PRIMITIVES)} objectives): ask for fewer --runs"
        )
    document = {
        "study": STUDY,
        "primitives_from": str(source_folder),
        "runs": args.runs,
        "schedule": {"init_batch": INIT_BATCH_2024, "batch": BATCH_2024},
        "plan": entries,
    }
    return document, [lambda: planned], {folder: made.evaluations for made, folder in planned}


def _scores(folder: Path) -> dict | None:
    """The objective's scores of the finished run in ``folder`` (None when unfinished)."""
    path = folder / "summary.json"
    summary = read_json(path) if path.exists() else None
    if not isinstance(summary, dict) or not summary.get("finished"):
        return None
    return summary["objectives"][summary["config"]["objective"]] | {"seed": summary["config"]["seed"]}


def rows(root: Path) -> list[dict[str, str]]:
    """Two ``runs.csv`` rows per finished run of the study in ``root`` (its source run on the 2023 schedule,
    then itself on the 2024 one), in the plan's order."""
    root = Path(root)
    document = read_json(root / PLAN_FILE)
    if not isinstance(document, dict) or document.get("study") != STUDY:
        raise EvolutionError(f"{root} is not a {STUDY} study ({PLAN_FILE})")
    source = Path(document["primitives_from"])  # as given to the study: relative to where it is reported
    out = []
    for entry in document["plan"]:
        mine = _scores(root / entry["dir"])
        theirs = _scores(source / entry["from"])
        if mine is None or theirs is None:
            continue
        for schedule, scores in zip(SCHEDULES, (theirs, mine), strict=True):
            out.append({
                "objective": entry["objective"], "run": str(entry["run"]), "schedule": schedule,
                "seed": str(scores["seed"]),
                **{key: "" if scores.get(key) is None else repr(float(scores[key])) for key, _ in METRICS},
            })  # fmt: skip
    return out


def _paired(table: Sequence[dict[str, str]], objective: str, key: str) -> tuple[list[float], list[float]]:
    """The 2024 and 2023 values of ``key`` on ``objective``, paired by run."""
    by = {
        schedule: {
            r["run"]: float(r[key])
            for r in table
            if r["objective"] == objective and r["schedule"] == schedule and r[key]
        }
        for schedule in SCHEDULES
    }
    runs = [r for r in by["2024"] if r in by["2023"]]
    return [by["2024"][r] for r in runs], [by["2023"][r] for r in runs]


def comparisons(table: Sequence[dict[str, str]]) -> list[Comparison]:
    """The 2024 schedule against the 2023 one, per objective and metric, paired by run; Holm over all."""
    found = []
    for objective in PRIMITIVES:
        for key, label in METRICS:
            new, old = _paired(table, objective, key)
            if len(new) >= 2:
                found.append(compare_paired(label, objective, "2024", new, "2023", old))
    return holm(found) if found else []


def medians_table(table: Sequence[dict[str, str]]) -> str:
    """Per objective and metric: runs, each schedule's median, the median paired difference (2024 - 2023)
    with its 95 % bootstrap interval."""
    rng = np.random.default_rng(0)
    lines = [
        "| objective | metric | runs | 2023 median | 2024 median | paired Δ median [95 % CI] |",
        "|---|---|---|---|---|---|",
    ]
    for objective in PRIMITIVES:
        for key, label in METRICS:
            new, old = _paired(table, objective, key)
            if not new:
                continue
            differences = [a - b for a, b in zip(new, old, strict=True)]
            bounds = interval(differences, "median", rng)
            ci = "" if bounds is None else f" [{bounds[0]:+.4g}, {bounds[1]:+.4g}]"
            lines.append(
                f"| {objective} | {label} | {len(new)} | {np.median(old):.4g} | {np.median(new):.4g} | "
                f"{np.median(differences):+.4g}{ci} |"
            )
    return "\n".join(lines) + "\n"


def build_report(root: Path) -> Path:
    """Write ``runs.csv`` and ``report.md`` of the study in ``root`` from its finished runs; return the
    report's path."""
    root = Path(root)
    table = rows(root)
    if not table:
        raise EvolutionError(f"{root} has no finished runs yet")
    buffer = io.StringIO()
    writer = csv.DictWriter(buffer, CSV_HEADER, lineterminator="\n")
    writer.writeheader()
    writer.writerows(table)
    write_atomic(root / "runs.csv", buffer.getvalue())
    document = read_json(root / PLAN_FILE)
    assert isinstance(document, dict)  # rows() checked it
    tested = comparisons(table)
    finished = len(table) // 2
    text = (
        f"# The 2023 MAP-Elites schedule against the authors' 2024 one: {root.name}\n\n"
        f"{finished} of {len(document['plan'])} runs finished; one row per run and schedule in "
        "[runs.csv](runs.csv). Each run here is a QD primitive run of the foraging study "
        f"(`{document['primitives_from']}`) again, every setting the same but the schedule: an initial "
        "batch of 25 and batches of 25 (the authors' 2024 code), against the study's 2023 schedule (100, "
        "then batches of 50). Run r here pairs with run r there: the same seed, scenario and budget.\n\n"
        "## Medians\n\n"
        f"{medians_table(table)}\n"
        "## Tests\n\n"
        "Paired by run: Shapiro-Wilk on the differences, then a paired t-test or Wilcoxon signed-rank; "
        "Holm's correction over the family of every row (every objective and metric). Significant rows in "
        "bold.\n\n" + (markdown_table(tested) if tested else "No objective has two paired runs yet.\n")
    )
    write_atomic(root / "report.md", text)
    return root / "report.md"
