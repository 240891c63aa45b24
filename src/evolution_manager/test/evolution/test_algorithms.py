"""GP_o, GP_fnd and MAP-Elites as ask/tell objects (with the toy evaluator of ``toy.py``)."""

from __future__ import annotations

import json
from collections import Counter

import pytest
from toy import ToyEvaluator

from evolution_manager.errors import AskTellError, ConfigError
from evolution_manager.evolution import operators
from evolution_manager.evolution.algorithms import GeneticProgramming, GPParameters, MapElites, QDParameters
from evolution_manager.evolution.deap_trees import OBJECTIVES
from evolution_manager.evolution.run_config import RunConfig, evaluation_seed
from swarm_sim.evaluation import EvaluationRequest


def drive(algorithm, evaluator, seed=1, after_tell=None):
    while not algorithm.done:
        first = algorithm.evaluations
        trees = algorithm.ask()
        requests = [EvaluationRequest(t, evaluation_seed(seed, first + i)) for i, t in enumerate(trees)]
        algorithm.tell(evaluator.evaluate(requests))
        if after_tell:
            after_tell(algorithm)
    return algorithm


@pytest.mark.parametrize("algorithm,objective", [("gp", "food"), ("gp-fnd", None), ("qd", "nest")])
def test_ask_and_tell_out_of_order_raise(algorithm, objective):
    algo = RunConfig.make(algorithm, objective, 120, 3).make_algorithm()
    with pytest.raises(AskTellError, match="call ask"):
        algo.tell([])
    trees = algo.ask()
    with pytest.raises(AskTellError, match="twice"):
        algo.ask()
    with pytest.raises(AskTellError, match="between ask"):
        algo.to_state()
    with pytest.raises(AskTellError, match="one per asked tree"):
        algo.tell(ToyEvaluator().evaluate([EvaluationRequest(trees[0], 1)]))
    algo.tell(ToyEvaluator().evaluate([EvaluationRequest(t, 1) for t in trees]))
    drive(algo, ToyEvaluator())
    with pytest.raises(AskTellError, match="budget"):
        algo.ask()


@pytest.mark.parametrize("algorithm,objective", [("gp", "density"), ("gp-fnd", None), ("qd", "food")])
def test_the_budget_counts_individuals_produced_in_whole_generations(algorithm, objective):
    # generations of 25 (GP_o), 75 (GP_fnd) and batches of 50 (QD) after the initial population: 150
    algo = drive(RunConfig.make(algorithm, objective, 137, 4).make_algorithm(), ToyEvaluator())
    assert algo.produced == 150 and algo.done
    initial = {"gp": 25, "gp-fnd": 75, "qd": 100}[algorithm]
    assert initial <= algo.evaluations <= initial + 150  # untouched offspring are not asked for
    exact = drive(RunConfig.make(algorithm, objective, 150, 4).make_algorithm(), ToyEvaluator())
    assert exact.produced == 150 and exact.evaluations == algo.evaluations


def test_gp_fnd_tournaments_use_all_three_objectives_and_gp_o_only_its_own(monkeypatch):
    seen = Counter()
    real = operators.best_of

    def spy(candidates, objective, rule):
        seen[objective] += 1
        return real(candidates, objective, rule)

    monkeypatch.setattr(operators, "best_of", spy)
    drive(RunConfig.make("gp-fnd", None, 75 * 4, 5).make_algorithm(), ToyEvaluator())
    assert set(seen) == {0, 1, 2} and min(seen.values()) > 0.25 * sum(seen.values())
    seen.clear()
    drive(RunConfig.make("gp", "nest", 100, 5).make_algorithm(), ToyEvaluator())
    assert set(seen) == {OBJECTIVES.index("nest")}


def test_gp_fnd_keeps_an_elite_per_objective():
    algo = RunConfig.make("gp-fnd", None, 75 * 6, 6).make_algorithm()
    best_so_far = [0.0, 0.0, 0.0]

    def check(a):
        for k in range(3):
            best_so_far[k] = max(best_so_far[k], max(t.fitness.values[k] for t in a.population))
            assert a.best(k).fitness.values[k] == best_so_far[k]
            # the elite is in the population it breeds from
            assert any(t.fitness.values[k] == best_so_far[k] for t in a.population)
        assert len(a.population) == 75  # whole generations, the last one too

    drive(algo, ToyEvaluator(), after_tell=check)


def test_gp_population_size_and_elitism():
    algo = RunConfig.make("gp", "food", 25 * 8, 7).make_algorithm()
    bests = []
    drive(algo, ToyEvaluator(), after_tell=lambda a: bests.append(a.best(2).fitness.values[2]))
    assert len(algo.population) <= 25
    assert bests == sorted(bests)  # the best never gets lost


def test_map_elites_archive_holds_at_most_three_per_bin_and_qd_score_never_decreases():
    algo = MapElites(1, 1500, 8, QDParameters())
    scores = []

    def check(a):
        assert all(len(entries) <= 3 for _, entries in a.archive.bins())
        scores.append(a.archive.qd_score)

    drive(algo, ToyEvaluator(), after_tell=check)
    assert scores == sorted(scores) and scores[-1] > scores[0]
    assert algo.batches == 1 + (len(scores) - 1) and len(algo.archive) > 3 * 20


def test_failed_evaluations_count_but_never_enter_the_archive():
    algo = MapElites(0, 600, 9, QDParameters())
    drive(algo, ToyEvaluator(fail_on="reverse_left"))
    assert algo.produced == 600
    assert all("reverse_left" not in e.tree for e in algo.archive.entries())
    gp = drive(GeneticProgramming([0], 200, 9, GPParameters()), ToyEvaluator(fail_on="reverse_left"))
    evaluated = [t for t in gp.population if t.fitness.values[0] >= 0]
    assert all("reverse_left" not in t for t, *_ in map(gp._record, evaluated))


@pytest.mark.parametrize("algorithm,objective", [("gp", "nest"), ("gp-fnd", None), ("qd", "density")])
def test_state_round_trip_continues_identically(algorithm, objective):
    config = RunConfig.make(algorithm, objective, 400, 10)
    straight = config.make_algorithm()
    asked_straight = []
    drive(straight, ToyEvaluator(), after_tell=lambda a: asked_straight.append(a.evaluations))
    first = config.make_algorithm()
    evaluator = ToyEvaluator()
    while first.evaluations < 160:
        n = first.evaluations
        trees = first.ask()
        requests = [EvaluationRequest(t, evaluation_seed(1, n + i)) for i, t in enumerate(trees)]
        first.tell(evaluator.evaluate(requests))

    state = json.loads(json.dumps(first.to_state()))
    second = config.make_algorithm()
    second.restore(state)
    drive(second, ToyEvaluator())
    assert json.dumps(second.to_state()) == json.dumps(straight.to_state())


def test_bad_parameters_are_refused_with_a_reason():
    with pytest.raises(ConfigError, match="population"):
        GeneticProgramming([0, 1, 2], 10, 1, GPParameters(population=3))
    with pytest.raises(ConfigError, match="probability"):
        GeneticProgramming([0], 10, 1, GPParameters(crossover=1.5))
    with pytest.raises(ConfigError, match="budget"):
        MapElites(0, 0, 1, QDParameters())
    with pytest.raises(ConfigError, match="objective"):
        RunConfig.make("qd", "speed", 10, 1)
    with pytest.raises(ConfigError, match="leave out"):
        RunConfig.make("gp-fnd", "food", 10, 1)
