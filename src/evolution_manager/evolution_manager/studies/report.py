"""The report of the 2023 paper's experiment: ``report.md``, ``runs.csv`` and figures from its run folders.

``build_report`` writes ``report.md`` and ``runs.csv`` (one row per run and objective) with, beside them in
``figures/``: box plots of best fitness, coverage and QD score (figs. 4-6) and of the held-out scores, the
histograms of the best fitness per bin of one run of each algorithm (fig. 8), the MAP-Elites grids of one run
per objective (fig. 7) and progress curves with the held-out scores; the paper's table 6 row by row (its
p-value and test beside ours, effect sizes, Holm's correction, the held-out comparison and a verdict per row)
and fig. 8's repertoire sizes beside the paper's; with ARGoS's rows, the transfer section
(``argos_transfer``); last ``notes.md`` when the folder has one. The ``report`` command
(``report_command``) chooses which report a folder gets.
"""

from __future__ import annotations

import csv
import io
import os
import statistics as stats
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from evolution_manager.errors import EvolutionError
from evolution_manager.evolution.archive import Repertoire
from evolution_manager.evolution.run import PROGRESS_HEADER
from evolution_manager.evolution.run_config import DEFAULT_PROFILE, RunConfig
from evolution_manager.files import CsvLog, number, read_json, read_json_object, write_atomic
from evolution_manager.studies import argos_transfer, intervals
from evolution_manager.studies.argos_transfer import measure as argos_measure
from evolution_manager.studies.significance import ALPHA, Comparison, compare, holm, markdown_table
from evolution_manager.viewing import figures
from swarm_sim.model import PAPER_OBJECTIVES

METRICS = (("best_fitness", "best fitness", 4), ("coverage", "coverage", 5), ("qd_score", "QD score", 6))
"""(summary key, name, figure number in the paper)."""

HELDOUT = {"best_fitness": "heldout_best_fitness", "qd_score": "heldout_qd_score"}
"""The held-out counterpart of a metric (coverage has none: the bins are the run's)."""

RUNS_HEADER = [
    "algorithm",
    "objective",
    "seed",
    "best_fitness",
    "heldout_best_fitness",
    "coverage",
    "qd_score",
    "heldout_qd_score",
    "repertoire_size",
]

PAPER_TABLE_6 = {
    # (metric, objective, second algorithm: "fnd" or "qd") -> (p-value as printed, test), paper table 6
    ("best fitness", "density", "fnd"): ("0.3505", "T-test"),
    ("best fitness", "density", "qd"): ("0.9695", "T-test"),
    ("best fitness", "nest", "fnd"): ("0.0004", "T-test"),
    ("best fitness", "nest", "qd"): ("0.0066", "T-test"),
    ("best fitness", "food", "fnd"): ("0.4406", "Mann-Whitney"),
    ("best fitness", "food", "qd"): ("0.9422", "T-test"),
    **{
        (m, o, a): ("< 0.0001", "T-test")
        for m in ("coverage", "QD score")
        for o in PAPER_OBJECTIVES
        for a in ("fnd", "qd")
    },
}
"""The paper's table 6. Where it is significant, GP_o is the lower of the two (section 4)."""

NOTES_FILE = "notes.md"
"""Written by a person beside an experiment's results (what the numbers mean, measurements made to explain
them); ``report`` appends it to ``report.md`` as it is."""

PAPER_REPERTOIRE_SIZES = {
    "density": {"GP_density": 148, "GP_fnd": 255, "QD_density": 290},
    "nest": {"GP_nest": 201, "GP_fnd": 255, "QD_nest": 283},
    "food": {"GP_food": 112, "GP_fnd": 255, "QD_food": 305},
}
"""Fig. 8 of the paper: filled bins of one run of each algorithm."""


@dataclass(frozen=True)
class FinishedRun:
    """A finished run of an experiment."""

    algorithm: str
    objective: str | None
    index: int
    directory: Path
    summary: dict

    def label(self, objective: str) -> str:
        """The name of this run's algorithm when compared on ``objective``."""
        if self.algorithm == "gp-fnd":
            return "GP_fnd"
        return ("GP_" if self.algorithm == "gp" else "QD_") + objective


def load_runs(root: Path) -> list[FinishedRun]:
    """Every finished run under ``root/runs`` (runs without a finished summary are skipped)."""
    runs = []
    for summary_path in sorted(Path(root).glob("runs/*/run*/summary.json")):
        summary = read_json(summary_path)
        if not isinstance(summary, dict) or not summary.get("finished"):
            continue
        config = summary["config"]
        index = int(summary_path.parent.name.removeprefix("run"))
        runs.append(
            FinishedRun(config["algorithm"], config["objective"], index, summary_path.parent, summary)
        )
    return runs


def runs_from_csv(path: Path) -> list[FinishedRun]:
    """The runs of an experiment's ``runs.csv`` (one row per run and objective), for the statistics of
    table 6 when the run directories are not at hand (e.g. a committed robustness check)."""
    text = Path(path).read_text()
    rows = list(csv.DictReader(io.StringIO(text)))
    if not rows or list(rows[0]) != RUNS_HEADER:
        raise EvolutionError(f"{path} is not a runs.csv (expected the columns {', '.join(RUNS_HEADER)})")
    grouped: dict[tuple[str, str], dict] = {}
    for row in rows:
        label = row["algorithm"]
        algorithm = "gp-fnd" if label == "GP_fnd" else ("gp" if label.startswith("GP_") else "qd")
        key = (label, row["seed"])
        run = grouped.setdefault(key, {"algorithm": algorithm, "objectives": {}})
        run["objectives"][row["objective"]] = {
            name: None if row[name] == "" else float(row[name]) for name in RUNS_HEADER[3:]
        }
    runs = []
    for index, ((label, seed), run) in enumerate(grouped.items()):
        objective = None if run["algorithm"] == "gp-fnd" else label.split("_", 1)[1]
        summary = {"config": {"seed": int(seed)}, "objectives": run["objectives"]}
        runs.append(FinishedRun(run["algorithm"], objective, index, Path(path).parent, summary))
    return runs


def _labels(objective: str) -> list[str]:
    return [f"GP_{objective}", "GP_fnd", f"QD_{objective}"]


def _samples(runs: Sequence[FinishedRun], key: str) -> dict[str, dict[str, list[float]]]:
    samples: dict[str, dict[str, list[float]]] = {
        o: {label: [] for label in _labels(o)} for o in PAPER_OBJECTIVES
    }
    for run in runs:
        for objective in PAPER_OBJECTIVES:
            if run.objective not in (None, objective):
                continue
            value = run.summary["objectives"][objective][key]
            if value is not None:
                samples[objective][run.label(objective)].append(float(value))
    return samples


def _repertoire(run: FinishedRun, objective: str) -> Repertoire:
    document = read_json_object(run.directory / f"repertoire_{objective}.json")
    return Repertoire.from_items(document["items"], int(document.get("items_per_bin", 3)))


def _comparisons(runs: Sequence[FinishedRun], pairs: str = "paper") -> list[Comparison]:
    """The paper's 18 comparisons (``pairs="paper"``: GP_o against GP_fnd and QD_o) or the 9 it left out
    (``"extra"``: GP_fnd against QD_o), Holm-corrected within the table."""
    rows = []
    for key, name, _ in METRICS:
        samples = _samples(runs, key)
        for objective in PAPER_OBJECTIVES:
            gp, fnd, qd = _labels(objective)
            chosen = ((gp, fnd), (gp, qd)) if pairs == "paper" else ((fnd, qd),)
            for first, second in chosen:
                a, b = samples[objective][first], samples[objective][second]
                if a and b:
                    rows.append(compare(name, objective, first, a, second, b))
    return holm(rows)


def _heldout_comparisons(runs: Sequence[FinishedRun]) -> dict[tuple[str, str, str], Comparison]:
    """The held-out counterpart of each paper row (best fitness and QD score), Holm over the 12."""
    rows = []
    for key, name, _ in METRICS:
        if key not in HELDOUT:
            continue
        samples = _samples(runs, HELDOUT[key])
        for objective in PAPER_OBJECTIVES:
            gp, fnd, qd = _labels(objective)
            for first, second in ((gp, fnd), (gp, qd)):
                a, b = samples[objective][first], samples[objective][second]
                if a and b:
                    rows.append(compare(name, objective, first, a, second, b))
    return {(r.metric, r.objective, r.second): r for r in holm(rows)}


def verdict(row: Comparison, paper_p: str) -> str:
    """ "same conclusion" when ours and the paper's agree on significance at 0.05 (uncorrected, as the
    paper) and, where both are significant, on which algorithm is higher (the paper's GP_o is the lower
    one); else "different: " and what differs, with our numbers."""
    paper_significant = paper_p.startswith("<") or float(paper_p) <= ALPHA
    ours = row.p_value <= ALPHA
    numbers = (
        f"{row.first} {row.mean_first:.4g} vs {row.second} {row.mean_second:.4g}, p = {_pv(row.p_value)}"
        + (f", d = {row.cohens_d:.2f}" if row.cohens_d is not None else "")
    )
    if paper_significant and ours:
        if row.mean_first < row.mean_second:
            return "same conclusion"
        return f"different: the difference is reversed here ({numbers})"
    if not paper_significant and not ours:
        return "same conclusion"
    if paper_significant:
        return f"different: no significant difference here ({numbers}, n = {row.n_first}/{row.n_second})"
    return f"different: significant here, not in the paper ({numbers})"


def _pv(p: float) -> str:
    return "< 0.0001" if p < 1e-4 else f"{p:.4f}"


BOOTSTRAP_SEED = 2023
"""Each interval of table 6 is drawn from a fresh ``numpy.random.default_rng(BOOTSTRAP_SEED)``, so that it
recomputes from ``runs.csv`` alone, row by row."""


def mean_difference_interval(first: Sequence[float], second: Sequence[float]) -> str:
    """mean(first) - mean(second) with its 95 % percentile bootstrap interval (``studies.intervals``)."""
    bounds = intervals.difference(first, second, "mean", np.random.default_rng(BOOTSTRAP_SEED))
    if bounds is None:
        return "n/a"
    return f"{sum(first) / len(first) - sum(second) / len(second):+.4f} [{bounds[0]:+.4f}, {bounds[1]:+.4f}]"


def _table6(runs: Sequence[FinishedRun]) -> str:
    rows = _comparisons(runs, "paper")
    held = _heldout_comparisons(runs)
    samples = {name: _samples(runs, key) for key, name, _ in METRICS}
    lines = [
        "| metric | objective | comparison | paper p | paper test | our means | difference (95 % CI) "
        "| our test | our p | p (Holm) | Cohen's d | A | held-out means | held-out p | verdict |",
        "|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|",
    ]
    for r in rows:
        ours = samples[r.metric][r.objective]
        ci = mean_difference_interval(ours[r.first], ours[r.second])
        second = "fnd" if r.second == "GP_fnd" else "qd"
        paper_p, paper_test = PAPER_TABLE_6[(r.metric, r.objective, second)]
        h = held.get((r.metric, r.objective, r.second))
        held_means = "n/a" if h is None else f"{h.mean_first:.4g} / {h.mean_second:.4g}"
        held_p = "n/a" if h is None else f"{_pv(h.p_value)} ({_short(h.test)})"
        d = "n/a" if r.cohens_d is None else f"{r.cohens_d:.2f}"
        lines.append(
            f"| {r.metric} | {r.objective} | {r.first} vs {r.second} | {paper_p} | {paper_test} "
            f"| {r.mean_first:.4g} / {r.mean_second:.4g} | {ci} | {_short(r.test)} | {_pv(r.p_value)} "
            f"| {_pv(r.p_holm)} | {d} | {r.vargha_delaney_a:.2f} | {held_means} | {held_p} "
            f"| {verdict(r, paper_p)} |"
        )
    same = sum("| same conclusion |" in line for line in lines)
    return (
        "\n".join(lines)
        + f"\n\n{same} of {len(rows)} rows reach the paper's conclusion. p (Holm): one family, the "
        f"{len(rows)} rows of this table. Difference: the first algorithm's mean minus the second's, with a "
        f"95 % percentile bootstrap interval ({intervals.RESAMPLES:,} resamples of each sample, "
        f"`numpy.random.default_rng({BOOTSTRAP_SEED})` for each row), not adjusted for the family.\n"
    )


def _short(test: str) -> str:
    return {"t-test (Welch)": "Welch t", "Mann-Whitney U": "Mann-Whitney"}.get(test, test)


def write_runs_csv(root: Path, runs: Sequence[FinishedRun]) -> Path:
    """``runs.csv``: one row per run and evolved objective (``runs_rows``)."""
    buffer = io.StringIO()
    writer = csv.writer(buffer, lineterminator="\n")
    writer.writerows([RUNS_HEADER, *runs_rows(runs)])
    path = Path(root) / "runs.csv"
    write_atomic(path, buffer.getvalue())
    return path


def runs_rows(runs: Sequence[FinishedRun]) -> list[list[str]]:
    """The rows of ``runs.csv`` (``RUNS_HEADER``): one per run and evolved objective, in the experiment
    plan's order (algorithm, objective, run index); floats as exact decimal text."""
    order = {a: i for i, a in enumerate(("gp", "gp-fnd", "qd"))}
    rows = []
    for run in sorted(runs, key=lambda r: (order[r.algorithm], r.objective or "", r.index)):
        for objective in PAPER_OBJECTIVES:
            if run.objective not in (None, objective):
                continue
            m = run.summary["objectives"][objective]
            rows.append(
                [
                    run.label(objective),
                    objective,
                    str(run.summary["config"]["seed"]),
                    number(m["best_fitness"]),
                    number(m.get("heldout_best_fitness")),
                    number(m["coverage"]),
                    number(m["qd_score"]),
                    number(m.get("heldout_qd_score")),
                    str(m["repertoire_size"]),
                ]
            )
    return rows


def _summary_table(runs: Sequence[FinishedRun]) -> str:
    lines = [
        "| objective | algorithm | runs | best fitness | held-out best fitness | coverage | QD score "
        "| held-out QD score | repertoire size (filled bins) |",
        "|---|---|---|---|---|---|---|---|---|",
    ]
    keys = ["best_fitness", "heldout_best_fitness", "coverage", "qd_score", "heldout_qd_score"]
    columns = [_samples(runs, key) for key in keys] + [_samples(runs, "repertoire_size")]
    for objective in PAPER_OBJECTIVES:
        for label in _labels(objective):
            cells = []
            for samples in columns:
                values = samples[objective][label]
                if not values:
                    cells.append("n/a")
                elif len(values) == 1:
                    cells.append(f"{values[0]:.4g}")
                else:
                    cells.append(f"{stats.mean(values):.4g} ± {stats.stdev(values):.2g}")
            n = len(columns[0][objective][label])
            lines.append(f"| {objective} | {label} | {n} | " + " | ".join(cells) + " |")
    return "\n".join(lines) + "\n"


def _header(root: Path, runs: Sequence[FinishedRun]) -> list[str]:
    parts = [f"# Experiment report: {root.name}\n"]
    plan = root / "experiment.json"
    if not plan.exists():
        return parts
    document = read_json(plan)
    assert isinstance(document, dict)
    scenarios = document.get("scenarios", "fresh")
    profile = document.get("profile", DEFAULT_PROFILE)  # experiments planned before profiles: the default
    # experiments planned before designs existed gave each run its own scenario unless one was given
    design = document.get("design") or ("per-run" if document.get("scenario_seed") is None else "shared")
    where = (
        f"every run on one shared scenario (scenario seed {document['scenario_seed']}, the authors' design)"
        if design == "shared"
        else "each run on its own scenario (the per-run design)"
    )
    parts.append(
        f"{len(runs)} finished runs of {len(document['plan'])} planned: "
        f"{document['runs']} runs per algorithm and objective, a budget of {document['evaluations']} "
        f"individuals produced per objective (GP_fnd {3 * document['evaluations']} on all three), "
        f"{document['trials']} trials per evaluation, {scenarios} scenarios"
        + (f", {where}" if scenarios == "fixed" else "")
        + f", the model's `{profile}` profile (docs/model.md), experiment seed {document['seed']}.\n"
    )
    command = (
        f"ws/run evolution_manager experiment --runs {document['runs']} --evaluations "
        f"{document['evaluations']} --seed {document['seed']} --trials {document['trials']} "
        f"--scenarios {scenarios} --profile {profile}"
    )
    if scenarios == "fixed":
        command += f" --design {design}"
    if document.get("scenario_seed") is not None and document.get("design") != "shared":
        command += f" --scenario-seed {document['scenario_seed']}"
    lines = [f"- Reproduce: `{command} --out {root.name}`"]
    sessions_path = root / "sessions.json"
    if sessions_path.exists():
        sessions = read_json(sessions_path)
        assert isinstance(sessions, list)
        wall = sum(float(x["wall_seconds"]) for x in sessions)
        commits = sorted({str(x["commit"]) for x in sessions})
        lines.append(f"- Commit: {', '.join(commits)}")
        lines.append(
            f"- Wall time: {wall:.0f} s ({wall / 3600:.2f} h) over {len(sessions)} session(s), "
            "as recorded at each finished run"
        )
    simulated = sum(int(r.summary.get("simulations", 0)) for r in runs)
    saved = sum(int(r.summary.get("simulations_saved", 0)) for r in runs)
    if simulated + saved:
        lines.append(
            f"- Simulations: {simulated} run, {saved} answered from the runs' caches of the fixed "
            f"scenario ({100 * saved / (simulated + saved):.1f} % of all evaluations saved)"
        )
    parts.append("\n".join(lines) + "\n")
    return parts


def _sizes_table(first: dict, runs: Sequence[FinishedRun]) -> str:
    sizes = _samples(runs, "repertoire_size")
    lines = [
        "| objective | algorithm | paper (one run) | ours (run shown) | ours, mean ± sd over runs |",
        "|---|---|---|---|---|",
    ]
    for objective in PAPER_OBJECTIVES:
        for label in _labels(objective):
            algorithm = "gp-fnd" if label == "GP_fnd" else ("gp" if label.startswith("GP") else "qd")
            run = first.get((algorithm, None if algorithm == "gp-fnd" else objective))
            shown = "n/a" if run is None else str(run.summary["objectives"][objective]["repertoire_size"])
            values = sizes[objective][label]
            spread = (
                "n/a"
                if not values
                else f"{stats.mean(values):.1f}"
                + (f" ± {stats.stdev(values):.1f}" if len(values) > 1 else "")
            )
            paper = PAPER_REPERTOIRE_SIZES[objective][label]
            lines.append(f"| {objective} | {label} | {paper} | {shown} | {spread} |")
    return "\n".join(lines) + "\n"


def build_report(
    root: Path,
    beside: Path | None = None,
    beside_title: str = "",
    argos_eval: str | None = None,
    argos_seeds: Sequence[int] | None = None,
    argos_jobs: int = 1,
) -> Path:
    """Write ``report.md``, ``runs.csv`` and the figures for the experiment in ``root``; return the
    report's path. ``beside``: another experiment's ``runs.csv`` whose table 6 is shown after this one's
    (e.g. the per-run design's, as a robustness check), under ``beside_title``. ``argos_eval``: the ARGoS
    harness's driver, to score in ARGoS the best trees not yet in ``argos_raw.tsv``; with that file the
    report has a transfer section (``studies.argos_transfer``)."""
    root = Path(root)
    runs = load_runs(root)
    if not runs:
        raise EvolutionError(f"{root} has no finished runs (runs/<label>/run<r>/summary.json)")
    seeds = list(argos_seeds) if argos_seeds else argos_transfer.parse_seeds(argos_transfer.DEFAULT_SEEDS)
    best = argos_transfer.best_trees(runs)
    if argos_eval is not None:
        argos_measure(root, best, argos_eval, seeds, argos_jobs)
    folder = root / "figures"
    parts = _header(root, runs)
    write_runs_csv(root, runs)
    parts.append(
        "## Results\n\nMean ± standard deviation over runs (one row per run and objective in "
        "[runs.csv](runs.csv)). QD score: the sum over bins of the best fitness, / 512; repertoire size: "
        "filled bins (the authors' analysis). GP repertoires: every individual of generations 1 onwards in "
        "a grid of one tree per bin; QD: the MAP-Elites archive (3 per bin). Held-out: each bin's best "
        "tree and the best tree re-scored on 5 fresh scenarios of 10 trials each (mean).\n\n"
        + _summary_table(runs)
    )
    for key, name, number_ in METRICS:
        path = figures.boxes(_samples(runs, key), name, folder / f"fig{number_}_{key}.png")
        parts.append(f"### Fig. {number_}-style: {name}\n\n![{name}](figures/{path.name})\n")
    for key, held_key in HELDOUT.items():
        name = f"held-out {key.replace('_', ' ').replace('qd', 'QD')}"
        path = figures.boxes(_samples(runs, held_key), name, folder / f"{held_key}.png")
        parts.append(f"### {name} (beyond the paper)\n\n![{name}](figures/{path.name})\n")
    parts.append(
        "## Table 6, row by row\n\n"
        "The paper's p-value and test beside ours. Ours: Shapiro-Wilk on each sample; if either rejects "
        f"normality at {ALPHA} (or cannot be tested: fewer than 3 runs, or all values equal), a two-sided "
        "Mann-Whitney U test, else a two-sided Welch t-test. Effect sizes: Cohen's d (pooled SD; negative: "
        "the first is lower) and Vargha-Delaney A (probability that the first beats the second). "
        "p (Holm): Holm's correction over the 18 rows. Held-out: the same test on the held-out scores "
        "(Holm over its 12 rows, not shown). Verdict: whether our uncorrected test at 0.05 reaches the "
        "paper's conclusion (significance, and GP_o the lower where significant).\n\n" + _table6(runs)
    )
    if beside is not None:
        other = runs_from_csv(beside)
        link = Path(os.path.relpath(Path(beside).resolve(), root.resolve())).as_posix()
        parts.append(
            f"### Table 6 again: {beside_title or beside}\n\n"
            f"The same tests on the runs of [{link}]({link}) ({len(other)} runs), which differ "
            "from the runs above only in how scenarios are given to runs.\n\n" + _table6(other)
        )
    extra = _comparisons(runs, "extra")
    if extra:
        parts.append(
            "### Comparisons the paper's table leaves out: GP_fnd vs QD_o\n\n" + markdown_table(extra)
        )
    first: dict[tuple[str, str | None], FinishedRun] = {}
    for run in runs:
        first.setdefault((run.algorithm, run.objective), run)
    histogram_rows = {}
    for objective in PAPER_OBJECTIVES:
        row = {}
        for algorithm in ("gp", "gp-fnd", "qd"):
            one = first.get((algorithm, None if algorithm == "gp-fnd" else objective))
            if one is not None:
                row[one.label(objective)] = _repertoire(one, objective)
        histogram_rows[objective] = row
    path = figures.histograms(histogram_rows, folder / "fig8_histograms.png")
    parts.append(
        "### Fig. 8-style: best fitness per bin of the repertoires of one run each (run 0)\n\n"
        f"![histograms](figures/{path.name})\n\nRepertoire sizes (filled bins) beside the paper's:\n\n"
        + _sizes_table(first, runs)
    )
    for objective in PAPER_OBJECTIVES:
        qd_run = first.get(("qd", objective))
        if qd_run is None:
            continue
        path = figures.heatmaps(
            _repertoire(qd_run, objective),
            f"QD_{objective} run {qd_run.index}",
            folder / f"fig7_grid_{objective}.png",
        )
        parts.append(
            f"### Fig. 7-style: MAP-Elites grid, {objective} (run {qd_run.index})\n\n"
            f"![grid](figures/{path.name})\n"
        )
    for objective in PAPER_OBJECTIVES:
        curves = {}
        held = {}
        for run in first.values():
            if run.objective in (None, objective):
                label = run.label(objective)
                curves[label] = CsvLog(run.directory / "progress.csv", PROGRESS_HEADER).read()
                m = run.summary["objectives"][objective]
                held[label] = {
                    objective: (
                        run.summary["evaluations"],
                        m.get("heldout_best_fitness"),
                        m.get("heldout_qd_score"),
                    )
                }
        path = figures.progress(curves, folder / f"progress_{objective}.png", [objective], heldout=held)
        parts.append(
            f"### Progress, {objective} (run 0 of each; circles: held-out scores at the end)\n\n"
            f"![progress](figures/{path.name})\n"
        )
    if (root / argos_transfer.RAW_FILE).exists():
        plan = RunConfig.from_json(runs[0].summary["config"])  # every run's model and trials: one plan
        transferred, missing = argos_transfer.transferred(root, best, seeds, plan.world(), plan.trials)
        argos_transfer.write_csv(root, transferred)
        parts.append(argos_transfer.section(transferred, missing, seeds, folder))
    notes = root / NOTES_FILE
    if notes.exists():  # a person's reading of the results, kept when the report is rebuilt
        parts.append(notes.read_text())
    report = root / "report.md"
    write_atomic(report, "\n".join(parts))
    return report


__all__ = ["build_report", "load_runs", "runs_from_csv"]
