"""Genetic-programming operators that draw every random number from an explicit ``random.Random``.

DEAP's operators (``genHalfAndHalf``, ``cxOnePoint``, ``mutInsert``, ``mutShrink``, ``mutNodeReplacement``,
``staticLimit``, ``selTournament``) call the module-level functions of :mod:`random`, one state shared by the
whole process. The functions here keep DEAP's trees (``PrimitiveTree``, ``searchSubtree``), its primitive set
and the same probabilities and behaviour, but take the generator as an argument, so that a run is a pure
function of its seed, can be checkpointed (``Random.getstate`` is a tuple of numbers) and resumed, and does
not change when another library draws from the global generator. Where DEAP chooses from a ``set`` (the
common types of ``cxOnePoint``) we choose from a sorted list, so results do not depend on
``PYTHONHASHSEED``.

Differences from DEAP, all deliberate: the tournament breaks exact ties in fitness by preferring the
shorter tree (lower height, then fewer nodes) when one of them is deeper than ``PARSIMONY_HEIGHT`` (paper,
section 3.3); and :func:`vary` applies each of the three mutations independently with its own probability
(paper, table 5) where DEAP's ``varAnd`` has one mutation.
"""

from __future__ import annotations

import random
from collections.abc import Sequence

from deap import gp

from .primitives import BehaviourTree

PARSIMONY_HEIGHT = 3
"""Exact ties in fitness prefer the shorter tree when either tree is deeper than this (paper, 3.3)."""


def generate(pset: gp.PrimitiveSet, rng: random.Random, min_height: int, max_height: int, grow: bool) -> list:
    """DEAP's ``generate`` for ``genGrow`` (``grow``) or ``genFull``: a list of nodes in pre-order."""
    height = rng.randint(min_height, max_height)
    nodes: list = []
    stack = [0]
    while stack:
        depth = stack.pop()
        leaf = depth == height or (grow and depth >= min_height and rng.random() < pset.terminalRatio)
        if leaf:
            nodes.append(rng.choice(pset.terminals[pset.ret]))
        else:
            primitive = rng.choice(pset.primitives[pset.ret])
            nodes.append(primitive)
            stack.extend([depth + 1] * primitive.arity)
    return nodes


def half_and_half(
    pset: gp.PrimitiveSet, rng: random.Random, min_height: int, max_height: int
) -> BehaviourTree:
    """DEAP's ``genHalfAndHalf``: a grown or a full tree, each with probability 1/2."""
    grow = rng.random() < 0.5
    return BehaviourTree(generate(pset, rng, min_height, max_height, grow))


def cx_one_point(first: BehaviourTree, second: BehaviourTree, rng: random.Random) -> None:
    """DEAP's ``cxOnePoint``, in place: swap two subtrees rooted below the roots (untyped trees)."""
    if len(first) < 2 or len(second) < 2:
        return
    index1 = rng.randrange(1, len(first))
    index2 = rng.randrange(1, len(second))
    slice1 = first.searchSubtree(index1)
    slice2 = second.searchSubtree(index2)
    first[slice1], second[slice2] = second[slice2], first[slice1]


def mut_insert(tree: BehaviourTree, pset: gp.PrimitiveSet, rng: random.Random) -> None:
    """DEAP's ``mutInsert``, in place: a new composite takes the subtree at a random node as one child;
    its other children are random terminals."""
    index = rng.randrange(len(tree))
    subtree_slice = tree.searchSubtree(index)
    composite = rng.choice(pset.primitives[pset.ret])
    position = rng.randrange(composite.arity)
    children: list = [
        rng.choice(pset.terminals[pset.ret]) if i != position else None for i in range(composite.arity)
    ]
    new_subtree = [composite]
    for i, child in enumerate(children):
        new_subtree.extend(tree[subtree_slice] if i == position else [child])
    tree[subtree_slice] = new_subtree


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


def size_key(tree: BehaviourTree) -> tuple[int, int]:
    """What "shorter" means in the parsimony tie-break: height first, then the number of nodes."""
    return tree.height, len(tree)


def preferred(challenger: BehaviourTree, holder: BehaviourTree, objective: int) -> bool:
    """Whether ``challenger`` beats ``holder`` on ``objective``: higher fitness, or an exact tie broken by
    the parsimony rule (shorter wins when either is deeper than ``PARSIMONY_HEIGHT``)."""
    a = challenger.fitness.values[objective]
    b = holder.fitness.values[objective]
    if a != b:
        return a > b
    if max(challenger.height, holder.height) > PARSIMONY_HEIGHT:
        return size_key(challenger) < size_key(holder)
    return False


def best_of(candidates: Sequence[BehaviourTree], objective: int) -> BehaviourTree:
    """The first candidate that no later candidate beats (see :func:`preferred`)."""
    winner = candidates[0]
    for candidate in candidates[1:]:
        if preferred(candidate, winner, objective):
            winner = candidate
    return winner


def tournament(
    population: Sequence[BehaviourTree],
    count: int,
    size: int,
    rng: random.Random,
    objectives: Sequence[int],
) -> list[BehaviourTree]:
    """DEAP's ``selTournament`` with the parsimony tie-break: ``count`` tournaments among ``size``
    individuals drawn with replacement. Each tournament compares on one of ``objectives`` drawn uniformly
    (with one objective, no draw is made: GP_o; with all three: GP_fnd)."""
    chosen = []
    for _ in range(count):
        objective = objectives[0] if len(objectives) == 1 else objectives[rng.randrange(len(objectives))]
        aspirants = [population[rng.randrange(len(population))] for _ in range(size)]
        chosen.append(best_of(aspirants, objective))
    return chosen
