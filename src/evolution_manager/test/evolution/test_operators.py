"""The seeded GP operators: valid trees within limits, DEAP's distributions, the parsimony tie-break."""

from __future__ import annotations

import random
from collections import Counter
from functools import partial

import pytest
from deap import gp
from scipy.stats import chi2_contingency

from bt_controller.language import Composite, parse
from evolution_manager.evolution import operators
from evolution_manager.evolution.deap_trees import OBJECTIVES, BehaviourTree, tree_from_text, tree_to_text
from evolution_manager.evolution.operators import (
    best_of,
    cx_one_point,
    derating,
    full_tree,
    mut_insert,
    mut_node_replacement,
    mut_shrink,
    preferred,
    tournament,
    vary,
)
from evolution_manager.evolution.parameters import MAX_TREE_HEIGHT

PAD = (0.0,) * (len(OBJECTIVES) - 3)
"""The objectives after the paper's three (a fitness holds every objective)."""

MUTATIONS = (("insert", 0.05), ("shrink", 0.1), ("replace", 0.5))


def _valid(tree, max_height=MAX_TREE_HEIGHT, max_nodes=1000):
    parsed = parse(tree_to_text(tree))
    assert parsed.size == len(tree) <= max_nodes
    assert parsed.depth == tree.height <= max_height
    return parsed


def _leaf_depths(tree):
    depths, stack = [], [0]
    for node in tree:
        depth = stack.pop()
        if node.arity:
            stack.extend([depth + 1] * node.arity)
        else:
            depths.append(depth)
    return depths


def test_initial_trees_are_full_of_height_one_to_four(pset):
    rng = random.Random(1)
    heights = Counter()
    for _ in range(500):
        tree = full_tree(pset, rng, 1, 4)
        parsed = _valid(tree, max_height=4)
        assert isinstance(parsed, Composite)
        assert set(_leaf_depths(tree)) == {tree.height}  # full: every leaf at the same depth
        heights[tree.height] += 1
    assert set(heights) == {1, 2, 3, 4}


def test_operators_keep_trees_valid_and_within_limits(pset):
    rng = random.Random(2)
    population = [full_tree(pset, rng, 1, 2) for _ in range(30)]  # height 4 may exceed 120 nodes
    for tree in population:
        tree.fitness.values = (0.5, 0.5, 0.5, *PAD)
    for _ in range(60):  # generations of heavy variation push against the limits
        heavy = (("insert", 0.9), ("shrink", 0.2), ("replace", 0.9))
        population = vary(population, pset, rng, 1.0, heavy, 6, 120)
        for tree in population:
            _valid(tree, max_height=6, max_nodes=120)  # the insert may replace the root by a leaf
            tree.fitness.values = (0.5, 0.5, 0.5, *PAD)
    assert max(t.height for t in population) == 6  # the limit was reached, and held


def test_untouched_offspring_keep_fitness_and_touched_ones_lose_it(pset):
    rng = random.Random(3)
    parents = [full_tree(pset, rng, 2, 3) for _ in range(10)]
    for p in parents:
        p.fitness.values = (0.1, 0.2, 0.3, *PAD)
    same = vary(parents, pset, rng, 0.0, (("insert", 0.0), ("shrink", 0.0), ("replace", 0.0)), 8, 1000)
    for child, parent in zip(same, parents, strict=True):
        assert child.fitness.valid and list(child) == list(parent) and child is not parent
    changed = vary(parents, pset, rng, 1.0, (), 8, 1000)
    assert not any(c.fitness.valid for c in changed)
    assert all(p.fitness.valid for p in parents)  # parents are never modified


def test_operators_use_only_the_generator_they_are_given(pset):
    random.seed(123)
    state = random.getstate()
    rng = random.Random(4)
    trees = [full_tree(pset, rng, 1, 4) for _ in range(20)]
    for t in trees:
        t.fitness.values = (0.0, 0.0, 0.0, *PAD)
    vary(trees, pset, rng, 0.8, MUTATIONS, 8, 1000)
    tournament(trees, 10, 3, rng, (0, 1, 2))
    assert random.getstate() == state


def _distribution(make, apply, draws=4000):
    return Counter(apply(make()) for _ in range(draws))


def _summary(tree):
    """Insertion has thousands of outcomes: compare where it lands and what it adds instead."""
    added = tuple(sorted(n.name for n in tree if n.arity))
    return len(tree), tree.height, added


def _same_distribution(p, q):
    """Chi-square test of homogeneity of two samples of outcomes (rare outcomes pooled)."""
    keys = sorted(set(p) | set(q), key=str)
    common = [k for k in keys if p[k] + q[k] >= 20]
    table = [[p[k] for k in common], [q[k] for k in common]]
    rare = [sum(p[k] for k in keys if k not in common), sum(q[k] for k in keys if k not in common)]
    if sum(rare) >= 20:
        table[0].append(rare[0])
        table[1].append(rare[1])
    return chi2_contingency(table).pvalue


TREE_A = "sel(seq(in_nest, stop), prob(forward, reverse, robot_left), food_left)"
TREE_B = "seq(on_food, sel(forward_left, nest_right))"


@pytest.mark.parametrize("name", ["insert", "shrink", "replace", "crossover"])
def test_operators_draw_from_deaps_distribution(pset, name):
    """Each operator's outcome distribution equals DEAP's own operator's: a chi-square test of homogeneity
    of 4000 outcomes each does not reject at p = 0.001 (and, but for insertion's summarised outcomes, both
    produce the same set of outcomes)."""
    rng = random.Random(6)
    ours = {
        "insert": lambda t: mut_insert(t, pset, rng),
        "shrink": lambda t: mut_shrink(t, rng),
        "replace": lambda t: mut_node_replacement(t, pset, rng),
    }
    theirs = {
        "insert": lambda t: gp.mutUniform(t, expr=partial(gp.genFull, min_=0, max_=2), pset=pset),
        "shrink": lambda t: gp.mutShrink(t),
        "replace": lambda t: gp.mutNodeReplacement(t, pset),
    }
    saved = random.getstate()
    random.seed(7)
    try:
        if name == "crossover":

            def pair():
                return tree_from_text(TREE_A, pset), tree_from_text(TREE_B, pset)

            def mine(trees):
                cx_one_point(*trees, rng)
                return tuple(tree_to_text(t) for t in trees)

            def deaps(trees):
                gp.cxOnePoint(*trees)
                return tuple(tree_to_text(t) for t in trees)

            p, q = _distribution(pair, mine), _distribution(pair, deaps)
        else:

            def one():
                return tree_from_text(TREE_A, pset)

            def mine(tree):
                ours[name](tree)
                return _summary(tree) if name == "insert" else tree_to_text(tree)

            def deaps(tree):
                theirs[name](tree)
                return _summary(tree) if name == "insert" else tree_to_text(tree)

            p, q = _distribution(one, mine), _distribution(one, deaps)
    finally:
        random.setstate(saved)
    assert set(p) == set(q) or name == "insert"  # every outcome of ours is one of DEAP's, and vice versa
    assert _same_distribution(p, q) > 0.001


def _with_fitness(pset, text, value):
    tree = tree_from_text(text, pset)
    tree.fitness.values = (value,) * len(OBJECTIVES)
    return tree


DEEP = "sel(seq(sel(seq(in_nest, stop), forward), forward), forward)"  # height 4
SHALLOW = "sel(seq(in_nest, stop), forward)"  # height 2


def test_ties_prefer_the_shorter_tree_when_one_is_deeper_than_three(pset):
    deep, shallow = _with_fitness(pset, DEEP, 0.5), _with_fitness(pset, SHALLOW, 0.5)
    assert preferred(shallow, deep, 0) and not preferred(deep, shallow, 0)
    assert best_of([deep, shallow], 2) is shallow
    better_deep = _with_fitness(pset, DEEP, 0.6)
    assert best_of([shallow, better_deep], 0) is better_deep
    # Both at most 3 deep: no preference, the first stays.
    small = _with_fitness(pset, "seq(in_nest, stop)", 0.5)
    assert best_of([shallow, small], 0) is shallow and best_of([small, shallow], 0) is small


def test_selection_derates_long_trees_as_the_authors_code():
    assert derating(1) == derating(10) == 1.0
    assert derating(11) == pytest.approx(1 - 1 / 990)
    assert derating(505) == pytest.approx(0.5) and derating(1000) == 0.0 and derating(1001) == 0.0


def test_a_long_tree_loses_to_a_slightly_worse_short_one(pset):
    long_text = "seq(" + ", ".join(["sel(in_nest, stop)"] * 4) + ")"  # 13 nodes: derated by 3/990
    long, short = _with_fitness(pset, long_text, 0.5), _with_fitness(pset, SHALLOW, 0.4986)
    assert len(long) == 13 and 0.5 * derating(13) < 0.4986
    assert best_of([long, short], 0) is short
    assert best_of([long, _with_fitness(pset, SHALLOW, 0.498)], 0) is long


def test_tournaments_with_equal_fitness_choose_the_shorter_tree(pset):
    rng = random.Random(8)
    deep, shallow = _with_fitness(pset, DEEP, 0.5), _with_fitness(pset, SHALLOW, 0.5)
    winners = tournament([deep, shallow], 400, 3, rng, (0,))
    # Only a tournament of three copies of the deep tree picks it: probability 1/8.
    assert 0.08 < sum(w is deep for w in winners) / 400 < 0.18


def test_tournament_draws_the_objective_uniformly(pset, monkeypatch):
    rng = random.Random(9)
    seen = Counter()
    real = operators.best_of

    def spy(candidates, objective, rule):
        seen[objective] += 1
        return real(candidates, objective, rule)

    monkeypatch.setattr(operators, "best_of", spy)
    trees = [_with_fitness(pset, SHALLOW, 0.5) for _ in range(5)]
    tournament(trees, 3000, 5, rng, (0, 1, 2))
    assert set(seen) == {0, 1, 2} and all(900 < seen[k] < 1100 for k in seen)
    seen.clear()
    tournament(trees, 100, 3, rng, (2,))
    assert dict(seen) == {2: 100}


def test_each_tournament_compares_on_its_own_objective(pset):
    rng = random.Random(10)
    a, b, c = (BehaviourTree(tree_from_text(SHALLOW, pset)) for _ in range(3))
    a.fitness.values, b.fitness.values, c.fitness.values = (
        (0.9, 0.1, 0.1, *PAD),
        (0.1, 0.9, 0.1, *PAD),
        (0.1, 0.1, 0.9, *PAD),
    )
    winners = Counter(id(w) for w in tournament([a, b, c], 600, 30, rng, (0, 1, 2)))
    assert all(150 < winners[id(t)] < 250 for t in (a, b, c))
