"""Repertoires on qdpy grids: the replacement rule, bins, metrics, and state round trips."""

from __future__ import annotations

import math
import random

import pytest

from evolution_manager.evolution.archive import Repertoire
from swarm_sim.model import fitness_ceiling


def test_a_full_bin_replaces_its_worst_only_with_a_strictly_better_tree():
    grid = Repertoire()
    d = (0.5, 0.5, 0.5)
    for i, f in enumerate((0.3, 0.1, 0.2)):
        assert grid.offer(f"t{i}", f, d, i)
    assert not grid.offer("tie", 0.1, d, 3)  # equal to the worst: rejected
    assert not grid.offer("worse", 0.05, d, 4)
    assert grid.offer("better", 0.25, d, 5)
    assert [e.tree for e in grid.entries()] == ["t0", "t2", "better"]
    assert len(grid) == 3 and grid.filled_bins == 1 and grid.qd_score == 0.3 / 512


def test_a_tree_is_stored_once_per_grid_and_may_return_once_evicted():
    grid = Repertoire()
    d = (0.1, 0.1, 0.1)
    assert grid.offer("a", 0.2, d, 0)
    assert not grid.offer("a", 0.9, d, 1)  # held already: refused whatever its fitness
    assert not grid.offer("a", 0.2, (0.9, 0.9, 0.9), 2)  # nor in another bin
    assert grid.offer("b", 0.3, d, 3) and grid.offer("c", 0.4, d, 4) and grid.offer("d", 0.5, d, 5)
    assert [e.tree for e in grid.entries()] == ["b", "c", "d"]  # "a" was the worst: evicted
    assert grid.offer("a", 0.6, d, 6)  # no longer held
    one = Repertoire(items_per_bin=1)
    assert one.offer("x", 0.5, d, 0) and not one.offer("x", 0.7, d, 1)
    assert one.qd_score == 0.5 / 512 and one.filled_bins == 1
    copy = Repertoire.from_state(grid.to_state())
    assert not copy.offer("a", 0.99, d, 7)  # the held set survives a round trip
    assert grid.best_entries()[0][1].tree == "a"


def test_bins_coverage_and_qd_score_agree_with_qdpy():
    rng = random.Random(1)
    grid = Repertoire()
    for i in range(3000):
        descriptors = (rng.random(), rng.random() ** 3, 1.0 if i % 7 == 0 else rng.random())
        grid.offer(f"t{i}", rng.random(), descriptors, i)
    assert grid.bin_of((1.0, 0.0, 0.999)) == (7, 0, 7)
    assert grid.coverage == grid.filled_bins / 512 == grid.grid.filled_bins / 512
    # qdpy's normalised QD score is the sum of each bin's best on the fitness domain [0, 1]; ours / 512
    assert grid.qd_score == pytest.approx(grid.grid.qd_score(normalized=True) / 512, abs=1e-12)
    assert grid.best_value == max(e.value for e in grid.entries()) == grid.best().value
    assert all(len(entries) <= 3 for _, entries in grid.bins())


def test_values_out_of_range_are_refused():
    grid = Repertoire()
    with pytest.raises(ValueError, match="fitness"):
        grid.offer("t", 1.5, (0.5, 0.5, 0.5), 0)
    with pytest.raises(ValueError, match="descriptor"):
        grid.offer("t", 0.5, (0.5, -0.2, 0.5), 0)
    with pytest.raises(ValueError, match="descriptor"):
        grid.offer("t", 0.5, (0.5, float("nan"), 0.5), 0)
    assert len(grid) == 0 and grid.offered == 0


def test_state_round_trip_rebuilds_the_same_grid_that_then_evolves_the_same():
    rng = random.Random(2)
    offers = [
        (f"t{i}", rng.random(), (rng.random(), rng.random(), rng.random() ** 4), i) for i in range(2000)
    ]
    grid = Repertoire()
    for offer in offers[:1000]:
        grid.offer(*offer)
    copy = Repertoire.from_state(grid.to_state())
    assert copy.to_state() == grid.to_state()
    for offer in offers[1000:]:
        assert grid.offer(*offer) == copy.offer(*offer)
    assert copy.to_state() == grid.to_state()


def test_the_repertoire_keeps_exactly_what_a_plain_qdpy_grid_keeps():
    """Our shortcuts (bin from descriptors, no item search, early refusal) do not change qdpy's choices."""
    from qdpy.containers import Grid
    from qdpy.phenotype import Features, Fitness, Individual

    plain = Grid(
        shape=(8, 8, 8),
        max_items_per_bin=3,
        fitness_domain=((0.0, 1.0),),
        features_domain=((0.0, 1.0),) * 3,
        fitness_weights=(1.0,),
    )
    ours = Repertoire()
    rng = random.Random(3)
    for i in range(4000):
        fitness = round(rng.random(), 2)  # many exact ties
        descriptors = (rng.random() ** 2, rng.choice([0.0, 0.5, 1.0]), rng.random())
        individual = Individual([i], name=str(i))
        individual.fitness = Fitness((fitness,), weights=(1.0,))
        individual.features = Features(descriptors)
        plain.add(individual)
        ours.offer(f"t{i}", fitness, descriptors, i)
    expected = {k: [int(ind.name) for ind in v] for k, v in plain.solutions.items() if v}
    assert {k: [e.evaluation for e in v] for k, v in ours.bins()} == expected


def test_a_clean_grid_refuses_a_tree_whose_simplified_form_its_bin_holds():
    """``sel(forward, stop)`` and ``seq(forward, in_nest)`` drive the wheels exactly as ``forward`` (the
    selector never gets past forward, the condition after it only decides the root's status): one
    behaviour."""
    from evolution_manager.evolution.archive import SimplifiedForms

    forms = SimplifiedForms()
    assert forms("sel(forward, stop)") == forms("seq(forward, in_nest)") == "forward"
    d, elsewhere = (0.5, 0.5, 0.5), (0.5, 0.5, 0.9)
    clean = Repertoire(forms=forms)
    assert clean.offer("sel(forward, stop)", 0.4, d, 0)
    assert not clean.offer("seq(forward, in_nest)", 0.9, d, 1)  # its form is in the bin: refused
    assert not clean.offer("forward", 0.4, d, 2)
    assert clean.offer("forward", 0.4, elsewhere, 3)  # another bin: another behaviour
    assert clean.offer("reverse", 0.3, d, 4) and clean.offer("stop", 0.5, d, 5)
    copy = Repertoire.from_state(clean.to_state(), forms)
    assert not copy.offer("seq(forward, in_nest)", 0.45, d, 6)  # the rule survives a round trip
    assert not clean.offer("sel(stop, reverse)", 0.6, d, 7)  # simplifies to stop, which the bin holds
    assert clean.offer("forward_left", 0.45, d, 8)  # the bin was full: evicts its worst, reverse
    assert clean.offer("seq(reverse, on_food)", 0.7, d, 9)  # reverse's form is free again; evicts 0.4
    assert not clean.offer("sel(reverse, stop)", 0.9, d, 10)  # reverse, held as seq(reverse, on_food)
    assert not clean.offer("forward", 0.8, d, 11)  # its text is held, in the other bin
    assert clean.offer("sel(forward, reverse)", 0.8, d, 12)  # sel(forward, stop) was evicted: form free
    held = [e.tree for e in clean.grid.solutions[clean.bin_of(d)]]
    assert held == ["stop", "seq(reverse, on_food)", "sel(forward, reverse)"]
    paper = Repertoire()
    assert paper.offer("sel(forward, stop)", 0.4, d, 0) and paper.offer("seq(forward, in_nest)", 0.4, d, 1)
    assert [e.tree for e in paper.entries()] == ["sel(forward, stop)", "seq(forward, in_nest)"]


def test_a_count_objective_keeps_fitness_above_one_and_a_fraction_refuses_it():
    # foraging counts deliveries per robot per trial (an ideal robot about 2.6); the pilot study's first
    # hierarchical forager above 1.0 stopped its run when every grid took fitness to lie in [0, 1]
    assert fitness_ceiling("foraging") == math.inf and fitness_ceiling("food") == 1.0
    foraging = Repertoire(fitness_max=fitness_ceiling("foraging"))
    d = (0.5, 0.5, 0.5)
    assert foraging.offer("a", 1.0222222222222221, d, 0) and foraging.offer("b", 2.5, d, 1)
    copy = Repertoire.from_state(foraging.to_state(), None, foraging.fitness_max)
    assert copy.offer("c", 1.7, d, 2) and [e.value for e in copy.entries()] == [1.0222222222222221, 2.5, 1.7]
    with pytest.raises(ValueError, match=r"fitness must be a number in \[0, 1\], got 1.5"):
        Repertoire().offer("a", 1.5, d, 0)
    with pytest.raises(ValueError, match=r"in \[0, inf\], got -0.5"):
        foraging.offer("d", -0.5, d, 3)
