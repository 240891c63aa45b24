"""Pairwise comparisons of algorithms as in the paper's table 6, plus effect sizes and a correction.

For two samples (one value per run): Shapiro-Wilk on each; if either rejects normality at ``alpha``, a
two-sided Mann-Whitney U test, else a two-sided Welch t-test (a t-test that does not assume equal
variances). Shapiro-Wilk needs at least 3 values: a smaller sample counts as not shown to be normal, so it
gets Mann-Whitney. A sample whose values are all equal cannot be tested for normality either and gets
Mann-Whitney too. Effect sizes: Cohen's d (pooled standard deviation) and Vargha-Delaney A (the
probability that a value of the first sample beats one of the second, ties counting half). p-values of the
whole table are corrected for multiple comparisons with Holm's step-down method.

For two paired samples (run k of one arm made from run k of the other, :func:`compare_paired`): Shapiro-Wilk
on the run-by-run differences, the paired t-test's assumption; if it does not reject normality at ``alpha``,
a two-sided paired t-test, else a two-sided Wilcoxon signed-rank test (scipy's default: zero differences
dropped). The effect sizes stay those of the unpaired rows, so that the rows of one table compare.
"""

from __future__ import annotations

import math
import warnings
from collections.abc import Sequence
from dataclasses import dataclass, replace

from scipy import stats

ALPHA = 0.05


@dataclass(frozen=True)
class Comparison:
    """One row of the table."""

    metric: str
    objective: str
    first: str
    second: str
    n_first: int
    n_second: int
    mean_first: float
    mean_second: float
    shapiro_first: float | None
    shapiro_second: float | None
    test: str
    p_value: float
    cohens_d: float | None
    vargha_delaney_a: float
    p_holm: float = math.nan

    @property
    def significant(self) -> bool:
        """Significant after Holm's correction."""
        return self.p_holm <= ALPHA


def shapiro(values: Sequence[float]) -> float | None:
    """The Shapiro-Wilk p-value, or None when the sample is too small or constant to be tested."""
    if len(values) < 3 or max(values) == min(values):
        return None
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return float(stats.shapiro(values).pvalue)


def cohens_d(a: Sequence[float], b: Sequence[float]) -> float | None:
    """(mean a - mean b) / pooled standard deviation: None when undefined (fewer than 2 values each, or
    no spread at all between different means); 0 for two constant, equal samples."""
    if len(a) < 2 or len(b) < 2:
        return None
    ma, mb = sum(a) / len(a), sum(b) / len(b)
    va = sum((x - ma) ** 2 for x in a) / (len(a) - 1)
    vb = sum((x - mb) ** 2 for x in b) / (len(b) - 1)
    pooled = math.sqrt(((len(a) - 1) * va + (len(b) - 1) * vb) / (len(a) + len(b) - 2))
    if pooled == 0.0:
        return 0.0 if ma == mb else None
    return (ma - mb) / pooled


def vargha_delaney(a: Sequence[float], b: Sequence[float]) -> float:
    """P(X > Y) + P(X = Y) / 2 for X from ``a`` and Y from ``b``."""
    wins = sum((x > y) + 0.5 * (x == y) for x in a for y in b)
    return wins / (len(a) * len(b))


def compare(
    metric: str, objective: str, first: str, a: Sequence[float], second: str, b: Sequence[float]
) -> Comparison:
    """Compare two samples (see the module docstring for the choice of test)."""
    a = [float(x) for x in a]
    b = [float(x) for x in b]
    if not a or not b:
        raise ValueError(f"cannot compare {first} and {second} on {metric}/{objective}: a sample is empty")
    pa, pb = shapiro(a), shapiro(b)
    normal = pa is not None and pb is not None and pa > ALPHA and pb > ALPHA
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        if a == b or (max(a) == min(a) == max(b) == min(b)):
            test, p = "identical samples", 1.0
        elif normal:
            test, p = "t-test (Welch)", float(stats.ttest_ind(a, b, equal_var=False).pvalue)
        else:
            test, p = "Mann-Whitney U", float(stats.mannwhitneyu(a, b, alternative="two-sided").pvalue)
    return _row(metric, objective, (first, a, pa), (second, b, pb), test, p)


def _row(
    metric: str,
    objective: str,
    one: tuple[str, list[float], float | None],
    other: tuple[str, list[float], float | None],
    test: str,
    p: float,
) -> Comparison:
    """A table row: each sample as (name, values, Shapiro-Wilk p), the test and its p, the effect sizes."""
    (first, a, pa), (second, b, pb) = one, other
    return Comparison(
        metric,
        objective,
        first,
        second,
        len(a),
        len(b),
        sum(a) / len(a),
        sum(b) / len(b),
        pa,
        pb,
        test,
        p,
        cohens_d(a, b),
        vargha_delaney(a, b),
    )


def compare_paired(
    metric: str, objective: str, first: str, a: Sequence[float], second: str, b: Sequence[float]
) -> Comparison:
    """Compare two paired samples, ``a[k]`` with ``b[k]`` (see the module docstring for the choice of test).
    The row's ``shapiro_first`` is the Shapiro-Wilk p of the differences ``a[k] - b[k]``, ``shapiro_second``
    None."""
    a = [float(x) for x in a]
    b = [float(x) for x in b]
    if len(a) != len(b):
        raise ValueError(
            f"cannot pair {first} ({len(a)} values) with {second} ({len(b)} values) on {metric}/{objective}"
        )
    if not a:
        raise ValueError(f"cannot compare {first} and {second} on {metric}/{objective}: a sample is empty")
    differences = [x - y for x, y in zip(a, b, strict=True)]
    normal_p = shapiro(differences)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        if not any(differences):
            test, p = "identical samples", 1.0
        elif normal_p is not None and normal_p > ALPHA:
            test, p = "t-test (paired)", float(stats.ttest_rel(a, b).pvalue)
        else:
            test, p = "Wilcoxon signed-rank", float(stats.wilcoxon(a, b).pvalue)
    return _row(metric, objective, (first, a, normal_p), (second, b, None), test, p)


def holm(rows: Sequence[Comparison]) -> list[Comparison]:
    """The rows with Holm-corrected p-values (same order)."""
    corrected = holm_adjusted([row.p_value for row in rows])
    return [replace(row, p_holm=p) for row, p in zip(rows, corrected, strict=True)]


def holm_adjusted(p_values: Sequence[float]) -> list[float]:
    """Holm's step-down adjusted p-values of one family, in the order given."""
    order = sorted(range(len(p_values)), key=lambda i: (p_values[i], i))
    corrected = [math.nan] * len(p_values)
    running = 0.0
    for rank, i in enumerate(order):
        running = max(running, min(1.0, (len(p_values) - rank) * p_values[i]))
        corrected[i] = running
    return corrected


def _p(value: float) -> str:
    return "< 0.0001" if value < 1e-4 else f"{value:.4f}"


def _optional(value: float | None, digits: int = 3) -> str:
    return "n/a" if value is None else f"{value:.{digits}f}"


def markdown_table(rows: Sequence[Comparison]) -> str:
    """The table in Markdown; significant rows (after correction) in bold."""
    header = (
        "| metric | objective | comparison | n | means | Shapiro-Wilk p | test | p | p (Holm) "
        "| Cohen's d | A |\n"
        "|---|---|---|---|---|---|---|---|---|---|---|\n"
    )
    lines = []
    for r in rows:
        strong = "**" if r.significant else ""
        lines.append(
            f"| {r.metric} | {r.objective} | {strong}{r.first} vs {r.second}{strong} "
            f"| {r.n_first}/{r.n_second} "
            f"| {r.mean_first:.4g} / {r.mean_second:.4g} "
            f"| {_optional(r.shapiro_first)} / {_optional(r.shapiro_second)} | {r.test} "
            f"| {_p(r.p_value)} | {strong}{_p(r.p_holm)}{strong} | {_optional(r.cohens_d, 2)} "
            f"| {r.vargha_delaney_a:.2f} |"
        )
    return header + "\n".join(lines) + "\n"
