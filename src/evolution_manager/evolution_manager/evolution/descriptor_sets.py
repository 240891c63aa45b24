"""The behaviour spaces a tree run's grids bin trees by: a run's ``descriptors`` setting names one.

``behaviour`` is the paper's: movement, rotation and conditionality, as the evaluator gives them (each in
[0, 1]). ``deliveries`` is the authors' 2026 one for swarms of several food kinds (``ga/qd.py``; their
descriptors are the deliveries of each kind): a tree's deliveries of kinds 1, 2 and 3 per robot per trial,
each divided by ``DELIVERY_DOMAIN`` so that the grid spans [0, 1]; more than that is kept in the last bin,
as their grid keeps a value beyond its domain. ``deliveries-0.25`` is the same axes over [0, 0.25], for tasks
whose trees deliver little of each kind (on ``multifood-arena6-carriers`` no tree of the heterogeneity study
delivered more than 0.27 of a kind, so the authors' grid left seven bins in eight of each axis almost empty).
``evaluations.csv`` always records the evaluator's own values; the grids, the archive and the repertoire
files hold the run's descriptors.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING

from swarm_sim.model import DESCRIPTORS, OBJECTIVES

if TYPE_CHECKING:
    from swarm_sim.tasks import TaskSpec

DELIVERY_DOMAIN = 0.5
"""Deliveries of one kind per robot per trial at the top of a ``deliveries`` grid axis (8 bins of 0.0625):
the reference trees on the authors' arenas 6 and 9 deliver 0.001 to 0.23 of a kind (docs/validation.md)."""

FOOD_KINDS = ("foraging1", "foraging2", "foraging3")


@dataclass(frozen=True)
class DescriptorSet:
    """A behaviour space: its axes' names and how an evaluation's values give a point of it in [0, 1]^3."""

    name: str
    names: tuple[str, ...]
    """The axes, as the grids, figures and repertoire files name them."""
    description: str
    values: Callable[[Sequence[float], Sequence[float]], tuple[float, ...]]
    """(every objective in ``OBJECTIVES`` order, the evaluator's descriptors) -> the axes' measured values,
    as a log records them."""
    scaled: Callable[[Sequence[float]], tuple[float, ...]]
    """The axes' measured values -> the point in [0, 1]^3."""

    def point(self, fitness: Sequence[float], descriptors: Sequence[float]) -> tuple[float, ...]:
        """The point of an evaluation (every objective, the evaluator's descriptors) in [0, 1]^3."""
        return self.scaled(self.values(fitness, descriptors))


def _delivery_values(fitness: Sequence[float], _: Sequence[float]) -> tuple[float, ...]:
    return tuple(float(fitness[OBJECTIVES.index(k)]) for k in FOOD_KINDS)


def _deliveries(name: str, domain: float, whose: str) -> DescriptorSet:
    """The deliveries of kinds 1-3 per robot per trial, each axis over [0, ``domain``] (more: last bin)."""

    def point(values: Sequence[float]) -> tuple[float, ...]:
        return tuple(min(1.0, max(0.0, v / domain)) for v in values)

    description = f"deliveries of food kinds 1-3 per robot per trial over [0, {domain:g}] ({whose})"
    return DescriptorSet(name, FOOD_KINDS, description, _delivery_values, point)


BEHAVIOUR = DescriptorSet(
    "behaviour",
    DESCRIPTORS,
    "movement, rotation and conditionality (the paper's)",
    lambda _, descriptors: tuple(float(d) for d in descriptors),
    tuple,
)
DELIVERIES = _deliveries("deliveries", DELIVERY_DOMAIN, "the authors' 2026")
DELIVERIES_QUARTER = _deliveries("deliveries-0.25", 0.25, "for tasks of few deliveries")
DELIVERY_SETS = (DELIVERIES, DELIVERIES_QUARTER)
"""The behaviour spaces of deliveries per food kind: they need a task of several kinds."""
DESCRIPTOR_SETS: dict[str, DescriptorSet] = {s.name: s for s in (BEHAVIOUR, *DELIVERY_SETS)}
"""Every behaviour space by name; ``behaviour`` is the default."""


def descriptor_set(name: str) -> DescriptorSet:
    """The set named ``name``; ValueError naming the choices otherwise."""
    if name not in DESCRIPTOR_SETS:
        raise ValueError(f"descriptors must be one of {', '.join(DESCRIPTOR_SETS)}, got {name!r}")
    return DESCRIPTOR_SETS[name]


def checked_space(name: str, task: TaskSpec, what: str, example: str) -> DescriptorSet:
    """The set named ``name`` for runs on ``task``; ValueError naming the choices, or, for ``deliveries`` on a
    task of one food kind, saying that ``what`` (trees, swarms) need a task of several (``example``)."""
    space = descriptor_set(name)
    if space in DELIVERY_SETS and task.config().food_kinds < 2:
        raise ValueError(
            f"descriptors {name} bins {what} by the deliveries of each food kind: task {task.name} has "
            f"one kind of food; give a task of several ({example}, ...)"
        )
    return space
