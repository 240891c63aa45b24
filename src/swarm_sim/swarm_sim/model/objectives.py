"""The objectives and behaviour descriptors as a table: each declared once, with what it measures.

A trial scores every objective of the table (``world.trial_values`` computes them in ``VALUE_NAMES`` order);
a task (``swarm_sim.tasks``) names the ones it is about. Pure Python: commands that only need the names (the
task tools, the option parsers) import this without the compiled world model.
"""

from __future__ import annotations

import math
from typing import NamedTuple

__all__ = [
    "COUNT_OBJECTIVES",
    "DESCRIPTORS",
    "DESCRIPTOR_TABLE",
    "FAMILIES",
    "N_OBJECTIVES",
    "N_PROBES",
    "N_VALUES",
    "OBJECTIVES",
    "OBJECTIVE_TABLE",
    "PAPER_OBJECTIVES",
    "PROBES",
    "VALUE_NAMES",
    "Objective",
    "fitness_ceiling",
]


class Objective(NamedTuple):
    """One row of the objectives table (``docs/model.md``, "Objectives").

    ``probe``: what it reads of each robot, at a trial's first (or initial) and last step, or over the trial;
    ``mapping``: how that becomes a fitness; ``ceiling``: the largest fitness (inf for a count);
    ``family``: the name of a library primitive evolved for it ("" for an objective that is no primitive).
    """

    name: str
    probe: str
    mapping: str
    ceiling: float
    family: str


OBJECTIVE_TABLE: tuple[Objective, ...] = (
    Objective(
        "density",
        "smoothed neighbourhood density at the initial and last steps",
        "(final - initial + 1) / 2, clipped to [0, 1]",
        1.0,
        "increaseDensity",
    ),
    Objective(
        "nest",
        "smoothed nest estimate at the initial and last steps",
        "((initial - final) / cap + 1) / 2; 1 when the final estimate is 0",
        1.0,
        "gotoNest",
    ),
    Objective(
        "food",
        "smoothed food estimate at the initial and last steps",
        "((initial - final) / cap + 1) / 2; 1 when the final estimate is 0",
        1.0,
        "gotoFood",
    ),
    Objective(
        "idensity",
        "smoothed neighbourhood density at the initial and last steps",
        "(initial - final + 1) / 2, clipped to [0, 1]",
        1.0,
        "reduceDensity",
    ),
    Objective(
        "inest",
        "smoothed nest estimate at the initial and last steps",
        "((final - initial) / cap + 1) / 2",
        1.0,
        "goAwayFromNest",
    ),
    Objective(
        "ifood",
        "true distance from the food region at the first and last steps",
        "(final - first + R) / (2 R), R the food region's radius",
        1.0,
        "goAwayFromFood",
    ),
    Objective(
        "foraging",
        "deliveries counted over the trial",
        "deliveries per robot per trial",
        math.inf,
        "",
    ),
    Objective(
        "aggregation",
        "true mean distance from the other robots at the first and last steps",
        "((first - last) / first + 1) / 2, clipped to [0, 1]; 0.5 for a robot alone",
        1.0,
        "",
    ),
    *(
        Objective(
            f"foraging{kind}",
            f"deliveries of food kind {kind} counted over the trial",
            "deliveries of the kind per robot per trial",
            math.inf,
            "",
        )
        for kind in (1, 2, 3)
    ),
    Objective(
        "foraging_biased",
        "deliveries of each food kind counted over the trial",
        "deliveries of the preferred kind + other_food_weight x those of the other kinds, per robot per "
        "trial; all deliveries when no kind is preferred",
        math.inf,
        "",
    ),
    Objective(
        "foraging_balanced",
        "the swarm's deliveries of each food kind counted over the trial",
        "K x the least over the arena's K food kinds of the swarm's deliveries of the kind per robot per "
        "trial, every robot given the swarm's value; foraging for one kind",
        math.inf,
        "",
    ),
)
"""Every objective, in fitness order: the paper's three, the 2024 follow-up's three inverse primitives,
foraging (every kind of food), aggregation (the ``aggregation`` task's, which neither paper has), the
authors' 2026 multi-food objectives: foraging of one kind each, and their bias and penalty fitness; and
this project's balanced foraging (issue 36), a property of the swarm that only a swarm delivering every kind
alike maximises. A new objective is a row appended here and its mapping appended to
``world.robot_objectives`` (``docs/tasks.md``)."""

PROBES: tuple[str, ...] = ("food_distance", "neighbour_distance")
"""What every road measures of each robot's true state at a trial's first and last steps
(``world.take_probes``), for the objectives that score the world rather than the robot's own estimates: the
distance from the food region (mm, 0 on food) and the mean distance from the other robots (mm)."""
N_PROBES = len(PROBES)

DESCRIPTOR_TABLE: tuple[Objective, ...] = (
    Objective("movement", "each tick's movement of the action run", "(sum + ticks) / (2 ticks)", 1.0, ""),
    Objective("rotation", "each tick's rotation of the action run", "(sum + ticks) / (2 ticks)", 1.0, ""),
    Objective(
        "conditionality",
        "condition ticks and action starts of the tree",
        "conditions / (conditions + starts); 1 when neither",
        1.0,
        "",
    ),
)
"""The three behaviour descriptors, in grid order (rows of the same shape: what they read and their map)."""

OBJECTIVES: tuple[str, ...] = tuple(row.name for row in OBJECTIVE_TABLE)
"""The objectives, in fitness order."""
DESCRIPTORS: tuple[str, ...] = tuple(row.name for row in DESCRIPTOR_TABLE)
"""The three behaviour descriptors, in grid order."""
VALUE_NAMES: tuple[str, ...] = OBJECTIVES + DESCRIPTORS
"""The values of a trial or an evaluation: the objectives, then the descriptors (the one home of these
names)."""
N_OBJECTIVES = len(OBJECTIVES)
"""How many of the values are objectives."""
N_VALUES = len(VALUE_NAMES)
COUNT_OBJECTIVES: tuple[str, ...] = tuple(row.name for row in OBJECTIVE_TABLE if math.isinf(row.ceiling))
"""Objectives whose fitness is a count (deliveries per robot per trial: 0 or more, an ideal robot about 2.6);
every other objective is a fraction in [0, 1]."""
PAPER_OBJECTIVES: tuple[str, ...] = ("density", "nest", "food")
"""The three objectives of the 2023 paper (its GP_fnd evolves them together)."""
FAMILIES: dict[str, str] = {row.name: row.family for row in OBJECTIVE_TABLE if row.family}
"""The family name of each primitive objective, in the authors' order (``params.py:134-166``): which objective
a primitive of a library was evolved for."""


def fitness_ceiling(objective: str) -> float:
    """The largest fitness ``objective`` can take: 1 for a fraction, unbounded for a count."""
    return next(row.ceiling for row in OBJECTIVE_TABLE if row.name == objective)
