"""The two roads agree bit for bit; a batch result depends only on its request."""

import numpy as np
import pytest

from bt_controller.language import parse, random_trees
from swarm_sim.core import world
from swarm_sim.evaluation import BatchEvaluator, EvaluationRequest, EvaluationResult, Evaluator
from swarm_sim.model import Config
from swarm_sim.roads import reference_road
from swarm_sim.tasks import FORAGING

# CI size; `ws/run swarm_sim bench --parity 300` runs the large comparison.
N_TREES = 16
TRIALS = 3


def _records_equal(a, b):
    return all(
        x.values == y.values and (x.start_poses == y.start_poses).all() and (x.end_poses == y.end_poses).all()
        for x, y in zip(a, b, strict=True)
    )


@pytest.mark.parametrize(
    "config",
    [
        Config(),
        Config(profile="clean"),
        # Short chains of 2 trials: 3 trials take a whole chain and the first trial of the next.
        Config(n_robots=5, ticks=12, chain_trials=2, delivery_probability=0.7),
        Config(profile="clean", n_robots=6, ticks=10, occlusion=False, friction=0.0),
    ],
    ids=["paper", "clean", "paper-small", "clean-small"],
)
def test_roads_agree_on_random_trees(config):
    texts = random_trees(99, N_TREES)
    requests = [EvaluationRequest(t, 1000 + k, TRIALS) for k, t in enumerate(texts)]
    batch = BatchEvaluator(config).evaluate_trials(requests)
    for request, (result, records) in zip(requests, batch, strict=True):
        values, ref_records = reference_road.evaluate(
            parse(request.tree), request.seed, request.trials, config
        )
        assert result.fitness + result.descriptors == values, request.tree
        assert _records_equal(records, ref_records), request.tree


def test_result_does_not_depend_on_batch_order_size_or_threads():
    texts = random_trees(5, 30)
    requests = [EvaluationRequest(t, 77 * k, 4) for k, t in enumerate(texts)]
    alone = [BatchEvaluator().evaluate([r])[0] for r in requests[:5]]
    whole = BatchEvaluator().evaluate(requests)
    order = np.random.default_rng(0).permutation(len(requests))
    shuffled = BatchEvaluator().evaluate([requests[k] for k in order])
    threaded = BatchEvaluator(threads=2).evaluate(requests)
    assert whole[:5] == alone
    assert [shuffled[list(order).index(k)] for k in range(len(requests))] == whole
    assert threaded == whole


def test_bad_requests_give_error_results_not_exceptions():
    good = EvaluationRequest("sel(seq(in_nest, stop), forward)", 3, 2)
    requests = [
        EvaluationRequest("sel(in_nest", 1),
        good,
        EvaluationRequest("forward", -1),
        EvaluationRequest("forward", 1, 0),
        EvaluationRequest("seq(" * 30 + "stop, stop" + ")" * 30, 1),
        EvaluationRequest("dance", 1),
    ]
    results = BatchEvaluator().evaluate(requests)
    assert len(results) == len(requests)
    assert results[1] == BatchEvaluator().evaluate([good])[0] and results[1].ok
    for k in (0, 2, 3, 4, 5):
        assert results[k].error and results[k].fitness is None and results[k].descriptors is None
    assert "seed" in results[2].error and "trials" in results[3].error and "dance" in results[5].error
    assert BatchEvaluator().evaluate([]) == []


def test_batch_evaluator_is_an_evaluator():
    assert isinstance(BatchEvaluator(), Evaluator)
    result = BatchEvaluator().evaluate([EvaluationRequest("forward", 0, 2)])[0]
    assert isinstance(result, EvaluationResult)
    assert all(0.0 <= v <= 1.0 for v in result.fitness + result.descriptors)


def test_seeds_and_trials_matter():
    evaluator = BatchEvaluator()
    tree = "sel(seq(nest_left, forward_left), seq(nest_right, forward_right), forward)"
    a, b, c = evaluator.evaluate(
        [EvaluationRequest(tree, 1, 4), EvaluationRequest(tree, 2, 4), EvaluationRequest(tree, 1, 6)]
    )
    assert a.fitness != b.fitness and a.fitness != c.fitness


def test_threads_are_validated():
    with pytest.raises(ValueError, match="threads"):
        BatchEvaluator(threads=0)


FORAGER = (
    "sel(seq(got_food, sel(seq(nest_left, forward_left), seq(nest_right, forward_right), forward)), "
    "sel(seq(food_left, forward_left), seq(food_right, forward_right), forward))"
)
PRIMITIVES = {
    "gotoNest": "sel(in_nest, seq(nest_left, forward_left), seq(nest_right, forward_right), "
    "prob(forward, reverse_left))",
    "gotoFood": "sel(on_food, seq(food_left, forward_left), seq(food_right, forward_right), "
    "prob(forward, forward_right))",
}


@pytest.mark.parametrize("profile", ["paper", "clean"])
def test_roads_agree_on_foraging_trees(profile):
    # 100 s trials: got_food, success and named primitives (each use its own success copy), random trees among
    # them; the forager delivers, so the carrying flag and the deliveries are exercised, not only zeros.
    from bt_controller.language import library_from_json

    library = library_from_json(
        {"format": 1, "primitives": [{"name": n, "tree": t} for n, t in PRIMITIVES.items()]}, "test"
    )
    config = FORAGING.config(profile)
    texts = [
        FORAGER,
        "sel(seq(got_food, gotoNest), prob(gotoFood, gotoNest))",
        *(f"sel(seq(got_food, gotoNest), {t})" for t in random_trees(5, 2, 3, 12, p_success=0.2)),
    ]
    requests = [EvaluationRequest(t, 300 + k, 2) for k, t in enumerate(texts)]
    batch = BatchEvaluator(config, library=library).evaluate_trials(requests)
    foraging = world.VALUE_NAMES.index("foraging")
    for request, (result, records) in zip(requests, batch, strict=True):
        assert result.error is None, result.error
        values, ref_records = reference_road.evaluate(
            library.parse(request.tree), request.seed, request.trials, config
        )
        assert result.fitness + result.descriptors == values, request.tree
        assert _records_equal(records, ref_records), request.tree
    assert sum(result.fitness[foraging] for result, _ in batch) > 0
