"""Percentile bootstrap confidence intervals for the statistics a report sets beside its tests.

Every interval is drawn from the generator the caller passes in (``numpy.random.Generator``), so that a
report that makes each one from a stated seed can be recomputed exactly from its data. Three designs:

- :func:`interval`: a statistic of one sample (the median of an arm's runs), the runs resampled with
  replacement;
- :func:`difference`: a statistic of the first sample minus the same statistic of the second, for two
  independent samples, each resampled on its own (the unpaired tests);
- a paired difference is :func:`interval` of the run-by-run differences (the pairs resampled together).

An interval of fewer than two values is undefined (``None``): resampling one value gives it back every time.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence

import numpy as np

RESAMPLES = 10_000
"""Bootstrap resamples per interval."""

LEVEL = 0.95
"""The intervals' confidence level."""

Statistic = Callable[..., np.ndarray]
"""A numpy reduction with an ``axis`` argument (``np.median``, ``np.mean``)."""

STATISTICS: dict[str, Statistic] = {"median": np.median, "mean": np.mean}
"""The statistics by name."""


def _resampled(
    values: Sequence[float], statistic: str, rng: np.random.Generator, resamples: int
) -> np.ndarray:
    data = np.asarray(values, dtype=float)
    picks = rng.integers(0, len(data), size=(resamples, len(data)))
    result: np.ndarray = STATISTICS[statistic](data[picks], axis=1)
    return result


def _bounds(draws: np.ndarray, level: float) -> tuple[float, float]:
    tail = (1.0 - level) / 2.0
    low, high = np.quantile(draws, [tail, 1.0 - tail])
    return float(low), float(high)


def _check(statistic: str, resamples: int, level: float) -> None:
    if statistic not in STATISTICS:
        raise ValueError(f"unknown statistic {statistic!r}: expected one of {', '.join(STATISTICS)}")
    if resamples < 1:
        raise ValueError(f"resamples must be at least 1, got {resamples}")
    if not 0.0 < level < 1.0:
        raise ValueError(f"level must lie in (0, 1), got {level}")


def interval(
    values: Sequence[float],
    statistic: str,
    rng: np.random.Generator,
    resamples: int = RESAMPLES,
    level: float = LEVEL,
) -> tuple[float, float] | None:
    """The percentile bootstrap interval of ``statistic`` ("median" or "mean") of one sample, or None for
    fewer than two values."""
    _check(statistic, resamples, level)
    if len(values) < 2:
        return None
    return _bounds(_resampled(values, statistic, rng, resamples), level)


def difference(
    first: Sequence[float],
    second: Sequence[float],
    statistic: str,
    rng: np.random.Generator,
    resamples: int = RESAMPLES,
    level: float = LEVEL,
) -> tuple[float, float] | None:
    """The percentile bootstrap interval of ``statistic(first) - statistic(second)`` for two independent
    samples, each resampled on its own (the first's resamples drawn before the second's), or None when
    either has fewer than two values."""
    _check(statistic, resamples, level)
    if len(first) < 2 or len(second) < 2:
        return None
    draws = _resampled(first, statistic, rng, resamples) - _resampled(second, statistic, rng, resamples)
    return _bounds(draws, level)


__all__ = ["LEVEL", "RESAMPLES", "STATISTICS", "difference", "interval"]
