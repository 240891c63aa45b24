"""The validated choice of a run (``evolution.validation``): the best distinct candidates, re-scored, the
highest validation mean chosen, on scenarios apart from the held-out ones."""

from __future__ import annotations

import pytest

from evolution_manager.evolution.run_config import HELDOUT_EVALUATIONS, heldout_seed
from evolution_manager.evolution.validation import (
    VALIDATION_CANDIDATES,
    VALIDATION_EVALUATIONS,
    best_distinct,
    choose_on_validation,
    validation_seeds,
    validation_settings,
)


def test_the_best_distinct_genomes_keep_their_first_score_and_the_earlier_among_equals():
    scored = [("a", 0.1), ("b", 0.5), ("a", 0.9), ("c", 0.5), ("d", 0.7), ("e", 0.2)]
    # "a" counts with its first score (a fixed scenario gives a genome one result; the first is the record)
    assert best_distinct(scored, 3) == [("d", 0.7), ("b", 0.5), ("c", 0.5)]
    assert best_distinct(scored, 10) == [("d", 0.7), ("b", 0.5), ("c", 0.5), ("e", 0.2), ("a", 0.1)]
    assert best_distinct([], 3) == []
    assert len(best_distinct([(k, k / 100) for k in range(100)])) == VALIDATION_CANDIDATES


def test_the_highest_validation_mean_is_chosen_not_the_highest_run_fitness():
    candidates = [("a", 0.9), ("b", 0.8), ("c", 0.7)]
    asked = []

    def score(genomes):
        asked.append(list(genomes))
        return [{"a": 0.2, "b": None, "c": 0.6}[g] for g in genomes]

    chosen = choose_on_validation(candidates, score)
    assert asked == [["a", "b", "c"]]  # one batch
    assert chosen is not None and (chosen.genome, chosen.fitness, chosen.validation_fitness) == (
        "c",
        0.7,
        0.6,
    )
    assert chosen.candidates == (("a", 0.9, 0.2), ("b", 0.8, None), ("c", 0.7, 0.6))
    # the earlier among equal means; nothing chosen when nothing could be scored
    tie = choose_on_validation(candidates, lambda genomes: [0.5 for _ in genomes])
    assert tie is not None and tie.genome == "a"
    assert choose_on_validation(candidates, lambda genomes: [None, float("nan"), None]) is None
    assert choose_on_validation([], score) is None
    with pytest.raises(ValueError, match="3 candidates scored with 2 validation means"):
        choose_on_validation(candidates, lambda genomes: [0.1, 0.2])


def test_validation_scenarios_are_seeded_by_the_run_and_apart_from_the_held_out_ones():
    seeds = validation_seeds(1234)
    assert seeds == validation_seeds(1234) and len(set(seeds)) == VALIDATION_EVALUATIONS
    assert validation_seeds(1235) != seeds
    assert not set(seeds) & {heldout_seed(1234, r) for r in range(HELDOUT_EVALUATIONS)}
    assert 1234 not in seeds  # nor the run's own scenario
    assert validation_settings(1234, 7) == {
        "seeds": seeds,
        "evaluations": VALIDATION_EVALUATIONS,
        "candidates": VALIDATION_CANDIDATES,
        "trials": 7,
    }
