"""Genetic-programming operators that draw every random number from an explicit ``random.Random``.

DEAP's operators (``genHalfAndHalf``, ``cxOnePoint``, ``mutInsert``, ``mutShrink``, ``mutNodeReplacement``,
``staticLimit``, ``selTournament``) call the module-level functions of :mod:`random`, one state shared by the
whole process. The functions here keep DEAP's trees (``PrimitiveTree``, ``searchSubtree``), its primitive set
and the same probabilities and behaviour, but take the generator as an argument, so that a run is a pure
function of its seed, can be checkpointed (``Random.getstate`` is a tuple of numbers) and resumed, and does
not change when another library draws from the global generator. Where DEAP chooses from a ``set`` (the
common types of ``cxOnePoint``) we choose from a sorted list, so results do not depend on
``PYTHONHASHSEED``.

Choices taken from the authors' code (KirstyMontague/big-mad-robot-repo at 6c65001), cited by file:line:

- initial trees are DEAP ``genFull`` trees of height 1-4 (gp/ea.py:61, qdpy/main.py:150);
- the insert mutation is DEAP's ``mutUniform`` with a full subtree of height 0-2 (gp/ea.py:74-75,
  qdpy/main.py:163-164): a random node's subtree is replaced by a new full tree;
- :func:`vary` applies each of the three mutations independently with its own probability, in the order
  insert, shrink, replace (gp/ea.py:104-120; paper, table 5), where DEAP's ``varAnd`` has one mutation;
- **bloat control**: every selection (tournaments, elites, MAP-Elites parents) compares the fitness
  multiplied by a length derating, 1 - (nodes - 10) / 990 above 10 nodes (gp/ea.py:762-770, used at
  gp/ea.py:784 and 815, qdpy/ea.py:599); stored fitness is never derated. Exact ties in derated fitness
  go to the challenger when the holder is taller than ``PARSIMONY_HEIGHT`` and the challenger is shorter
  (gp/ea.py:794; the paper's section 3.3 states only this tie-break). The paper's rule alone hardly acts
  (exact ties are rare on continuous fitness), the derating acts on every comparison: we follow the code,
  which produced the paper's numbers. The 2024 flat foraging baseline derates by 1 - (nodes - 64) / 6930
  instead (``parameters.DERATINGS``; GP runs name theirs in ``GPParameters.derating``);
- a new tree's leaves are drawn uniformly over the terminals (DEAP), except in the hierarchical node set,
  where a leaf is a condition or a primitive with probability 1/2 each, then uniform within its class
  (:func:`choose_leaf`; the authors' 2024 code, local.py:132,177 at a73e4af). Node replacement keeps DEAP's
  uniform choice over the terminals in both sets (the addendum cites the classed draw for generation only).
"""

from __future__ import annotations

import random
from collections.abc import Sequence

from deap import gp

from evolution_manager.evolution.deap_trees import BehaviourTree
from evolution_manager.evolution.parameters import DERATINGS, Derating

PARSIMONY_HEIGHT = 3
"""Exact ties in derated fitness prefer a shorter challenger when the holder is taller than this."""

STANDARD = DERATINGS["standard"]
"""The 2023 derating, 1 - max(0, nodes - 10) / 990 (``parameters.DERATINGS``)."""


def generate(pset: gp.PrimitiveSet, rng: random.Random, min_height: int, max_height: int, grow: bool) -> list:
    """DEAP's ``generate`` for ``genGrow`` (``grow``) or ``genFull``: a list of nodes in pre-order."""
    height = rng.randint(min_height, max_height)
    nodes: list = []
    stack = [0]
    while stack:
        depth = stack.pop()
        leaf = depth == height or (grow and depth >= min_height and rng.random() < pset.terminalRatio)
        if leaf:
            nodes.append(choose_leaf(pset, rng))
        else:
            primitive = rng.choice(pset.primitives[pset.ret])
            nodes.append(primitive)
            stack.extend([depth + 1] * primitive.arity)
    return nodes


def choose_leaf(pset: gp.PrimitiveSet, rng: random.Random) -> gp.Terminal:
    """A leaf for a new tree: uniform over the set's terminals (DEAP), or, for a set with ``leaf_classes``
    (``deap_trees.make_primitive_set``, the hierarchical node set), a class drawn uniformly and then a leaf
    uniformly within it (the authors' 2024 generation, local.py:132,177 at a73e4af)."""
    classes = getattr(pset, "leaf_classes", None)
    if classes is None:
        return rng.choice(pset.terminals[pset.ret])
    return rng.choice(classes[rng.randrange(len(classes))])


def full_tree(pset: gp.PrimitiveSet, rng: random.Random, min_height: int, max_height: int) -> BehaviourTree:
    """DEAP's ``genFull``: every leaf at the same depth, drawn in [min_height, max_height]."""
    return BehaviourTree(generate(pset, rng, min_height, max_height, grow=False))


def cx_one_point(first: BehaviourTree, second: BehaviourTree, rng: random.Random) -> None:
    """DEAP's ``cxOnePoint``, in place: swap two subtrees rooted below the roots (untyped trees)."""
    if len(first) < 2 or len(second) < 2:
        return
    index1 = rng.randrange(1, len(first))
    index2 = rng.randrange(1, len(second))
    slice1 = first.searchSubtree(index1)
    slice2 = second.searchSubtree(index2)
    first[slice1], second[slice2] = second[slice2], first[slice1]


INSERT_MIN_HEIGHT = 0
INSERT_MAX_HEIGHT = 2


def mut_insert(tree: BehaviourTree, pset: gp.PrimitiveSet, rng: random.Random) -> None:
    """The insert mutation as the authors' ``mutUniform``, in place: the subtree at a random node (the root
    included) is replaced by a new full tree of height 0-2."""
    index = rng.randrange(len(tree))
    subtree_slice = tree.searchSubtree(index)
    tree[subtree_slice] = generate(pset, rng, INSERT_MIN_HEIGHT, INSERT_MAX_HEIGHT, grow=False)


def mut_shrink(tree: BehaviourTree, rng: random.Random) -> None:
    """DEAP's ``mutShrink``, in place: a composite below the root is replaced by one of its children."""
    if len(tree) < 3 or tree.height <= 1:
        return
    composites = [i for i in range(1, len(tree)) if tree[i].arity]
    if not composites:
        return
    index = rng.choice(composites)
    child = rng.randrange(tree[index].arity)
    start = index + 1
    for _ in range(child):
        start = tree.searchSubtree(start).stop
    kept = tree[tree.searchSubtree(start)]
    tree[tree.searchSubtree(index)] = kept


def mut_node_replacement(tree: BehaviourTree, pset: gp.PrimitiveSet, rng: random.Random) -> None:
    """DEAP's ``mutNodeReplacement``, in place: a node below the root becomes another node of its kind (a
    terminal for a terminal, a composite with as many children for a composite)."""
    if len(tree) < 2:
        return
    index = rng.randrange(1, len(tree))
    node = tree[index]
    if node.arity == 0:
        tree[index] = rng.choice(pset.terminals[node.ret])
    else:
        tree[index] = rng.choice([p for p in pset.primitives[node.ret] if p.args == node.args])


def _too_big(tree: BehaviourTree, max_height: int, max_nodes: int) -> bool:
    return len(tree) > max_nodes or tree.height > max_height


def vary(
    parents: Sequence[BehaviourTree],
    pset: gp.PrimitiveSet,
    rng: random.Random,
    crossover: float,
    mutations: Sequence[tuple[str, float]],
    max_height: int,
    max_nodes: int,
) -> list[BehaviourTree]:
    """Offspring of ``parents`` as DEAP's ``varAnd`` makes them, with a static height limit.

    Consecutive pairs cross with probability ``crossover``; then each child undergoes each mutation of
    ``mutations`` (``"insert"``, ``"shrink"``, ``"replace"`` with its probability) in turn. A child that
    grew over ``max_height`` or ``max_nodes`` is replaced by a copy of one of the operator's inputs chosen at
    random (DEAP's ``staticLimit``, on height and size). A child touched by any operator has an invalid
    fitness; an untouched one keeps its parent's.
    """
    offspring = [parent.clone() for parent in parents]
    for i in range(1, len(offspring), 2):
        if rng.random() < crossover:
            inputs = (offspring[i - 1].clone(), offspring[i].clone())
            cx_one_point(offspring[i - 1], offspring[i], rng)
            for j in (i - 1, i):
                if _too_big(offspring[j], max_height, max_nodes):
                    offspring[j] = rng.choice(inputs).clone()
                del offspring[j].fitness.values
    for i in range(len(offspring)):
        for name, probability in mutations:
            if rng.random() < probability:
                child = offspring[i]
                if name == "insert":  # the only mutation that can grow a tree
                    before = child.clone()
                    mut_insert(child, pset, rng)
                    if _too_big(child, max_height, max_nodes):
                        child = offspring[i] = before
                elif name == "shrink":
                    mut_shrink(child, rng)
                elif name == "replace":
                    mut_node_replacement(child, pset, rng)
                else:
                    raise ValueError(f"unknown mutation {name!r}: expected insert, shrink or replace")
                del child.fitness.values
    return offspring


def derating(nodes: int, rule: Derating = STANDARD) -> float:
    """The selection weight of a tree of ``nodes`` nodes under ``rule`` (by default 1 up to 10 nodes, falling
    linearly to 0 at 1000)."""
    return rule(nodes)


def selection_fitness(fitness: float, nodes: int, rule: Derating = STANDARD) -> float:
    """The fitness that selection compares: the stored fitness times :func:`derating`."""
    return fitness * rule(nodes)


def preferred(
    challenger: BehaviourTree, holder: BehaviourTree, objective: int, rule: Derating = STANDARD
) -> bool:
    """Whether ``challenger`` beats ``holder`` on ``objective``: higher derated fitness, or an exact tie
    that the parsimony rule gives to a shorter challenger when the holder is taller than
    ``PARSIMONY_HEIGHT``."""
    a = selection_fitness(challenger.fitness.values[objective], len(challenger), rule)
    b = selection_fitness(holder.fitness.values[objective], len(holder), rule)
    if a != b:
        return a > b
    return holder.height > PARSIMONY_HEIGHT and challenger.height < holder.height


def best_of(candidates: Sequence[BehaviourTree], objective: int, rule: Derating = STANDARD) -> BehaviourTree:
    """The first candidate that no later candidate beats (see :func:`preferred`)."""
    winner = candidates[0]
    for candidate in candidates[1:]:
        if preferred(candidate, winner, objective, rule):
            winner = candidate
    return winner


def tournament(
    population: Sequence[BehaviourTree],
    count: int,
    size: int,
    rng: random.Random,
    objectives: Sequence[int],
    rule: Derating = STANDARD,
) -> list[BehaviourTree]:
    """DEAP's ``selTournament`` with the parsimony tie-break: ``count`` tournaments among ``size``
    individuals drawn with replacement. Each tournament compares on one of ``objectives`` drawn uniformly
    (with one objective, no draw is made: GP_o; with all three: GP_fnd), under the derating ``rule``."""
    chosen = []
    for _ in range(count):
        objective = objectives[0] if len(objectives) == 1 else objectives[rng.randrange(len(objectives))]
        aspirants = [population[rng.randrange(len(population))] for _ in range(size)]
        chosen.append(best_of(aspirants, objective, rule))
    return chosen
