"""Repertoires: qdpy grids of 8 x 8 x 8 bins over the behaviour descriptors, 3 trees per bin (or 1).

Metrics as the authors' analysis (charts/analysis.py:61-88): coverage = filled bins / 512; QD score = the sum
over filled bins of the best fitness in the bin, divided by 512; repertoire size (paper, fig. 8) = filled
bins. A tree text is stored at most once per grid (the authors' qdpy/ea.py:394 drops an offspring the
container already holds): a tree offered again is refused, whatever its fitness. A grid given ``forms`` (runs
of the ``clean`` profile) also refuses a tree whose simplified form (:class:`SimplifiedForms`) is already in
its bin: a clone that behaves exactly as a tree the bin holds is not a second behaviour (docs/algorithms.md,
"Clones").

A :class:`Repertoire` wraps a ``qdpy.containers.Grid`` and keeps for every stored tree its text, its
fitness on one objective, its descriptors and the index of the evaluation that produced it. The same
class is the MAP-Elites archive and the passive grid that every evaluated tree of every algorithm is
offered to, so coverage and QD score compare like with like.

Notes on qdpy 0.1.2.2 with numpy 2: a ``qdpy`` ``Fitness`` defaults to *minimisation* (weights -1) and
stores weighted values, and the grid overwrites an individual's weights with its own ``fitness_weights``;
we give both the fitness and the grid the weights ``(1.0,)``, and store plain Python floats. The grid finds
an individual in its item list by equality, and qdpy's ``Individual`` compares by content, so two
evaluations of the same tree would count as one: our :class:`Entry` compares by identity (each evaluation
is its own item). The grid silently ignores an individual whose features are out of bounds, so values are
checked before they reach it.
"""

from __future__ import annotations

import math
from collections.abc import Iterator
from dataclasses import dataclass

import numpy as np

from bt_controller.language import Library, parse, simplify_if_small, to_text
from evolution_manager.evolution.qdpy_grid import Features, Fitness, Grid, ScoresDict

GRID_SHAPE: tuple[int, int, int] = (8, 8, 8)
ITEMS_PER_BIN = 3
WEIGHTS = (1.0,)


class SimplifiedForms:
    """The simplified form of a tree text, ``to_text(simplify_if_small(parse(text)))``, once per text.

    ``bt_controller.language.simplify`` keeps every motor of every tick (so fitness, movement and rotation)
    and may change only the count of condition ticks (conditionality); it takes about a millisecond or two per
    evolved tree, so one instance is shared by everything that asks (a run's grids and its cache). A run
    with a primitive library gives it: its names are parsed into their ``success`` copies, and the form is
    the expanded tree's (two trees that expand to the same simplified tree are clones, names or not)."""

    def __init__(self, library: Library | None = None) -> None:
        self._forms: dict[str, str] = {}
        self.library = library

    def __call__(self, tree: str) -> str:
        form = self._forms.get(tree)
        if form is None:
            form = self._forms[tree] = to_text(simplify_if_small(parse(tree, library=self.library)))
        return form


class Entry:
    """One evaluated tree in a grid, as qdpy's containers see an individual (its ``IndividualLike``
    protocol), equal only to itself. ``genome`` may carry the algorithm's own form of the tree (MAP-Elites
    keeps its DEAP tree there, to vary it without parsing the text again)."""

    __slots__ = (
        "descriptors",
        "elapsed",
        "evaluation",
        "features",
        "fitness",
        "genome",
        "name",
        "scores",
        "tree",
        "value",
    )

    def __init__(
        self,
        tree: str,
        fitness: float,
        descriptors: tuple[float, ...],
        evaluation: int,
        genome: object = None,
    ) -> None:
        self.tree = tree
        self.value = fitness
        self.descriptors = tuple(descriptors)
        self.evaluation = evaluation
        self.genome = genome
        self.name = str(evaluation)
        self.fitness = Fitness((fitness,), weights=WEIGHTS)
        self.features = Features(self.descriptors)
        self.scores = ScoresDict()
        self.elapsed = math.nan

    def dominates(self, other: Entry) -> bool:
        """qdpy's individual dominance: on fitness."""
        return self.fitness.dominates(other.fitness)

    def reset(self) -> None:  # part of qdpy's protocol; entries are never reset
        raise TypeError("a grid entry is immutable")

    def __setitem__(self, key: object, value: object) -> None:  # part of qdpy's protocol
        raise TypeError("a grid entry is immutable")


class _Grid(Grid):
    """qdpy's ``Grid`` with shortcuts that keep its behaviour for :class:`Entry` items: the bin of an entry
    is computed from its descriptors directly (qdpy checks runtime protocols on every call); the bounds
    check is skipped (``Repertoire.offer`` checked them); and a new entry is appended to the item list
    without searching it (an entry is a new object every time and compares by identity, so the search
    could never find it)."""

    def index_grid(self, param: object) -> tuple:
        if isinstance(param, Entry):
            return self._index_grid_features(param.descriptors)
        return super().index_grid(param)

    def _check_if_can_be_added(self, individual: object) -> None:
        if not isinstance(individual, Entry):  # an Entry's values were checked by Repertoire.offer
            super()._check_if_can_be_added(individual)

    def _add_to_collection(self, collection: list, individual: object) -> tuple[bool, int]:
        if isinstance(individual, Entry) and isinstance(collection, list):
            collection.append(individual)
            return True, len(collection) - 1
        return super()._add_to_collection(collection, individual)


@dataclass(frozen=True)
class Item:
    """A stored tree as it appears in a repertoire file."""

    bin: tuple[int, int, int]
    tree: str
    fitness: float
    descriptors: tuple[float, float, float]
    evaluation: int


def _unit(value: float, what: str, top: float = 1.0) -> float:
    """``value`` checked to lie in [0, ``top``] (rounding errors of 1e-9 put back inside)."""
    value = float(value)
    if not (math.isfinite(value) and -1e-9 <= value <= top + 1e-9):
        raise ValueError(f"{what} must be a number in [0, {top:g}], got {value!r}")
    return min(max(value, 0.0), top)


class Repertoire:
    """A grid of ``GRID_SHAPE`` bins holding up to ``ITEMS_PER_BIN`` trees each (qdpy ``Grid``).

    A tree enters a bin with a free place; in a full bin it replaces the worst item when its fitness is
    strictly higher (qdpy's rule). Every bin's items keep their order of arrival. A tree text the grid holds
    is refused; with ``forms``, so is a tree whose simplified form one of its bin's items has.
    """

    def __init__(
        self,
        shape: tuple[int, ...] = GRID_SHAPE,
        items_per_bin: int = ITEMS_PER_BIN,
        forms: SimplifiedForms | None = None,
        fitness_max: float = 1.0,
    ) -> None:
        self.shape = tuple(shape)
        self.items_per_bin = items_per_bin
        self.forms = forms
        self.fitness_max = fitness_max
        """The largest fitness offered (``swarm_sim.core.world.fitness_ceiling``: 1, or unbounded for a
        count)."""
        self.grid = _Grid(
            shape=self.shape,
            max_items_per_bin=items_per_bin,
            fitness_domain=((0.0, fitness_max),),
            features_domain=((0.0, 1.0),) * len(self.shape),
            fitness_weights=WEIGHTS,
        )
        self.offered = 0
        self._held: set[str] = set()

    def offer(
        self,
        tree: str,
        fitness: float,
        descriptors: tuple[float, ...],
        evaluation: int,
        genome: object = None,
    ) -> bool:
        """Offer one evaluated tree; return whether the grid kept it."""
        fitness = _unit(fitness, "fitness", self.fitness_max)
        descriptors = tuple(_unit(d, "a descriptor") for d in descriptors)
        if len(descriptors) != len(self.shape):
            raise ValueError(f"expected {len(self.shape)} descriptors, got {len(descriptors)}")
        self.offered += 1
        if tree in self._held:
            return False
        # qdpy would refuse a tree no better than the worst of a full bin: say so without building an entry
        index = self.grid._index_grid_features(descriptors)
        held = self.grid.solutions[index]
        if len(held) >= self.items_per_bin and fitness <= min(e.value for e in held):
            return False
        if self.forms is not None and held:  # simplified only when it could decide
            form = self.forms(tree)
            if any(self.forms(e.tree) == form for e in held):
                return False
        before = [e.tree for e in held]
        if self.grid.add(Entry(tree, fitness, descriptors, evaluation, genome)) is None:
            return False
        after = {e.tree for e in self.grid.solutions[index]}
        self._held.difference_update(t for t in before if t not in after)
        self._held.add(tree)
        return True

    def bin_of(self, descriptors: tuple[float, ...]) -> tuple[int, ...]:
        """The bin index of a descriptor vector."""
        return tuple(
            int(i) for i in self.grid.index_grid(tuple(_unit(d, "a descriptor") for d in descriptors))
        )

    def bins(self) -> Iterator[tuple[tuple[int, ...], list[Entry]]]:
        """Filled bins in index order, each with its items in order of arrival."""
        for index in sorted(self.grid.solutions):
            entries = self.grid.solutions[index]
            if entries:
                yield tuple(int(i) for i in index), entries

    def entries(self) -> list[Entry]:
        """Every stored item, bin by bin (index order), then in order of arrival: a canonical order."""
        return [entry for _, entries in self.bins() for entry in entries]

    def __len__(self) -> int:
        return len(self.grid)

    @property
    def filled_bins(self) -> int:
        """Filled bins: the repertoire size of the paper's fig. 8."""
        return int(self.grid.filled_bins)

    @property
    def bin_count(self) -> int:
        return math.prod(self.shape)

    @property
    def coverage(self) -> float:
        """Filled bins / all bins."""
        return self.filled_bins / self.bin_count

    @property
    def qd_score(self) -> float:
        """The sum over filled bins of the best fitness in the bin, divided by the number of bins (512), as
        the authors' analysis (charts/analysis.py:83-86); from qdpy's per-bin quality array."""
        total = math.fsum(float(v) for v in self.grid.quality_array[..., 0].ravel() if v == v)
        return total / self.bin_count

    def best_entries(self) -> list[tuple[tuple[int, ...], Entry]]:
        """The best item of every filled bin (the first to arrive among equals), in bin order."""
        chosen = []
        for index, entries in self.bins():
            best = entries[0]
            for entry in entries[1:]:
                if entry.value > best.value:
                    best = entry
            chosen.append((index, best))
        return chosen

    @property
    def best_value(self) -> float | None:
        """The highest fitness held (None when empty)."""
        return float(np.nanmax(self.grid.quality_array)) if self.filled_bins else None

    def best(self) -> Entry | None:
        """The item with the highest fitness (the first in canonical order on ties), or None when empty."""
        best: Entry | None = None
        for entry in self.entries():
            if best is None or entry.value > best.value:
                best = entry
        return best

    def best_per_bin(self) -> dict[tuple[int, ...], float]:
        """The best fitness of every filled bin."""
        return {index: max(e.value for e in entries) for index, entries in self.bins()}

    def items(self) -> list[Item]:
        """The stored trees as plain records, in canonical order."""
        return [
            Item(index, e.tree, e.value, e.descriptors, e.evaluation)  # type: ignore[arg-type]  # 3-d grid
            for index, entries in self.bins()
            for e in entries
        ]

    def to_state(self) -> dict:
        """A JSON-able description from which :meth:`from_state` rebuilds an identical repertoire."""
        return {
            "shape": list(self.shape),
            "items_per_bin": self.items_per_bin,
            "offered": self.offered,
            "bins": [
                {
                    "bin": list(index),
                    "items": [
                        {
                            "tree": e.tree,
                            "fitness": e.value,
                            "descriptors": list(e.descriptors),
                            "evaluation": e.evaluation,
                        }
                        for e in entries
                    ],
                }
                for index, entries in self.bins()
            ],
        }

    @classmethod
    def from_state(
        cls, state: dict, forms: SimplifiedForms | None = None, fitness_max: float = 1.0
    ) -> Repertoire:
        """Rebuild a repertoire written by :meth:`to_state` (every bin's items in their order); ``forms`` and
        ``fitness_max`` as the repertoire that wrote it had (the state records neither: the run's profile
        and objective do)."""
        repertoire = cls(tuple(state["shape"]), int(state["items_per_bin"]), forms, fitness_max)
        for record in state["bins"]:
            for item in record["items"]:
                entry = Entry(
                    str(item["tree"]),
                    float(item["fitness"]),
                    tuple(item["descriptors"]),
                    int(item["evaluation"]),
                )
                if tuple(repertoire.bin_of(entry.descriptors)) != tuple(record["bin"]):
                    raise ValueError(f"an item of bin {record['bin']} has descriptors of another bin")
                if repertoire.grid.add(entry) is None:
                    raise ValueError(f"bin {record['bin']} holds more than {repertoire.items_per_bin} items")
                repertoire._held.add(entry.tree)
        repertoire.offered = int(state["offered"])
        return repertoire

    @classmethod
    def from_items(cls, items: list[dict], items_per_bin: int = ITEMS_PER_BIN) -> Repertoire:
        """Rebuild a repertoire from the ``items`` of a repertoire file (bin by bin, in order of arrival)."""
        repertoire = cls(items_per_bin=items_per_bin)
        for item in items:
            descriptors = tuple(float(d) for d in item["descriptors"])
            entry = Entry(str(item["tree"]), float(item["fitness"]), descriptors, int(item["evaluation"]))
            if repertoire.grid.add(entry) is None:
                raise ValueError(f"bin {item['bin']} holds more than {repertoire.items_per_bin} items")
            repertoire._held.add(entry.tree)
        repertoire.offered = len(items)
        return repertoire
