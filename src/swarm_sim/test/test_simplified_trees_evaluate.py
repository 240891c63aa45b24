"""A simplified tree evaluates exactly as its original: same fitness, movement and rotation for one seed (only
conditionality, the share of condition ticks, may change), on random trees with probabilistic nodes."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from bt_controller.random_trees import random_tree_grow
from bt_controller.simplify import simplify
from bt_controller.tree import Composite, to_text
from swarm_sim.config import DEFAULT, Config
from swarm_sim.evaluation import BatchEvaluator, EvaluationRequest


def profiles() -> list[Config]:
    """Every model profile the configuration knows (one until profiles exist)."""
    names = getattr(DEFAULT, "PROFILES", None) or getattr(Config, "PROFILES", None)
    if names and any(f.name == "profile" for f in dataclasses.fields(Config)):
        return [dataclasses.replace(DEFAULT, profile=name) for name in names]
    return [DEFAULT]


@pytest.mark.parametrize("config", profiles(), ids=lambda c: getattr(c, "profile", "current"))
def test_simplified_trees_score_identically(config: Config) -> None:
    rng = np.random.default_rng(3)
    pairs = []
    while len(pairs) < 150:
        tree = random_tree_grow(rng, int(rng.integers(2, 6)), float(rng.uniform(0.2, 0.5)))
        simple = simplify(tree)
        if simple.size < tree.size:
            pairs.append((tree, simple))
    with_prob = [any(isinstance(n, Composite) and n.kind == "prob" for n in t.preorder()) for t, _ in pairs]
    assert sum(with_prob) > 50
    requests = [EvaluationRequest(to_text(t), 1000 + i, trials=4) for i, p in enumerate(pairs) for t in p]
    results = BatchEvaluator(config).evaluate(requests)
    for i, (tree, simple) in enumerate(pairs):
        original, simplified = results[2 * i], results[2 * i + 1]
        assert original.ok and simplified.ok
        assert simplified.fitness == original.fitness, (to_text(tree), to_text(simple))
        assert simplified.descriptors[:2] == original.descriptors[:2], (to_text(tree), to_text(simple))
