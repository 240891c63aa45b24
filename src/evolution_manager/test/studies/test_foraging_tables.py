"""The foraging study's statistics: bootstrap intervals, paired tests, the Holm family and progress bands."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy import stats

from evolution_manager.studies import foraging_tables, intervals
from evolution_manager.studies.significance import compare_paired


def test_an_interval_is_a_function_of_its_data_and_the_generator_passed_in():
    values = [0.9, 1.1, 1.3, 1.0, 1.2, 1.4, 0.8, 1.05]
    first = intervals.interval(values, "median", np.random.default_rng(7))
    assert first == intervals.interval(values, "median", np.random.default_rng(7))
    by_mean = intervals.interval(values, "mean", np.random.default_rng(7))
    assert by_mean != intervals.interval(values, "mean", np.random.default_rng(8))  # another generator
    assert first is not None and first[0] <= float(np.median(values)) <= first[1]
    assert intervals.interval([1.0], "median", np.random.default_rng(7)) is None  # one value: undefined
    with pytest.raises(ValueError, match="expected one of median, mean"):
        intervals.interval(values, "mode", np.random.default_rng(7))


def test_the_percentile_interval_is_the_quantiles_of_the_resampled_statistic():
    values = [0.5, 0.7, 0.6, 0.9, 1.1]
    rng = np.random.default_rng(3)
    picks = rng.integers(0, 5, size=(200, 5))
    by_hand = np.quantile(np.median(np.asarray(values)[picks], axis=1), [0.025, 0.975])
    made = intervals.interval(values, "median", np.random.default_rng(3), resamples=200)
    assert made == (float(by_hand[0]), float(by_hand[1]))


def test_a_difference_interval_covers_a_known_shift_about_as_often_as_it_says():
    rng = np.random.default_rng(11)
    covered = 0
    for _ in range(200):
        a, b = rng.normal(1.5, 0.2, 20), rng.normal(1.0, 0.2, 20)
        made = intervals.difference(list(a), list(b), "mean", rng, resamples=1000)
        assert made is not None
        covered += made[0] <= 0.5 <= made[1]
    assert (
        0.88 <= covered / 200 <= 0.99
    )  # 95 % nominal; the percentile interval runs a little narrow at n = 20


def test_at_ten_runs_a_percentile_interval_of_a_mean_covers_about_ninety_percent():
    """What the report says of its intervals at 10 runs per arm: a little narrow."""
    rng = np.random.default_rng(13)
    covered = 0
    for _ in range(400):
        made = intervals.difference(
            list(rng.normal(1.5, 0.2, 10)), list(rng.normal(1.0, 0.2, 10)), "mean", rng, 1000
        )
        assert made is not None
        covered += made[0] <= 0.5 <= made[1]
    assert 0.85 <= covered / 400 <= 0.95


def test_paired_runs_get_the_paired_tests_by_the_normality_of_their_differences():
    rng = np.random.default_rng(5)
    base = rng.normal(1.4, 0.3, 10)  # runs that differ a lot from each other ...
    shifted = base + 0.05 + rng.normal(0.0, 0.01, 10)  # ... and a small, steady gain run by run
    row = compare_paired("best fitness", "foraging", "swarm", list(shifted), "source", list(base))
    assert row.test == "t-test (paired)" and row.shapiro_second is None
    assert row.shapiro_first == pytest.approx(stats.shapiro(shifted - base).pvalue)
    assert row.p_value == pytest.approx(stats.ttest_rel(shifted, base).pvalue) and row.p_value < 1e-4
    unpaired = stats.ttest_ind(shifted, base, equal_var=False).pvalue
    assert unpaired > 0.5  # the same runs unpaired show nothing: pairing is what finds the gain
    skewed = base + np.array([0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.01, 0.02, 0.9])
    row = compare_paired("best fitness", "foraging", "swarm", list(skewed), "source", list(base))
    assert row.test == "Wilcoxon signed-rank"
    assert row.p_value == pytest.approx(stats.wilcoxon(skewed, base).pvalue)
    same = compare_paired("best fitness", "foraging", "swarm", list(base), "source", list(base))
    assert (same.test, same.p_value) == ("identical samples", 1.0)
    with pytest.raises(ValueError, match="cannot pair"):
        compare_paired("best fitness", "foraging", "swarm", [1.0, 2.0], "source", [1.0])


def _scores() -> foraging_tables.Scores:
    rng = np.random.default_rng(2)
    scores: foraging_tables.Scores = {}
    for metric, _ in foraging_tables.METRICS:
        source = {k: float(v) for k, v in enumerate(rng.normal(1.5, 0.2, 10))}
        scores[metric] = {
            "flat": {k: float(v) for k, v in enumerate(rng.normal(0.9, 0.1, 10))},
            "source": source,
            "swarm": {k: v + 0.02 + float(rng.normal(0, 0.005)) for k, v in source.items()},
        }
    return scores


def test_the_tests_pair_by_run_index_correct_over_one_family_and_name_it():
    pairs = [("source", "flat"), ("swarm", "source")]
    rows = foraging_tables.tests(_scores(), pairs, paired=[("swarm", "source")])
    assert len(rows) == 4  # two pairs on two metrics: one family
    assert sorted(r.row.p_holm for r in rows) == pytest.approx(
        sorted(min(1.0, p) for p in _holm([r.row.p_value for r in rows]))
    )
    swarm = foraging_tables.find_test(rows, "best fitness", ("swarm", "source"))
    assert swarm is not None and swarm.paired and swarm.effect.endswith("of paired Δ")
    assert swarm.row.significant and swarm.favours_first  # a steady gain run by run, found paired
    flat = foraging_tables.find_test(rows, "held-out best fitness", ("source", "flat"))
    assert flat is not None and not flat.paired and flat.effect in ("Δ mean", "Δ median")
    assert flat.interval is not None and flat.interval[0] < flat.estimate < flat.interval[1]
    text = foraging_tables.comparisons_table(rows)
    assert (
        "the 4 rows of this table (2 comparisons on 2 metrics: best fitness, held-out best fitness)" in text
    )
    assert "| 10 pairs |" in text and "| 10/10 |" in text
    # a run missing from one arm leaves that pair out of the paired test
    scores = _scores()
    del scores["best fitness"]["swarm"][3]
    again = foraging_tables.tests(scores, pairs, paired=[("swarm", "source")])
    paired = foraging_tables.find_test(again, "best fitness", ("swarm", "source"))
    assert paired is not None and paired.row.n_first == paired.row.n_second == 9


def _holm(ps: list[float]) -> list[float]:
    order = sorted(range(len(ps)), key=lambda i: ps[i])
    out, running = [0.0] * len(ps), 0.0
    for rank, i in enumerate(order):
        running = max(running, (len(ps) - rank) * ps[i])
        out[i] = running
    return out


def test_a_progress_band_steps_each_run_and_spans_where_every_run_has_a_value():
    curves = [
        ([10.0, 20.0, 30.0, 40.0], [math.nan, 1.0, 2.0, 3.0]),
        ([10.0, 25.0, 35.0], [0.5, 1.5, 2.5]),
        ([15.0, 30.0, 45.0], [1.0, 1.0, 4.0]),
    ]
    band = foraging_tables.progress_band(curves, points=5)
    assert band.runs == 3
    assert band.evaluations == [20.0, 23.75, 27.5, 31.25, 35.0]  # the latest first value to the earliest end
    ends = foraging_tables.progress_band(curves, points=2)  # at 20: (1.0, 0.5, 1.0); at 35: (2.0, 2.5, 1.0)
    assert ends.median == [1.0, 2.0]
    assert ends.low == [0.75, 1.5] and ends.high == [1.0, 2.25]
