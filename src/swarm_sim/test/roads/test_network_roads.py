"""Networks (``bt_controller.interpreters.network``) on both roads, bit for bit: alone, in swarms mixed with
trees, and step by step in recordings."""

import numpy as np
import pytest

from bt_controller.interpreters import N_WEIGHTS, Network, parse_controller
from bt_controller.interpreters import network_text as to_text
from bt_controller.language import ACTIONS
from swarm_sim.evaluation import BatchEvaluator, EvaluationRequest, SwarmRequest
from swarm_sim.model import Config, of_trees
from swarm_sim.roads import record_trial, record_trial_reference, reference_road
from swarm_sim.tasks import FORAGING


def _steering() -> Network:
    """A network that reads its senses: hidden unit h turns on with input h (weights 8, bias -4), and the
    output weights spread the units over the action range."""
    weights = np.zeros(N_WEIGHTS)
    for h in range(5):
        weights[h * 9 + 2 * h] = 8.0  # in_nest, got_food, nest_right, food_right, robot_right
        weights[h * 9 + 2 * h - 1 if h else 8] = -8.0
        weights[45 + h] = -4.0
    weights[50:55] = (2.5, -3.0, 1.5, -1.0, 3.0)
    return Network(tuple(weights))


def _networks() -> list[Network]:
    rng = np.random.default_rng(37)
    return [
        Network((0.0,) * N_WEIGHTS),
        _steering(),
        *(Network(tuple(rng.uniform(-5, 5, N_WEIGHTS))) for _ in range(3)),
        Network(tuple(np.round(rng.normal(0, 1, N_WEIGHTS), 2))),
    ]


def _records_equal(a, b):
    return len(a) == len(b) and all(
        x.values == y.values and (x.start_poses == y.start_poses).all() and (x.end_poses == y.end_poses).all()
        for x, y in zip(a, b, strict=True)
    )


CONFIGS = pytest.mark.parametrize(
    "config",
    [Config(), Config(profile="clean"), FORAGING.config("paper")],
    ids=["paper", "clean", "foraging"],
)


@CONFIGS
def test_roads_agree_on_networks(config):
    trials = 6 if config.ticks < 100 else 2
    texts = [to_text(n) for n in _networks()]
    requests = [EvaluationRequest(t, 500 + k, trials) for k, t in enumerate(texts)]
    batch = BatchEvaluator(config).evaluate_trials(requests)
    actions_seen = set()
    for request, (result, records) in zip(requests, batch, strict=True):
        assert result.ok, result.error
        controller = parse_controller(request.tree)
        values, ref_records = reference_road.evaluate(controller, request.seed, trials, config)
        assert result.fitness + result.descriptors == values, request.tree
        assert _records_equal(records, ref_records), request.tree
        actions_seen.add(result.descriptors)
    assert len(actions_seen) == len(texts)  # the networks behave differently


def test_zero_network_turns_right_every_tick_and_ticks_no_condition():
    # all weights 0: output 3.5 -> forward_right at every tick (rotation -1, movement 0, conditionality 0)
    [result] = BatchEvaluator(Config()).evaluate([EvaluationRequest(to_text(_networks()[0]), 3, 2)])
    movement, rotation, conditionality = result.descriptors
    assert ACTIONS[3] == "forward_right" and rotation < 0.5 and conditionality == 0.0
    assert movement == 0.5  # movement and rotation are scaled to [0, 1] around 0.5


@CONFIGS
def test_roads_agree_on_a_swarm_mixing_trees_and_networks(config):
    trials = 6 if config.ticks < 100 else 2
    nets = [to_text(n) for n in _networks()[1:4]]
    tree = "sel(seq(on_food, stop), seq(food_left, forward_left), seq(food_right, forward_right), forward)"
    layout = of_trees((nets[0], tree, nets[1], nets[0], tree, nets[2], tree, nets[1], nets[0]), 9)
    [(result, records)] = BatchEvaluator(config).evaluate_trials([SwarmRequest(layout, 21, trials)])
    assert result.ok, result.error
    values, ref_records = reference_road.evaluate(layout.parsed(), 21, trials, config)
    assert result.fitness + result.descriptors == values
    assert _records_equal(records, ref_records)


@pytest.mark.parametrize("config", [Config(), FORAGING.config("paper")], ids=["paper", "foraging"])
def test_recordings_agree_step_by_step_on_a_network(config):
    text = to_text(_steering())
    fast = record_trial(text, 8, 1, config)
    slow = record_trial_reference(text, 8, 1, config)
    assert fast.tree == slow.tree == text
    for name in ("poses", "actions", "ticks", "smoothed", "ground", "fitness", "carrying", "deliveries"):
        np.testing.assert_array_equal(getattr(fast, name), getattr(slow, name), err_msg=name)
    assert fast.values == slow.values
    assert len(set(fast.actions[fast.ticks >= 0].ravel().tolist())) > 1  # it steers, not one action
