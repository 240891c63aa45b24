"""Table 6 across training scenarios: the paper's experiment repeated on several shared scenario seeds.

A scenarios folder holds one paper experiment per scenario seed, ``seed-K/`` (``experiment --seed K``: under
the authors' shared design every run of experiment K evolves on the scenario derived from K). ``report DIR``
on such a folder writes:

- ``runs.csv``: the paper's ``runs.csv`` with ``scenario_seed`` first, one row per finished run and objective;
- ``report.md``: per scenario, whether each of table 6's 18 rows reaches the paper's conclusion (the paper's
  own test choice and threshold, as ``report`` decides it for one experiment), the fraction of scenarios that
  do, and a pooled model per row over every scenario.

The pooled model of a row is a linear mixed model (statsmodels ``MixedLM``, REML): the metric against the
algorithm (first as the reference level) with a random intercept per scenario seed. Its estimate is the
second algorithm's mean minus the first's, with a Wald 95 % confidence interval and p-value; the 18 pooled
p-values are one Holm family. A row with runs of one scenario only gets no pooled model. Everything in the
report is computed from ``runs.csv`` (``tables_from_rows``), so a test recomputes it from the committed file.
"""

from __future__ import annotations

import csv
import io
import math
import warnings
from collections.abc import Sequence
from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np

from evolution_manager.errors import EvolutionError
from evolution_manager.files import read_json, write_atomic
from evolution_manager.studies.report import (
    ALPHA,
    METRICS,
    PAPER_TABLE_6,
    RUNS_HEADER,
    load_runs,
    runs_rows,
    verdict,
)
from evolution_manager.studies.significance import compare, holm_adjusted
from swarm_sim.model import PAPER_OBJECTIVES

SCENARIOS_HEADER = ["scenario_seed", *RUNS_HEADER]
"""The columns of a scenarios folder's ``runs.csv``."""

FOLDER_PREFIX = "seed-"
"""Each scenario's experiment folder: ``seed-<experiment seed>``."""


@dataclass(frozen=True)
class Pooled:
    """One row of table 6 pooled over scenarios by the mixed model."""

    metric: str
    objective: str
    first: str
    second: str
    scenarios: int
    n: int
    estimate: float
    low: float
    high: float
    p_value: float
    p_holm: float = math.nan


def is_scenarios_folder(root: Path) -> bool:
    """Whether ``root`` holds scenario experiments (``seed-K/experiment.json``), being none itself."""
    root = Path(root)
    return not (root / "experiment.json").exists() and any(root.glob(f"{FOLDER_PREFIX}*/experiment.json"))


def scenario_rows(root: Path) -> list[dict[str, str]]:
    """Every finished run and objective of every scenario experiment under ``root``, as ``runs.csv`` rows
    (scenario seeds in increasing order, then each experiment's plan order)."""
    found = []
    for plan in Path(root).glob(f"{FOLDER_PREFIX}*/experiment.json"):
        document = read_json(plan)
        if not isinstance(document, dict) or not isinstance(document.get("scenario_seed"), int):
            raise EvolutionError(f"{plan} is not a paper experiment of the shared design (no scenario_seed)")
        found.append((document["scenario_seed"], plan.parent))
    rows: list[dict[str, str]] = []
    for seed, folder in sorted(found):
        for values in runs_rows(load_runs(folder)):
            rows.append(dict(zip(SCENARIOS_HEADER, [str(seed), *values], strict=True)))
    return rows


def write_scenarios_csv(root: Path, rows: Sequence[dict[str, str]]) -> Path:
    """``runs.csv`` of the scenarios folder ``root``."""
    buffer = io.StringIO()
    writer = csv.DictWriter(buffer, SCENARIOS_HEADER, lineterminator="\n")
    writer.writeheader()
    writer.writerows(rows)
    path = Path(root) / "runs.csv"
    write_atomic(path, buffer.getvalue())
    return path


def read_scenarios_csv(path: Path) -> list[dict[str, str]]:
    """The rows of a scenarios ``runs.csv``; ``EvolutionError`` for other columns."""
    rows = list(csv.DictReader(io.StringIO(Path(path).read_text())))
    if not rows or list(rows[0]) != SCENARIOS_HEADER:
        raise EvolutionError(f"{path} is not a scenarios runs.csv (expected {', '.join(SCENARIOS_HEADER)})")
    return rows


def _pairs(objective: str) -> tuple[tuple[str, str], ...]:
    gp = f"GP_{objective}"
    return ((gp, "GP_fnd"), (gp, f"QD_{objective}"))


def _values(rows: Sequence[dict[str, str]], key: str, objective: str, label: str) -> dict[str, list[float]]:
    """Per scenario seed, the values of ``key`` of ``label``'s runs on ``objective``."""
    out: dict[str, list[float]] = {}
    for row in rows:
        if row["objective"] == objective and row["algorithm"] == label and row[key] != "":
            out.setdefault(row["scenario_seed"], []).append(float(row[key]))
    return out


def _mixed(
    first: dict[str, list[float]], second: dict[str, list[float]]
) -> tuple[float, float, float, float]:
    """The mixed model's (estimate, CI low, CI high, p) of second minus first (scenario: random intercept)."""
    # statsmodels, pandas, scipy.stats: seconds to import, only when the model is fitted
    import statsmodels.formula.api as smf
    from pandas import DataFrame

    records = [
        (value, group, scenario)
        for group, sample in ((0, first), (1, second))
        for scenario, values in sample.items()
        for value in values
    ]
    frame = DataFrame(records, columns=["value", "second", "scenario"])
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # convergence notes of a near-zero scenario variance: the fit stands
        fit = smf.mixedlm("value ~ second", frame, groups=frame["scenario"]).fit(reml=True)
    low, high = (float(v) for v in np.asarray(fit.conf_int(alpha=ALPHA).loc["second"]))
    return float(fit.params["second"]), low, high, float(fit.pvalues["second"])


def tables_from_rows(rows: Sequence[dict[str, str]]) -> tuple[str, str]:
    """The report's two tables from ``runs.csv`` rows: per scenario (verdict by row) and pooled."""
    scenarios = sorted({row["scenario_seed"] for row in rows}, key=int)
    per_scenario = [
        "| metric | objective | comparison | paper p | "
        + " | ".join(f"scenario {i + 1}" for i in range(len(scenarios)))
        + " | reach the paper's conclusion |",
        "|---|---|---|---|" + "---|" * len(scenarios) + "---|",
    ]
    pooled: list[Pooled] = []
    for key, name, _ in METRICS:
        for objective in PAPER_OBJECTIVES:
            for first, second in _pairs(objective):
                paper_p = PAPER_TABLE_6[(name, objective, "fnd" if second == "GP_fnd" else "qd")][0]
                a, b = _values(rows, key, objective, first), _values(rows, key, objective, second)
                cells, same, tested = [], 0, 0
                for scenario in scenarios:
                    if len(a.get(scenario, [])) < 2 or len(b.get(scenario, [])) < 2:
                        cells.append("n/a")
                        continue
                    row = compare(name, objective, first, a[scenario], second, b[scenario])
                    said = verdict(row, paper_p)
                    tested += 1
                    same += said == "same conclusion"
                    cells.append(
                        ("same" if said == "same conclusion" else "differs")
                        + f" (p = {shown_p(row.p_value)}, n = {row.n_first}/{row.n_second})"
                    )
                per_scenario.append(
                    f"| {name} | {objective} | {first} vs {second} | {paper_p} | "
                    + " | ".join(cells)
                    + f" | {same} of {tested} |"
                )
                both = [s for s in scenarios if s in a and s in b]
                if len(both) >= 2:
                    estimate, low, high, p = _mixed({s: a[s] for s in both}, {s: b[s] for s in both})
                    n = sum(len(a[s]) + len(b[s]) for s in both)
                    pooled.append(
                        Pooled(name, objective, first, second, len(both), n, estimate, low, high, p)
                    )
    return "\n".join(per_scenario) + "\n", _pooled_table(_holm(pooled))


def _holm(rows: Sequence[Pooled]) -> list[Pooled]:
    corrected = holm_adjusted([r.p_value for r in rows])
    return [replace(r, p_holm=p) for r, p in zip(rows, corrected, strict=True)]


def shown_p(p: float) -> str:
    """A p-value as the report prints it: three significant figures, and below the smallest a double keeps
    apart from zero (a Wald p of a very large effect underflows to 0) as ``< 1e-300``, never ``0``."""
    return "< 1e-300" if p < 1e-300 else f"{p:.3g}"


def _pooled_table(rows: Sequence[Pooled]) -> str:
    if not rows:
        return "No row has runs of two scenarios yet: no pooled model.\n"
    lines = [
        "| metric | objective | comparison | scenarios | runs | second - first (95 % CI) | p | p (Holm, "
        f"{len(rows)} rows) | paper p | pooled verdict |",
        "|---|---|---|---|---|---|---|---|---|---|",
    ]
    for r in rows:
        paper_p = PAPER_TABLE_6[(r.metric, r.objective, "fnd" if r.second == "GP_fnd" else "qd")][0]
        paper_significant = paper_p.startswith("<") or float(paper_p) <= ALPHA
        ours = r.p_value <= ALPHA
        if paper_significant and ours:
            said = "same conclusion" if r.estimate > 0 else "different: reversed"
        elif paper_significant == ours:
            said = "same conclusion"
        else:
            said = "different: " + ("not significant pooled" if paper_significant else "significant pooled")
        lines.append(
            f"| {r.metric} | {r.objective} | {r.first} vs {r.second} | {r.scenarios} | {r.n} "
            f"| {r.estimate:.4g} ({r.low:.4g}, {r.high:.4g}) | {shown_p(r.p_value)} | {shown_p(r.p_holm)} "
            f"| {paper_p} | {said} |"
        )
    return "\n".join(lines) + "\n"


def build_scenarios_report(root: Path) -> Path:
    """Write ``runs.csv`` and ``report.md`` of the scenarios folder ``root``; return the report's path."""
    root = Path(root)
    rows = scenario_rows(root)
    if not rows:
        raise EvolutionError(f"{root} has no finished runs in its {FOLDER_PREFIX}K experiments")
    write_scenarios_csv(root, rows)
    per_scenario, pooled = tables_from_rows(read_scenarios_csv(root / "runs.csv"))
    seeds = sorted({row["scenario_seed"] for row in rows}, key=int)
    counts = {s: len({(r["algorithm"], r["seed"]) for r in rows if r["scenario_seed"] == s}) for s in seeds}
    listing = "\n".join(f"{i + 1}. scenario seed {s}: {counts[s]} finished runs" for i, s in enumerate(seeds))
    text = (
        "# Table 6 across training scenarios\n\n"
        f"The paper's experiment on {len(seeds)} shared scenario seeds (every run of an experiment evolves "
        "on its one scenario, the authors' design), one row per run and objective in [runs.csv](runs.csv):"
        "\n\n"
        f"{listing}\n\n"
        "## Per scenario\n\n"
        "Each cell: whether table 6's row reaches the paper's conclusion on that scenario (the paper's test "
        "choice, significance at 0.05 uncorrected, and where both are significant the direction: GP_o the "
        "lower), with our p-value and the runs compared. n/a: fewer than two runs of a group.\n\n"
        f"{per_scenario}\n"
        "## Pooled over scenarios\n\n"
        "A linear mixed model per row: the metric against the algorithm, a random intercept per scenario "
        "seed (statsmodels MixedLM, REML); the estimate is the second algorithm's mean minus the first's, "
        "with its Wald 95 % confidence interval and p-value; Holm's correction over the rows shown (one "
        "family). The verdict uses the uncorrected p, as the paper's table does.\n\n"
        f"{pooled}"
    )
    path = root / "report.md"
    write_atomic(path, text)
    return path
