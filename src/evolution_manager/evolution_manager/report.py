"""``report DIR``: rebuild the report of an experiment, or the results of a single run, from its files.

For an experiment folder (``experiment.json``, ``runs/``) it writes ``report.md`` with, beside it in
``figures/``: box plots of best fitness, coverage and QD score (figs. 4-6), the fitness histograms of one
run of each algorithm (fig. 8), the MAP-Elites grids of one run per objective (fig. 7) and progress
curves; and the table of pairwise tests (table 6) with effect sizes and Holm's correction. Algorithms are
compared per objective: GP_o and QD_o on their objective, GP_fnd on each of the three (with the passive
grid of that objective for coverage and QD score). For a run directory (``config.json``) it rewrites the
run's repertoires, summary, best trees and figures from its last checkpoint.
"""

from __future__ import annotations

import statistics as stats
import sys
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

from . import figures
from .archive import Repertoire
from .cli import EXIT_USAGE, Parser, UsageError
from .errors import EvolutionError
from .files import CsvLog, read_json, read_json_object, write_atomic
from .primitives import OBJECTIVES
from .run import PROGRESS_HEADER
from .statistics import ALPHA, Comparison, compare, holm, markdown_table

METRICS = (("best_fitness", "best fitness", 4), ("coverage", "coverage", 5), ("qd_score", "QD score", 6))
"""(summary key, name, figure number in the paper)."""


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


def _labels(objective: str) -> list[str]:
    return [f"GP_{objective}", "GP_fnd", f"QD_{objective}"]


def _samples(runs: Sequence[FinishedRun], key: str) -> dict[str, dict[str, list[float]]]:
    samples: dict[str, dict[str, list[float]]] = {o: {label: [] for label in _labels(o)} for o in OBJECTIVES}
    for run in runs:
        for objective in OBJECTIVES:
            if run.objective not in (None, objective):
                continue
            value = run.summary["objectives"][objective][key]
            if value is not None:
                samples[objective][run.label(objective)].append(float(value))
    return samples


def _repertoire(run: FinishedRun, objective: str) -> Repertoire:
    document = read_json_object(run.directory / f"repertoire_{objective}.json")
    return Repertoire.from_items(document["items"])


def _comparisons(runs: Sequence[FinishedRun]) -> list[Comparison]:
    rows = []
    for key, name, _ in METRICS:
        samples = _samples(runs, key)
        for objective in OBJECTIVES:
            gp, fnd, qd = _labels(objective)
            for first, second in ((gp, fnd), (gp, qd), (fnd, qd)):
                a, b = samples[objective][first], samples[objective][second]
                if a and b:
                    rows.append(compare(name, objective, first, a, second, b))
    return holm(rows)


def _summary_table(runs: Sequence[FinishedRun]) -> str:
    lines = [
        "| objective | algorithm | runs | best fitness | coverage | QD score | repertoire size |",
        "|---|---|---|---|---|---|---|",
    ]
    columns = [_samples(runs, key) for key, _, _ in METRICS] + [_samples(runs, "repertoire_size")]
    for objective in OBJECTIVES:
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


def build_report(root: Path) -> Path:
    """Write ``report.md`` and its figures for the experiment in ``root``; return the report's path."""
    root = Path(root)
    runs = load_runs(root)
    if not runs:
        raise EvolutionError(f"{root} has no finished runs (runs/<label>/run<r>/summary.json)")
    folder = root / "figures"
    parts = [f"# Experiment report: {root.name}\n"]
    plan = root / "experiment.json"
    if plan.exists():
        document = read_json_object(plan)
        parts.append(
            f"{len(runs)} finished runs of {len(document['plan'])} planned: "
            f"{document['runs']} runs per algorithm and objective, {document['evaluations']} evaluations "
            f"per objective (GP_fnd {3 * document['evaluations']} on all three), {document['trials']} trials "
            f"per evaluation, experiment seed {document['seed']}.\n"
        )
    parts.append("## Results\n\nMean ± standard deviation over runs.\n\n" + _summary_table(runs))
    for key, name, number in METRICS:
        path = figures.boxes(_samples(runs, key), name, folder / f"fig{number}_{key}.png")
        parts.append(f"### Fig. {number}-style: {name}\n\n![{name}](figures/{path.name})\n")
    rows = _comparisons(runs)
    parts.append(
        "## Pairwise tests (table 6)\n\n"
        f"Shapiro-Wilk on each sample; if either rejects normality at {ALPHA} "
        "(or cannot be tested: fewer than "
        "3 runs, or all values equal), a two-sided Mann-Whitney U test, else a two-sided Welch t-test. "
        "Effect sizes: Cohen's d (pooled SD) and Vargha-Delaney A (probability that the first beats the "
        f"second). p (Holm): Holm's correction over all {len(rows)} tests of the table; bold = significant "
        f"at {ALPHA} after correction.\n\n" + markdown_table(rows)
    )
    first: dict[tuple[str, str | None], FinishedRun] = {}
    for run in runs:
        first.setdefault((run.algorithm, run.objective), run)
    histogram_rows = {}
    for objective in OBJECTIVES:
        row = {}
        for algorithm in ("gp", "gp-fnd", "qd"):
            one = first.get((algorithm, None if algorithm == "gp-fnd" else objective))
            if one is not None:
                row[one.label(objective)] = _repertoire(one, objective)
        histogram_rows[objective] = row
    path = figures.histograms(histogram_rows, folder / "fig8_histograms.png")
    parts.append(
        "### Fig. 8-style: fitness of the repertoires of one run each\n\n"
        f"![histograms](figures/{path.name})\n"
    )
    for objective in OBJECTIVES:
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
    for objective in OBJECTIVES:
        curves = {}
        for run in first.values():
            if run.objective in (None, objective):
                curves[run.label(objective)] = CsvLog(run.directory / "progress.csv", PROGRESS_HEADER).read()
        path = figures.progress(curves, folder / f"progress_{objective}.png", [objective])
        parts.append(f"### Progress, {objective} (one run each)\n\n![progress](figures/{path.name})\n")
    report = root / "report.md"
    write_atomic(report, "\n".join(parts))
    return report


def rebuild_run(root: Path) -> list[Path]:
    """Rewrite a run directory's results from its last checkpoint (its logs are left as they are)."""
    from .outputs import write_results
    from .run import Run

    return write_results(Run.resume(root, None, cut=False))


def report(argv: Sequence[str] | None = None) -> int:
    """Run ``report``; return the exit status."""
    parser = Parser(prog="report", description=__doc__.split("\n")[0])
    parser.add_argument("dir", type=Path, help="an experiment folder or a run directory")
    try:
        args = parser.parse_args(argv)
    except UsageError as error:
        print(f"report: error: {error}", file=sys.stderr)
        return EXIT_USAGE
    try:
        if (args.dir / "experiment.json").exists() or (args.dir / "runs").is_dir():
            print(build_report(args.dir))
        elif (args.dir / "config.json").exists():
            for path in rebuild_run(args.dir):
                print(path)
        else:
            raise UsageError(f"{args.dir} is neither an experiment folder nor a run directory")
    except (UsageError, EvolutionError, OSError, KeyError, ValueError) as error:
        print(f"report: error: {error!s} (is {args.dir} a finished run or experiment?)", file=sys.stderr)
        return EXIT_USAGE
    return 0


def main() -> None:
    """Console entry point of ``report``."""
    sys.exit(report())


__all__ = ["build_report", "load_runs", "rebuild_run", "report"]
