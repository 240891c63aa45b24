"""A simplified tree evaluates exactly as its original in the batch evaluator: same fitness, movement and
rotation (only conditionality, the share of condition ticks, may change), on random trees with probabilistic
nodes, for several seeds, under both profiles; many of the simplified trees move a probabilistic node and keep
its draws with a key (``prob@K``), and the same holds for the simplifier that keeps positions."""

from __future__ import annotations

import numpy as np
import pytest

from bt_controller.language import Composite, Node, random_tree_grow, simplify, to_text
from bt_controller.model_settings import PROFILES
from swarm_sim.evaluation import BatchEvaluator, EvaluationRequest
from swarm_sim.model import default_config


def shrinking_pairs(seed: int, n: int, keep_positions: bool) -> list[tuple[Node, Node]]:
    """``n`` random trees (from ``seed``) that the simplifier makes smaller, with their simplified trees."""
    rng = np.random.default_rng(seed)
    pairs = []
    while len(pairs) < n:
        tree = random_tree_grow(rng, int(rng.integers(2, 6)), float(rng.uniform(0.2, 0.5)))
        simple = simplify(tree, keep_positions=keep_positions)
        if simple.size < tree.size:
            pairs.append((tree, simple))
    return pairs


@pytest.mark.parametrize("profile", PROFILES)
@pytest.mark.parametrize("seed", [3, 4])
def test_simplified_trees_score_identically(profile: str, seed: int) -> None:
    pairs = shrinking_pairs(seed, 120, keep_positions=False) + shrinking_pairs(seed, 30, keep_positions=True)
    with_prob = [any(isinstance(n, Composite) and n.kind == "prob" for n in t.preorder()) for t, _ in pairs]
    assert sum(with_prob) > 50
    assert sum("@" in to_text(simple) for _, simple in pairs) > 20  # probabilistic nodes moved, with keys
    requests = [
        EvaluationRequest(to_text(t), 1000 * seed + i, trials=4) for i, pair in enumerate(pairs) for t in pair
    ]
    results = BatchEvaluator(default_config(profile)).evaluate(requests)
    for i, (tree, simple) in enumerate(pairs):
        original, simplified = results[2 * i], results[2 * i + 1]
        assert original.ok and simplified.ok
        assert original.descriptors is not None and simplified.descriptors is not None
        assert simplified.fitness == original.fitness, (to_text(tree), to_text(simple))
        assert simplified.descriptors[:2] == original.descriptors[:2], (to_text(tree), to_text(simple))
