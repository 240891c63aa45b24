"""The optimisers over a network's weights: DEAP's operators drawn from a passed-in generator give DEAP's own
results; the GA and CMA-ES continue exactly from their state; pycma leaves numpy's global generator alone; a
run stopped and resumed ends with the very files of an uninterrupted one, through ``evolve``."""

from __future__ import annotations

import json
import random

import numpy as np
import pytest
from deap import base, tools
from killed_runs import straight_and_killed
from threadpoolctl import threadpool_info

from bt_controller.interpreters import N_WEIGHTS, load_network
from evolution_manager.evolution.networks import (
    NetworkConfig,
    NetworkParameters,
    NetworkRun,
    WeightCmaEs,
    WeightGA,
    WeightMapElites,
    cx_two_point,
    mut_gaussian,
    sel_best,
    sel_tournament,
)
from evolution_manager.studies.evolve import evolve
from swarm_sim.evaluation import BatchEvaluator


class _Fitness(base.Fitness):
    weights = (1.0,)


class _Individual(list):
    def __init__(self, values, fitness):  # type: ignore[no-untyped-def]  # a test helper, untyped like the other tests
        super().__init__(values)
        self.fitness = _Fitness((fitness,))


def test_operators_draw_as_deaps_own_from_the_same_generator_state():
    source = random.Random(11)
    for trial in range(200):
        a = [source.uniform(-5, 5) for _ in range(N_WEIGHTS)]
        b = [source.uniform(-5, 5) for _ in range(N_WEIGHTS)]
        fitness = [source.random() for _ in range(25)]
        ours = random.Random(trial)
        x, y = list(a), list(b)
        cx_two_point(x, y, ours)
        mutated = list(a)
        mut_gaussian(mutated, 0.0, 5.0, 0.05, ours)
        winners = sel_tournament(fitness, 22, 3, ours)
        random.seed(trial)  # DEAP draws from the random module
        dx, dy = list(a), list(b)
        tools.cxTwoPoint(dx, dy)
        [dm] = tools.mutGaussian(list(a), 0.0, 5.0, 0.05)
        population = [_Individual([k], f) for k, f in enumerate(fitness)]
        deap_winners = [ind[0] for ind in tools.selTournament(population, 22, 3)]
        assert (x, y, mutated, winners) == (dx, dy, dm, deap_winners)
        assert sel_best(fitness, 3) == [ind[0] for ind in tools.selBest(population, 3)]


def _descriptors(w):  # type: ignore[no-untyped-def]  # a test helper, untyped like the other tests
    return [1.0 / (1.0 + np.exp(-w[k])) for k in range(2)] + [0.0]


def _drive(optimiser, generations: int) -> list[list[float]]:
    asked = []
    for _ in range(generations):
        batch = optimiser.ask()
        asked.extend(batch)
        optimiser.tell([-float(np.sum(np.square(w))) + w[0] for w in batch], [_descriptors(w) for w in batch])
    return asked


@pytest.mark.parametrize("kind", ["ga", "cmaes", "qd"])
def test_an_optimiser_continues_exactly_from_its_state(kind):
    def make():  # type: ignore[no-untyped-def]  # a test helper, untyped like the other tests
        p = NetworkParameters()
        if kind == "ga":
            return WeightGA(p, random.Random(4))
        return (WeightCmaEs if kind == "cmaes" else WeightMapElites)(p, np.random.default_rng(4))

    straight = make()
    _drive(straight, 8)
    stopped = make()
    _drive(stopped, 3)
    state = json.loads(json.dumps(stopped.to_state()))  # a checkpoint is plain JSON
    resumed = make()
    resumed.restore(state)
    _drive(resumed, 5)
    assert resumed.to_state() == straight.to_state()
    assert resumed.ask() == straight.ask()


def test_the_ga_keeps_its_elites_rounds_and_improves():
    ga = WeightGA(NetworkParameters(), random.Random(2))
    asked = _drive(ga, 30)
    assert len(asked) == 25 + 29 * 22  # the 3 elites are not asked again
    assert all(w == round(w, 2) for weights in asked for w in weights)
    assert all(-5 <= w <= 5 for w in asked[0])
    assert max(ga.fitness) > max(-float(np.sum(np.square(w))) + w[0] for w in asked[:25])


def test_cmaes_samples_from_the_passed_generator_only():
    np.random.seed(123)
    before = np.random.get_state()[1].copy()
    one = WeightCmaEs(NetworkParameters(), np.random.default_rng(9))
    two = WeightCmaEs(NetworkParameters(), np.random.default_rng(9))
    assert _drive(one, 4) == _drive(two, 4)
    assert (np.random.get_state()[1] == before).all()
    other = WeightCmaEs(NetworkParameters(), np.random.default_rng(10))
    assert other.ask() != one.ask()
    assert len(one.ask()) == 25 and len(one.ask()[0]) == N_WEIGHTS


def test_map_elites_fills_bins_and_draws_from_the_passed_generator():
    one = WeightMapElites(NetworkParameters(), np.random.default_rng(5))
    asked = _drive(one, 6)
    assert len(asked) == 6 * 50 and one.scheduler.archive.stats.num_elites > 4
    two = WeightMapElites(NetworkParameters(), np.random.default_rng(5))
    assert _drive(two, 6) == asked


def _files(root):  # type: ignore[no-untyped-def]  # a test helper, untyped like the other tests
    names = ("evaluations.csv", "progress.csv", "summary.json", "checkpoint.json", "best/food.json",
             "repertoire_food.json")  # fmt: skip
    return {name: (root / name).read_bytes() for name in names}


def test_a_run_steps_its_optimiser_on_one_blas_thread_and_gives_the_threads_back(tmp_path):
    """The optimisers' eigendecompositions run on one BLAS thread (``NetworkRun._batch_context``); after the
    run the process's BLAS libraries have their threads as before."""

    def blas_threads() -> dict[str, int]:
        pools = [pool for pool in threadpool_info() if pool["user_api"] == "blas"]
        return {pool["filepath"]: pool["num_threads"] for pool in pools}

    before = blas_threads()
    assert before  # numpy's BLAS is loaded
    config = NetworkConfig("nn-cmaes", "food", evaluations=60, seed=3, trials=1)
    run = NetworkRun.start(config, tmp_path / "run", BatchEvaluator(config.world()))
    during: list[dict[str, int]] = []
    run.execute(on_batch=lambda *_: during.append(blas_threads()))
    assert during and all(set(threads.values()) == {1} for threads in during)
    after = blas_threads()  # the run may have loaded another BLAS (scipy's, through pycma)
    assert {path: after[path] for path in before} == before


@pytest.mark.parametrize("algorithm", ["nn-ga", "nn-cmaes", "nn-qd"])
def test_a_run_stopped_and_resumed_ends_identical(tmp_path, algorithm):
    args = ["--algorithm", algorithm, "--objective", "food", "--evaluations", "100", "--trials", "1"]
    assert evolve([*args, "--seed", "3", "--out", str(tmp_path / "straight"), "--no-progress"]) == 0
    config = NetworkConfig.from_json(json.loads((tmp_path / "straight" / "config.json").read_text()))
    evaluator = BatchEvaluator(config.world())
    stopped = NetworkRun.start(config, tmp_path / "stopped", evaluator)
    for stop in (30, 80):
        stopped.execute(checkpoint_interval=1e9, stop_after=stop)
        with open(tmp_path / "stopped" / "evaluations.csv", "a") as log:  # rows after the last checkpoint
            log.write("999,1,garbage\n")
        stopped.lock.release()  # type: ignore[union-attr]  # a started run holds its lock
        stopped = NetworkRun.resume(tmp_path / "stopped", evaluator)
    stopped.execute(checkpoint_interval=0)
    stopped.finish()
    assert _files(tmp_path / "stopped") == _files(tmp_path / "straight")
    summary = json.loads((tmp_path / "straight" / "summary.json").read_text())
    best = load_network(tmp_path / "straight" / "best" / "food.json")
    assert list(best.weights) == summary["best"]["weights"] and summary["produced"] >= 100
    repertoire = json.loads((tmp_path / "straight" / "repertoire_food.json").read_text())["items"]
    assert len(repertoire) == summary["repertoire_size"] == round(summary["coverage"] * 512) > 0
    assert all(item["bin"][2] == 0 for item in repertoire)  # a network's conditionality is 0
    assert max(item["fitness"] for item in repertoire) == summary["best"]["fitness"]
    # the same options again: refused, the run is there; --resume of a finished run changes nothing
    assert evolve([*args, "--seed", "3", "--out", str(tmp_path / "straight"), "--no-progress"]) == 2
    assert evolve(["--out", str(tmp_path / "straight"), "--resume", "--no-progress"]) == 0
    assert _files(tmp_path / "straight")["evaluations.csv"] == _files(tmp_path / "stopped")["evaluations.csv"]


def test_a_killed_run_resumes_to_the_same_files(tmp_path):
    argv = ["--algorithm", "nn-ga", "--objective", "food", "--evaluations", "400", "--trials", "1"]
    straight, killed = straight_and_killed([*argv, "--seed", "4"], tmp_path, rows=4)
    assert _files(killed) == _files(straight)


def test_bad_network_run_options_are_one_line_refusals(tmp_path, capsys):
    assert evolve(["--algorithm", "nn-ga", "--out", str(tmp_path / "a"), "--no-progress"]) == 2
    assert "needs --objective" in capsys.readouterr().err
    args = ["--algorithm", "nn-cmaes", "--objective", "food", "--out", str(tmp_path / "b")]
    assert evolve([*args, "--objectives", "food,nest"]) == 2
    assert "no --library or --objectives" in capsys.readouterr().err
