"""Compositions on the multi-food tasks (``evolution.compositions``): the authors' three mutations, Mix-ME's
mixing, their QD score at 1, 2, 4 and 8 bins, the bias-aware grid, and a run binned by deliveries that
resumes to the same files. The source repertoire is written by hand: five foragers in bins of a deliveries
grid, so that the axis mutation has neighbours along every axis."""

from __future__ import annotations

import json
import random

import pytest

from evolution_manager.errors import ConfigError
from evolution_manager.evolution.compositions import (
    Cell,
    CompositionConfig,
    CompositionParameters,
    CompositionRun,
    Member,
    axis_neighbours,
    bin_of,
    cells_digest,
    coarse_qd_scores,
    evaluate_genomes,
    mix,
    mutate_all,
    mutate_axis,
    read_sources,
)
from evolution_manager.evolution.descriptor_sets import DELIVERIES
from evolution_manager.studies.evolve import evolve
from swarm_sim.evaluation import BatchEvaluator, EvaluationRequest
from swarm_sim.model import OBJECTIVES
from swarm_sim.tasks import task_named

TASK = "multifood-arena9-kind2"
FORAGERS = {
    (0, 0, 0): "sel(seq(on_food2, stop), forward)",
    (1, 0, 0): "sel(seq(got_food1, in_nest, stop), seq(got_food1, nest_left, forward_left), forward_right)",
    (0, 1, 0): "sel(seq(got_food2, nest_right, forward_right), seq(food_left2, forward_left), forward)",
    (0, 0, 1): "sel(seq(got_food3, nest_left, forward_left), seq(food_right3, forward_right), forward)",
    (2, 0, 0): "sel(seq(got_food1, nest_right, forward_right), seq(food_left1, forward_left), forward)",
}
"""Hand-made foragers and the (made-up) deliveries bins they stand in: what matters is the bins' shape."""


@pytest.fixture(scope="module")
def source(tmp_path_factory):
    """A run directory holding only a repertoire file of :data:`FORAGERS`."""
    out = tmp_path_factory.mktemp("source") / "foragers"
    out.mkdir()
    items = [{"bin": list(b), "fitness": 0.1 * k, "tree": t} for k, (b, t) in enumerate(FORAGERS.items())]
    (out / "repertoire_foraging_biased.json").write_text(json.dumps({"items": items}))
    return out


def _cells(*bins):
    return [Cell("run", "foraging", b, 0.0, "forward") for b in bins]


# The authors' mutations and Mix-ME's mixing ----------------------------------------------------------------
def test_mutate_all_redraws_each_robots_cell_with_probability_one_half():
    rng = random.Random(1)
    changed = total = 0
    for _ in range(400):
        genome = tuple(rng.randrange(50) for _ in range(9))
        child = mutate_all(genome, rng, 50)
        assert len(child) == 9 and all(0 <= c < 50 for c in child)
        changed += sum(a != b for a, b in zip(genome, child, strict=True))
        total += 9
    # each cell redrawn with probability 0.5 and then differs with probability 49/50: 0.49 expected
    assert 0.46 < changed / total < 0.52
    assert mutate_all((3,) * 9, random.Random(2), 50) == mutate_all((3,) * 9, random.Random(2), 50)


def test_axis_neighbours_share_every_other_coordinate():
    cells = _cells((0, 0, 0), (1, 0, 0), (2, 0, 0), (0, 1, 0), (1, 1, 0), (0, 0, 3))
    neighbours = axis_neighbours(cells)
    assert neighbours[0] == ((1, 2), (3,), (5,))
    assert neighbours[1] == ((0, 2), (4,), ())
    assert neighbours[5] == ((), (), (0,))


def test_mutate_axis_moves_every_robot_along_one_axis_or_keeps_it():
    cells = _cells((0, 0, 0), (1, 0, 0), (2, 0, 0), (0, 1, 0), (1, 1, 0), (0, 0, 3))
    neighbours = axis_neighbours(cells)
    rng = random.Random(3)
    moved_axes = set()
    for _ in range(300):
        genome = tuple(rng.randrange(len(cells)) for _ in range(9))
        child = mutate_axis(genome, rng, neighbours)
        for before, after in zip(genome, child, strict=True):
            differs = [a for a in range(3) if cells[before].bin[a] != cells[after].bin[a]]
            assert len(differs) == (0 if before == after else 1)
            moved_axes.update(differs)
    assert moved_axes == {0, 1, 2}
    # a cell with no neighbour on any axis stays
    lonely = _cells((0, 0, 0), (5, 5, 5))
    assert mutate_axis((0, 1, 0), random.Random(4), axis_neighbours(lonely)) == (0, 1, 0)


def test_mix_takes_each_robot_from_one_of_the_two_parents():
    a, b = (0,) * 9, (1,) * 9
    children = [mix(a, b, random.Random(seed)) for seed in range(50)]
    assert all(set(c) <= {0, 1} and len(c) == 9 for c in children)
    assert sum(sum(c) for c in children) / (9 * 50) == pytest.approx(0.5, abs=0.08)
    assert mix(a, b, random.Random(7)) == mix(a, b, random.Random(7))
    with pytest.raises(ValueError, match="one length"):
        mix(a, (1,) * 8, random.Random(0))


# The QD score at coarser grids -----------------------------------------------------------------------------
def test_coarse_qd_scores_keep_the_fittest_per_bin_over_k_cubed():
    scored = [((0.1, 0.1, 0.1), 1.0), ((0.4, 0.2, 0.3), 3.0), ((0.6, 0.1, 0.1), 2.0), ((1.0, 1.0, 1.0), 0.5)]
    scores = coarse_qd_scores(scored)
    assert scores[1] == 3.0  # one bin: the fittest of all
    assert scores[2] == pytest.approx((3.0 + 2.0 + 0.5) / 8)  # the top edge falls into the last bin
    assert scores[4] == pytest.approx((1.0 + 3.0 + 2.0 + 0.5) / 64)
    assert scores[8] == pytest.approx((1.0 + 3.0 + 2.0 + 0.5) / 512)
    assert coarse_qd_scores([]) == {1: 0.0, 2: 0.0, 4: 0.0, 8: 0.0}


# Configuration ----------------------------------------------------------------------------------------------
def test_a_multifood_configuration_round_trips_and_the_default_writes_what_it_did():
    parameters = CompositionParameters(cell_mutation="axis", crossover_operator="mix")
    config = CompositionConfig(
        "qd", 10, 1, cells=3, parameters=parameters, task=TASK, objective="foraging_biased",
        descriptors="deliveries",
    )  # fmt: skip
    document = config.to_json()
    assert document["task"] == TASK and document["descriptors"] == "deliveries"
    assert document["parameters"]["cell_mutation"] == "axis"
    assert CompositionConfig.from_json(json.loads(json.dumps(document))) == config
    plain = CompositionConfig("ga", 10, 1, cells=3).to_json()
    assert list(plain)[:4] == ["kind", "objective", "task", "algorithm"]
    assert "descriptors" not in plain and set(plain["parameters"]) == {
        "population", "tournament", "elites", "crossover", "mutation", "init_batch", "batch",
    }  # fmt: skip
    assert (plain["objective"], plain["task"]) == ("foraging", "foraging")


@pytest.mark.parametrize(
    ("changes", "words"),
    [
        ({"descriptors": "deliveries", "task": "foraging"}, "has one kind of food"),
        ({"parameters": CompositionParameters(crossover_operator="mix")}, "goes with algorithm qd"),
        ({"objective": "tidiness"}, "objective must be one of"),
    ],
)
def test_a_bad_configuration_is_refused_in_words(changes, words):
    with pytest.raises(ConfigError, match=words):
        CompositionConfig("ga", 10, 1, cells=3, **changes)
    with pytest.raises(ConfigError, match="cell_mutation must be one of one, all, axis, got 'some'"):
        CompositionParameters(cell_mutation="some")


# Evaluation and the grid ------------------------------------------------------------------------------------
def test_nine_equal_trees_give_the_homogeneous_result_on_a_multifood_task(source):
    cells = read_sources([source])[0]
    evaluator = BatchEvaluator(task_named(TASK).config("paper"))
    members = evaluate_genomes(
        evaluator, cells, [(k,) * 9 for k in range(len(cells))], 11, 2, 0, None, "foraging_biased", DELIVERIES
    )
    alone = evaluator.evaluate([EvaluationRequest(c.tree, 11, 2) for c in cells])
    kinds = [OBJECTIVES.index(f"foraging{k}") for k in (1, 2, 3)]
    for member, result in zip(members, alone, strict=True):
        assert result.ok
        assert member.fitness == result.fitness[OBJECTIVES.index("foraging_biased")]
        assert member.descriptors == tuple(result.fitness[k] for k in kinds)
    assert any(m.fitness for m in members)  # some forager delivers something: the check is not of zeros


def test_under_a_preferred_kind_a_bin_keeps_the_genome_delivering_more_of_it(source, tmp_path):
    cells = read_sources([source])[0]
    config = CompositionConfig(
        "qd", 10, 1, cells=len(cells), task=TASK, objective="foraging_biased", descriptors="deliveries",
        cells_digest=cells_digest(cells),
    )  # fmt: skip
    run = CompositionRun(config, cells, tmp_path / "run", None)
    assert run.preferred == 1  # kind 2
    held = Member((0,) * 9, 0.30, (0.02, 0.20, 0.02), 0)
    fitter = Member((1,) * 9, 0.35, (0.30, 0.19, 0.30), 1)  # fitter, but fewer of kind 2
    more = Member((2,) * 9, 0.25, (0.01, 0.21, 0.01), 2)
    assert bin_of(DELIVERIES.scaled(held.descriptors))[1] == bin_of(DELIVERIES.scaled(more.descriptors))[1]
    assert not run._displaces(fitter, held) and run._displaces(more, held)
    unbiased = CompositionRun(
        CompositionConfig("qd", 10, 1, cells=len(cells), task=TASK, descriptors="deliveries"),
        cells, tmp_path / "other", None,
    )  # fmt: skip
    assert unbiased.preferred is None and unbiased._displaces(fitter, held)


# A run ----------------------------------------------------------------------------------------------------
def _compose(source, out, *extra):
    args = [
        "--task", TASK, "--objective", "foraging_biased", "--descriptors", "deliveries", "--swarm-from",
        str(source), "--algorithm", "qd", "--trials", "1", "--swarm-mutation", "axis",
        "--swarm-crossover", "mix",
    ]  # fmt: skip
    return evolve([*args, "--out", str(out), "--no-progress", "--checkpoint-every", "0", *extra])


def test_a_deliveries_run_writes_its_axes_and_the_coarse_qd_scores(source, tmp_path):
    out = tmp_path / "run"
    assert _compose(source, out, "--evaluations", "40", "--seed", "2") == 0
    header = (out / "evaluations.csv").read_text().splitlines()[0]
    assert header == "evaluation,seed,genome,foraging_biased,foraging1,foraging2,foraging3,error"
    summary = json.loads((out / "summary.json").read_text())
    archive, evaluated = summary["qd_scores_archive"], summary["qd_scores_evaluated"]
    assert set(archive) == set(evaluated) == {"1", "2", "4", "8"}
    assert evaluated["1"] == summary["best_fitness"]  # one bin keeps the fittest of everything evaluated
    assert archive["8"] <= evaluated["8"] + 1e-12 and archive["1"] <= evaluated["1"]
    repertoire = json.loads((out / "repertoire_compositions.json").read_text())
    assert repertoire["descriptors"] == ["foraging1", "foraging2", "foraging3"]
    for item in repertoire["items"]:
        assert item["bin"] == list(bin_of(DELIVERIES.scaled(item["descriptors"])))
    assert (out / "best" / "foraging_biased_swarm.json").is_file()
    # the baseline: the best of every cell's nine copies on the run's scenario, then held-out
    config = json.loads((out / "config.json").read_text())
    cells = read_sources([source])[0]
    alone = BatchEvaluator(task_named(TASK).config("paper")).evaluate(
        [EvaluationRequest(c.tree, config["scenario_seed"], 1) for c in cells]
    )
    fitness = [r.fitness[OBJECTIVES.index("foraging_biased")] for r in alone]
    baseline = summary["homogeneous"]
    assert baseline["fitness"] == max(fitness) and baseline["cell"] == fitness.index(max(fitness))
    assert baseline["tree"] == cells[baseline["cell"]].tree
    assert len(baseline["heldout_descriptors"]) == len(summary["heldout_descriptors"]) == 3
    assert summary["heldout_best_fitness"] is not None and baseline["heldout_best_fitness"] is not None


def test_a_deliveries_run_stopped_and_resumed_ends_identical(source, tmp_path):
    assert _compose(source, tmp_path / "straight", "--evaluations", "60", "--seed", "5") == 0
    config = CompositionConfig.from_json(json.loads((tmp_path / "straight" / "config.json").read_text()))
    cells = read_sources([source])[0]
    evaluator = BatchEvaluator(config.world())
    stopped = CompositionRun.start(config, cells, tmp_path / "stopped", evaluator)
    for stop in (20, 90):
        stopped.execute(checkpoint_interval=1e9, stop_after=stop)
        stopped.lock.release()
        stopped = CompositionRun.resume(tmp_path / "stopped", evaluator)
    stopped.execute(checkpoint_interval=0)
    stopped.write_results()
    names = ["config.json", "cells.json", "evaluations.csv", "progress.csv", "checkpoint.json",
             "summary.json", "repertoire_compositions.json", "best/foraging_biased_swarm.json"]  # fmt: skip
    for name in names:
        assert (tmp_path / "stopped" / name).read_bytes() == (tmp_path / "straight" / name).read_bytes(), name
