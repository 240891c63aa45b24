"""A tiny evaluator for the tests: a deterministic function of (tree text, seed), not a model of anything.

Fitness rewards some leaves per objective (every one of ``OBJECTIVES``), plus a little seed noise;
descriptors come from the mix of actions and conditions, so MAP-Elites has somewhere to spread.
It answers the evaluator contract.
"""

from __future__ import annotations

import hashlib
import re
from collections import Counter
from collections.abc import Sequence

from bt_controller.language import ACTIONS
from swarm_sim.evaluation import EvaluationRequest, EvaluationResult

_WORD = re.compile(r"[a-z_]+")


def _noise(tree: str, seed: int) -> float:
    digest = hashlib.blake2b(f"{tree}|{seed}".encode(), digest_size=8).digest()
    return int.from_bytes(digest, "little") / 2**64


class ToyEvaluator:
    """Deterministic, fast, and enough structure for selection to matter."""

    def __init__(self, noise: float = 0.05, fail_on: str | None = None) -> None:
        self.noise = noise
        self.fail_on = fail_on
        self.calls = 0

    def evaluate(self, requests: Sequence[EvaluationRequest]) -> list[EvaluationResult]:
        self.calls += 1
        return [self.one(r) for r in requests]

    def one(self, request: EvaluationRequest) -> EvaluationResult:
        if self.fail_on is not None and self.fail_on in request.tree:
            return EvaluationResult(None, None, f"refused: contains {self.fail_on}")
        words = Counter(w for w in _WORD.findall(request.tree) if w not in ("seq", "sel", "prob"))
        total = max(1, sum(words.values()))
        actions = sum(words[a] for a in ACTIONS)
        conditions = total - actions
        n = self.noise * _noise(request.tree, request.seed)
        density = (words["stop"] + words["robot_left"]) / total
        nest = (words["in_nest"] + words["nest_left"] + words["forward"]) / total
        food = (words["on_food"] + words["food_right"] + words["forward_left"]) / total
        # the inverse primitives reward the other leaves, foraging the carrying condition (every objective,
        # ``OBJECTIVES`` order)
        inverse = [
            (words["reverse"] + words["reverse_left"] + words[c]) / total
            for c in ("robot_right", "nest_right", "food_left")
        ]
        foraging = (words["got_food"] + words["forward_right"]) / total
        aggregation = (words["robot_left"] + words["robot_right"]) / total
        fitness = tuple(min(1.0, 0.5 * v + n) for v in (density, nest, food, *inverse, foraging, aggregation))
        # one kind of food: foraging1, foraging_biased and foraging_balanced are foraging, foraging2 and
        # foraging3 none
        fitness += (fitness[6], 0.0, 0.0, fitness[6], fitness[6])
        a = max(1, actions)
        movement = 0.5 + 0.5 * (words["forward"] - words["reverse"]) / a
        rotation = (
            0.5
            + 0.5
            * (
                words["forward_left"]
                + words["reverse_right"]
                - words["forward_right"]
                - words["reverse_left"]
            )
            / a
        )
        conditionality = conditions / total
        return EvaluationResult(fitness, (movement, rotation, conditionality), None)
