"""A run's final choice made on validation scenarios, not on the scenario it was evolved on.

Every evaluation of a run is on one fixed scenario, and the run keeps the genome that scored highest there.
Among a thousand genomes that maximum is partly the scenario's luck (the winner's curse): in issue 36's
pilots every composition beat the best homogeneous swarm on the run's scenario and lost to it on the
held-out ones. Here the ``VALIDATION_CANDIDATES`` best distinct genomes of the run are re-scored on
``VALIDATION_EVALUATIONS`` validation scenarios, and the one of highest mean there is the run's validated
choice. The held-out scenarios, drawn apart from both, then measure that choice without the bias of having
chosen it. The homogeneous baseline inside a composition run is chosen the same way among its cells, so
the two are compared alike.

The validation scenarios come from the run's scenario seed along ``RUN_VALIDATION``; the held-out ones along
``RUN_HELDOUT``: the two sets share no seed but by a 64-bit collision.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Hashable, Iterable, Sequence
from dataclasses import dataclass
from typing import Generic, TypeVar

from bt_controller.draws import RUN_VALIDATION, derive_seed

VALIDATION_EVALUATIONS = 5
"""Validation scenarios per candidate: as many as the held-out scenarios (``HELDOUT_EVALUATIONS``)."""

VALIDATION_CANDIDATES = 10
"""How many of a run's best distinct genomes are re-scored: 50 evaluations of a run's 1,000 or more."""

_Genome = TypeVar("_Genome", bound=Hashable)


def validation_seeds(scenario_seed: int, count: int = VALIDATION_EVALUATIONS) -> list[int]:
    """The seeds of a run's validation scenarios, from its scenario seed."""
    return [derive_seed(scenario_seed, RUN_VALIDATION, r) for r in range(count)]


def validation_settings(scenario_seed: int, trials: int) -> dict:
    """What a run's summary records of its validation: the scenarios' seeds, how many, how many candidates
    were re-scored and the trials of each evaluation."""
    return {
        "seeds": validation_seeds(scenario_seed),
        "evaluations": VALIDATION_EVALUATIONS,
        "candidates": VALIDATION_CANDIDATES,
        "trials": trials,
    }


def best_distinct(
    scored: Iterable[tuple[_Genome, float]], count: int = VALIDATION_CANDIDATES
) -> list[tuple[_Genome, float]]:
    """The ``count`` genomes of highest fitness, each once with its first score, the earlier first among
    equal fitness (the order a run met them in)."""
    first: dict[_Genome, float] = {}
    for genome, fitness in scored:
        first.setdefault(genome, fitness)
    ordered = sorted(enumerate(first.items()), key=lambda entry: (-entry[1][1], entry[0]))
    return [item for _, item in ordered[:count]]


@dataclass(frozen=True)
class Validated(Generic[_Genome]):
    """The validated choice: the genome, its fitness on the run's scenario and its mean on the validation
    scenarios, with every candidate's pair of scores (validation None where an evaluation failed)."""

    genome: _Genome
    fitness: float
    validation_fitness: float
    candidates: tuple[tuple[_Genome, float, float | None], ...]


def choose_on_validation(
    candidates: Sequence[tuple[_Genome, float]], score: Callable[[Sequence[_Genome]], Sequence[float | None]]
) -> Validated[_Genome] | None:
    """The candidate of highest validation mean (the earlier in ``candidates`` among equals); ``score`` gives
    each genome's mean over the validation scenarios, or None where an evaluation failed. None when no
    candidate could be scored."""
    if not candidates:
        return None
    means = list(score([genome for genome, _ in candidates]))
    if len(means) != len(candidates):
        raise ValueError(f"{len(candidates)} candidates scored with {len(means)} validation means")
    chosen: tuple[int, float] | None = None
    for index, mean in enumerate(means):
        if mean is not None and math.isfinite(mean) and (chosen is None or mean > chosen[1]):
            chosen = (index, mean)
    if chosen is None:
        return None
    index, mean = chosen
    genome, fitness = candidates[index]
    rows = tuple((g, f, m) for (g, f), m in zip(candidates, means, strict=True))
    return Validated(genome, fitness, float(mean), rows)
