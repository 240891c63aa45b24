"""The foraging study's statistics, computed from its runs' scores alone (``runs.csv`` holds them all).

A run's score is the best forager's deliveries per robot per trial, in-run (``best_fitness``, on the fixed
training scenarios) and held-out (``heldout_best_fitness``, 5 fresh scenarios of 10 trials). Per metric:

- the tests of ``significance`` for each pair of arms asked for (``compare``: Shapiro-Wilk, then Welch's t or
  Mann-Whitney U), or, for arms whose run ``k`` is made from the other arm's run ``k``, the paired tests
  (``compare_paired``: Shapiro-Wilk on the differences, then a paired t-test or Wilcoxon signed-rank), the
  runs paired by index;
- Holm's correction over one family: every row of the table, both metrics together;
- beside each test, the difference it tests with a 95 % percentile bootstrap interval (``intervals``): the
  difference of the means for a t-test, of the medians for Mann-Whitney U, the mean of the paired
  differences for a paired t-test, their median for Wilcoxon; and the median of every arm with its interval.

Every interval is drawn from ``numpy.random.default_rng(BOOTSTRAP_SEED)``, a fresh generator for each, so
that each is a function of its data alone and a test recomputes any row by itself.
"""

from __future__ import annotations

import csv
import statistics as stats
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from evolution_manager.studies import intervals
from evolution_manager.studies.significance import Comparison, compare, compare_paired, holm

if TYPE_CHECKING:  # the figures module loads matplotlib: only when a band is made
    # matplotlib (about 1.5 s to import) loads only when figures are drawn
    from evolution_manager.viewing.figures import Band

BOOTSTRAP_SEED = 2024
"""The seed of every interval's generator."""

METRICS: tuple[tuple[str, str], ...] = (
    ("best fitness", "best_fitness"),
    ("held-out best fitness", "heldout_best_fitness"),
)
"""(the metric's name in the tables, its column in ``runs.csv``)."""

Scores = dict[str, dict[str, dict[int, float]]]
"""metric name -> arm -> run index -> score."""


def _rng() -> np.random.Generator:
    return np.random.default_rng(BOOTSTRAP_SEED)


def scores_from_rows(rows: Iterable[Mapping[str, object]]) -> Scores:
    """The scores of ``runs.csv``'s rows (``arm``, ``run`` and the metrics' columns; an empty cell or None
    is a score not measured)."""
    scores: Scores = {metric: {} for metric, _ in METRICS}
    for row in rows:
        for metric, column in METRICS:
            value = row.get(column)
            if value is None or value == "":
                continue
            scores[metric].setdefault(str(row["arm"]), {})[int(str(row["run"]))] = float(str(value))
    return scores


def read_scores(path: Path) -> Scores:
    """The scores of a ``runs.csv``."""
    with Path(path).open(newline="") as handle:
        return scores_from_rows(csv.DictReader(handle))


@dataclass(frozen=True)
class Test:
    """A row of the comparisons: the test and the difference it tests, with its interval."""

    row: Comparison
    paired: bool
    median_first: float
    median_second: float
    effect: str
    """What ``estimate`` is: "Δ mean", "Δ median", "mean of paired Δ" or "median of paired Δ"."""
    estimate: float
    interval: tuple[float, float] | None

    @property
    def favours_first(self) -> bool:
        """Significant after Holm's correction, the first arm the higher."""
        return self.row.significant and self.estimate > 0

    @property
    def favours_second(self) -> bool:
        """Significant after Holm's correction, the second arm the higher."""
        return self.row.significant and self.estimate < 0


def _effect(
    row: Comparison, first: Sequence[float], second: Sequence[float], paired: bool
) -> tuple[str, float, tuple[float, float] | None]:
    """The difference the row's test is about, and its interval."""
    means = row.test.startswith("t-test")
    statistic = "mean" if means else "median"
    if paired:
        differences = [x - y for x, y in zip(first, second, strict=True)]
        estimate = float(intervals.STATISTICS[statistic](np.asarray(differences)))
        return f"{statistic} of paired Δ", estimate, intervals.interval(differences, statistic, _rng())
    estimate = float(
        intervals.STATISTICS[statistic](np.asarray(first))
        - intervals.STATISTICS[statistic](np.asarray(second))
    )
    return f"Δ {statistic}", estimate, intervals.difference(first, second, statistic, _rng())


def tests(
    scores: Scores, pairs: Sequence[tuple[str, str]], paired: Iterable[tuple[str, str]] = ()
) -> list[Test]:
    """The tests of ``pairs`` on every metric where both arms have runs, Holm-corrected over all of them
    together; a pair in ``paired`` is tested on the run indices both arms have, paired by index."""
    paired = set(paired)
    found: list[tuple[Comparison, bool, list[float], list[float]]] = []
    for metric, _ in METRICS:
        by_arm = scores.get(metric, {})
        for first, second in pairs:
            a_runs, b_runs = by_arm.get(first, {}), by_arm.get(second, {})
            if not a_runs or not b_runs:
                continue
            if (first, second) in paired:
                common = sorted(set(a_runs) & set(b_runs))
                if not common:
                    continue
                a, b = [a_runs[k] for k in common], [b_runs[k] for k in common]
                row = compare_paired(metric, "foraging", first, a, second, b)
            else:
                a, b = [a_runs[k] for k in sorted(a_runs)], [b_runs[k] for k in sorted(b_runs)]
                row = compare(metric, "foraging", first, a, second, b)
            found.append((row, (first, second) in paired, a, b))
    corrected = holm([row for row, _, _, _ in found])
    made = []
    for row, (_, is_paired, a, b) in zip(corrected, found, strict=True):
        effect, estimate, interval = _effect(row, a, b, is_paired)
        made.append(Test(row, is_paired, stats.median(a), stats.median(b), effect, estimate, interval))
    return made


def median_interval(values: Sequence[float]) -> tuple[float, float] | None:
    """The 95 % bootstrap interval of the median of an arm's runs (its own fresh generator)."""
    return intervals.interval(values, "median", _rng())


def signed(value: float) -> str:
    """A difference with its sign, three decimals."""
    return f"{value:+.3f}"


def with_interval(estimate: float, interval: tuple[float, float] | None, sign: bool = True) -> str:
    """``+0.123 [+0.045, +0.201]`` (``sign=False``: without signs), or the estimate alone without an
    interval."""
    form = signed if sign else (lambda v: f"{v:.3f}")
    if interval is None:
        return f"{form(estimate)} [n/a]"
    return f"{form(estimate)} [{form(interval[0])}, {form(interval[1])}]"


def p_text(value: float) -> str:
    """A p-value as the tables write it."""
    return "< 0.0001" if value < 1e-4 else f"{value:.4f}"


def family_text(rows: Sequence[Test]) -> str:
    """The sentence that names the Holm family of ``rows``."""
    metrics = list(dict.fromkeys(t.row.metric for t in rows))
    pairs = len({(t.row.first, t.row.second) for t in rows})
    return (
        f"Holm's correction runs over one family: the {len(rows)} rows of this table ({pairs} comparisons "
        f"on {len(metrics)} metric{'s' if len(metrics) != 1 else ''}: {', '.join(metrics)}); every "
        "'p (Holm)' of this report is of this family."
    )


def comparisons_table(rows: Sequence[Test]) -> str:
    """The comparisons in Markdown, significant rows (after Holm's correction) in bold, with the sentences
    that say what the columns are."""
    lines = [
        family_text(rows)
        + " Paired rows (a heterogeneous swarm arm against the arm whose run k gave its run k the foragers) "
        "pair the runs by index: Shapiro-Wilk on the differences chooses a paired t-test or Wilcoxon "
        "signed-rank. The other rows are unpaired: Shapiro-Wilk on each arm chooses Welch's t-test or "
        "Mann-Whitney U. 'estimate [95 % CI]': the difference the test is about (first arm minus "
        "second), with a percentile bootstrap interval "
        f"({intervals.RESAMPLES:,} resamples, `numpy.random.default_rng({BOOTSTRAP_SEED})` for each "
        "interval; an unpaired difference resamples each arm on its own, a paired one resamples the "
        "pairs; the intervals are not adjusted for the family, so an interval may exclude 0 where p "
        "(Holm) is above 0.05, and at 10 runs a percentile interval of a mean covers the true difference "
        "about 90 % of the time rather than 95 %, measured on normal samples: it runs a little narrow). "
        "Cohen's d (pooled standard deviation) and Vargha-Delaney A are the unpaired ones on every row.\n",
        "| metric | comparison | n | medians | means | Shapiro-Wilk p | test | tested difference | estimate "
        "[95 % CI] | p | p (Holm) | Cohen's d | A |",
        "|---|---|---|---|---|---|---|---|---|---|---|---|---|",
    ]
    for t in rows:
        r = t.row
        strong = "**" if r.significant else ""
        if t.paired:
            normal = f"Δ: {_optional(r.shapiro_first)}"
            n = f"{r.n_first} pairs"
        else:
            normal = f"{_optional(r.shapiro_first)} / {_optional(r.shapiro_second)}"
            n = f"{r.n_first}/{r.n_second}"
        d = "n/a" if r.cohens_d is None else f"{r.cohens_d:.2f}"
        lines.append(
            f"| {r.metric} | {strong}{r.first} vs {r.second}{strong} | {n} "
            f"| {t.median_first:.3f} / {t.median_second:.3f} | {r.mean_first:.3f} / {r.mean_second:.3f} "
            f"| {normal} | {r.test} | {t.effect} | {with_interval(t.estimate, t.interval)} "
            f"| {p_text(r.p_value)} | {strong}{p_text(r.p_holm)}{strong} | {d} | {r.vargha_delaney_a:.2f} |"
        )
    return "\n".join(lines) + "\n"


def _optional(value: float | None) -> str:
    return "n/a" if value is None else f"{value:.3f}"


@dataclass(frozen=True)
class Claim:
    """A claim set beside our tests in the 2024 table."""

    text: str
    source: str
    pairs: tuple[tuple[str, str], ...]


def find_test(rows: Sequence[Test], metric: str, pair: tuple[str, str]) -> Test | None:
    """The test of ``pair`` on ``metric``, or None where it was not made."""
    return next((t for t in rows if t.row.metric == metric and (t.row.first, t.row.second) == pair), None)


def _verdict(t: Test | None) -> str:
    if t is None:
        return "not measured"
    if t.favours_first:
        return "higher"
    if t.favours_second:
        return "lower"
    return "no difference shown"


def _cell(t: Test | None) -> str:
    if t is None:
        return "n/a"
    return (
        f"{t.effect} {with_interval(t.estimate, t.interval)}; {t.row.test}, p (Holm) {p_text(t.row.p_holm)}"
    )


def finding(rows: Sequence[Test], pair: tuple[str, str]) -> str:
    """What the tests of ``pair`` find, in-run and held-out."""
    in_run = _verdict(find_test(rows, METRICS[0][0], pair))
    held = _verdict(find_test(rows, METRICS[1][0], pair))
    if in_run == held:
        return f"{in_run}, in-run and held-out"
    return f"in-run {in_run}; held-out {held}"


def claims_table(rows: Sequence[Test], claims: Sequence[Claim]) -> str:
    """The claims, each beside the tests we bring to it (one line per pair of arms), in Markdown."""
    lines = [
        "| claim | from | our comparison | in-run best: difference [95 % CI]; test, p (Holm) | held-out: "
        "difference [95 % CI]; test, p (Holm) | we find |",
        "|---|---|---|---|---|---|",
    ]
    for claim in claims:
        for k, pair in enumerate(claim.pairs):
            head = f"{claim.text} | {claim.source}" if k == 0 else " | "
            lines.append(
                f"| {head} | {pair[0]} vs {pair[1]} | {_cell(find_test(rows, METRICS[0][0], pair))} "
                f"| {_cell(find_test(rows, METRICS[1][0], pair))} | {finding(rows, pair)} |"
            )
    return "\n".join(lines) + "\n"


def progress_band(curves: Sequence[tuple[Sequence[float], Sequence[float]]], points: int = 200) -> Band:
    """The median and quartiles over runs of a progress metric. Each curve is a run's (evaluations, value)
    rows, a value NaN where not yet recorded; a run's value at ``e`` evaluations is its last recorded one at
    or before ``e``. The band spans the evaluations where every run has a value: from the latest first
    recorded value to the earliest last row."""
    # matplotlib (about 1.5 s to import) loads only when figures are drawn
    from evolution_manager.viewing.figures import Band

    if not curves:
        raise ValueError("a band needs at least one run's curve")
    steps = []
    for evaluations, values in curves:
        x, y = np.asarray(evaluations, dtype=float), np.asarray(values, dtype=float)
        known = ~np.isnan(y)
        if not known.any():
            raise ValueError("a run's curve has no recorded value")
        steps.append((x[known], y[known], float(x[-1])))
    start = max(float(x[0]) for x, _, _ in steps)
    end = min(last for _, _, last in steps)
    grid = np.linspace(start, max(start, end), points)
    at = np.array([y[np.searchsorted(x, grid, side="right") - 1] for x, y, _ in steps])
    low, median, high = np.percentile(at, [25, 50, 75], axis=0)
    return Band(list(grid), list(low), list(median), list(high), len(curves))


__all__ = [
    "BOOTSTRAP_SEED",
    "METRICS",
    "Claim",
    "Scores",
    "Test",
    "claims_table",
    "comparisons_table",
    "family_text",
    "find_test",
    "finding",
    "median_interval",
    "p_text",
    "progress_band",
    "read_scores",
    "scores_from_rows",
    "tests",
    "with_interval",
]
