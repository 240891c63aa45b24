"""Several kinds of food (the authors' 2026 arenas 5, 6 and 9): the numbered conditions, carrying and
deliveries per kind, the per-kind and biased objectives, alike on the batch road, the reference road and both
recordings; the registered arena tasks; and the bad settings of these arenas, refused in one line."""

from __future__ import annotations

import subprocess
import sys
from dataclasses import replace

import numpy as np
import pytest

from bt_controller.language import CONDITIONS, MULTIFOOD_CONDITIONS, parse, random_trees
from swarm_sim.evaluation import BatchEvaluator, EvaluationRequest, SwarmRequest
from swarm_sim.model import OBJECTIVES, arena_entries, of_trees
from swarm_sim.roads import record_trial, record_trial_reference, reference_road
from swarm_sim.tasks import (
    FORAGING,
    UNSEEN_FIRST_ENTRY,
    TaskError,
    Trials,
    arena_task,
    task_from_yaml,
    task_named,
    task_names,
    task_to_yaml,
    unseen_twin,
)

GATHERER = (
    "sel(seq(sel(got_food1, got_food2, got_food3), sel(seq(nest_left, forward_left), seq(nest_right, "
    "forward_right), forward)), sel(seq(food_left2, forward_left), seq(food_right2, forward_right), "
    "seq(food_left3, forward_left), prob(forward, forward_left, forward_right)))"
)
"""A tree that reads every numbered kind: back to the nest with anything, else towards kind 2 or 3."""


def _short(name: str, ticks: int = 60) -> object:
    return replace(task_named(name), trials=Trials(ticks=ticks, chain_trials=5))


def _named(values: tuple[float, ...]) -> dict[str, float]:
    return dict(zip(OBJECTIVES, values, strict=False))


@pytest.mark.parametrize("profile", ["paper", "clean"])
def test_a_multifood_task_scores_alike_on_both_roads_and_each_kind_adds_up(profile):
    config = _short("multifood-arena6").config(profile)
    assert config.food_kinds == 3 and config.regions == 4
    ((result, records),) = BatchEvaluator(config).evaluate_trials([EvaluationRequest(GATHERER, 2, 5)])
    values, reference = reference_road.evaluate(parse(GATHERER), 2, 5, config)
    assert result.fitness + result.descriptors == values
    assert all((a.end_poses == b.end_poses).all() for a, b in zip(records, reference, strict=True))
    named = _named(values)
    assert named["foraging"] == named["foraging1"] + named["foraging2"] + named["foraging3"]
    assert named["foraging_biased"] == named["foraging"]  # no kind preferred in arena 6


def test_the_arena_tasks_run_the_2026_code_which_differs_after_a_chains_first_trial():
    config = _short("multifood-arena6").config("paper")
    assert config.authors_code == 2026
    older = replace(config, authors_code=2024)
    request = [EvaluationRequest(GATHERER, 2, 5)]
    ((_, new_records),) = BatchEvaluator(config).evaluate_trials(request)
    ((_, old_records),) = BatchEvaluator(older).evaluate_trials(request)
    # The first trial is the same (nobody reads robot_left here); the later ones start their estimates afresh.
    assert (new_records[0].end_poses == old_records[0].end_poses).all()
    assert any(
        (a.end_poses != b.end_poses).any() for a, b in zip(new_records[1:], old_records[1:], strict=True)
    )


def test_random_trees_over_every_condition_agree_on_both_roads_in_a_heterogeneous_swarm():
    config = _short("multifood-arena9-kind2", ticks=16).config("paper")
    trees = random_trees(11, 3, 25, conditions=CONDITIONS)  # every condition, the numbered ones included
    swarm = of_trees([trees[k % 3] for k in range(config.n_robots)], config.n_robots)
    ((result, _),) = BatchEvaluator(config).evaluate_trials([SwarmRequest(swarm, 4, 5)])
    assert result.ok, result.error
    values, _ = reference_road.evaluate(swarm.parsed(), 4, 5, config)
    assert result.fitness + result.descriptors == values


def _specialist(kind: int) -> str:
    home = "sel(seq(nest_left, forward_left), seq(nest_right, forward_right), forward)"
    return (
        f"sel(seq(got_food{kind}, {home}), "
        f"sel(seq(food_left{kind}, forward_left), seq(food_right{kind}, forward_right), forward))"
    )


def test_the_balanced_fitness_of_a_swarm_of_specialists_agrees_on_every_road():
    """Three groups of three robots, each fetching one kind, on the balanced task: the batch road, the
    reference road (the node graph's lockstep) and both recordings give every value alike, the balanced
    one included; per trial it is three times the swarm's least delivered kind per robot. Seed 3, whose
    last trial delivers every kind (rare in 60 s trials; the other trials score 0)."""
    config = _short("multifood-arena6-balanced", ticks=120).config("paper")
    swarm = of_trees([_specialist(1 + i // 3) for i in range(9)], config.n_robots)
    ((result, records),) = BatchEvaluator(config).evaluate_trials([SwarmRequest(swarm, 3, 5)])
    values, _ = reference_road.evaluate(swarm.parsed(), 3, 5, config)
    assert result.fitness + result.descriptors == values
    named = _named(values)
    per_trial = [_named(r.values) for r in records]
    balanced = [3 * min(t["foraging1"], t["foraging2"], t["foraging3"]) for t in per_trial]
    assert [t["foraging_balanced"] for t in per_trial] == pytest.approx(balanced, abs=1e-12)
    assert [t["foraging_balanced"] > 0 for t in per_trial] == [False] * 4 + [True]
    assert 0.0 < named["foraging_balanced"] <= named["foraging"]
    batch, slow = record_trial(swarm, 3, 4, config), record_trial_reference(swarm, 3, 4, config)
    assert np.array_equal(batch.fitness, slow.fitness, equal_nan=True) and batch.values == slow.values
    k = OBJECTIVES.index("foraging_balanced")
    assert batch.fitness[-1, k] == pytest.approx(3 * batch.deliveries[-1].sum(axis=0).min() / 9, abs=1e-12)
    assert batch.fitness[-1, k] == pytest.approx(per_trial[4]["foraging_balanced"], abs=1e-12)
    assert batch.fitness[-1, k] > 0


def test_the_biased_fitness_prefers_its_kind():
    task = _short("multifood-arena9-kind2")
    assert task.scoring.preferred_food == 2 and task.scoring.other_food_weight == 0.5
    ((result, _),) = BatchEvaluator(task.config()).evaluate_trials([EvaluationRequest(GATHERER, 7, 5)])
    named = _named(result.fitness)
    expected = named["foraging2"] + 0.5 * (named["foraging1"] + named["foraging3"])
    assert named["foraging_biased"] == pytest.approx(expected, rel=1e-12)


def test_both_recordings_of_a_multifood_trial_are_the_same():
    config = _short("multifood-arena5", ticks=40).config("paper")
    batch, reference = record_trial(GATHERER, 3, 2, config), record_trial_reference(GATHERER, 3, 2, config)
    for name in ("poses", "actions", "smoothed", "ground", "initial", "carrying", "deliveries"):
        assert (getattr(batch, name) == getattr(reference, name)).all(), name
    assert batch.ground.shape[2] == 4 and batch.carrying.shape[2] == batch.deliveries.shape[2] == 3
    assert batch.smoothed.shape[2] == 5  # nest, food, density, food2, food3
    assert (
        np.array_equal(batch.fitness, reference.fitness, equal_nan=True) and batch.values == reference.values
    )


def test_the_registered_arena_tasks():
    for layout in range(1, 9):
        task = task_named(f"multifood-arena{layout}")
        kinds = 3 if layout in (5, 6) else 1
        assert task.config().food_kinds == kinds
        assert task.nodes.conditions == (MULTIFOOD_CONDITIONS if kinds == 3 else FORAGING.nodes.conditions)
    for kind in (1, 2, 3):
        task = task_named(f"multifood-arena9-kind{kind}")
        assert task.scoring.preferred_food == kind and "foraging_biased" in task.objectives
        assert task_from_yaml(task_to_yaml(task)) == task
    # arena 6 scored by its least delivered kind: arena 6's task but for the objective and the words
    balanced, six = task_named("multifood-arena6-balanced"), task_named("multifood-arena6")
    assert balanced.objectives == (*six.objectives, "foraging_balanced")
    assert "foraging_balanced" in balanced.description and balanced.config().food_kinds == 3
    assert replace(balanced, name=six.name, description=six.description, objectives=six.objectives) == six
    assert task_from_yaml(task_to_yaml(balanced)) == balanced
    assert arena_task(FORAGING, 6, balanced=True, name="multifood-arena6-balanced") == balanced
    assert unseen_twin("multifood-arena6-balanced").objectives == balanced.objectives


def test_the_unseen_twins_take_the_arenas_no_run_evolves_on():
    """``<task>-unseen``: the same task, trial k of a block on generated arena 5 + k, never on 0 to 4."""
    names = [n for n in task_names() if n.endswith("-unseen")]
    assert len(names) == 10 and all(unseen_twin(n.removesuffix("-unseen")).name == n for n in names)
    for name in names:
        seen, unseen = task_named(name.removesuffix("-unseen")), task_named(name)
        layout = int(name.split("arena")[1][0])
        bias = seen.scoring.preferred_food - 1 if layout == 9 else None
        entries = arena_entries(layout, bias=bias)
        assert UNSEEN_FIRST_ENTRY == 5 and len(entries) == 10
        for region, m in ((unseen.regions[i], i) for i in range(len(unseen.regions))):
            assert region.centre == tuple((e[m].x, e[m].y) for e in entries[5:10]), (name, m)
            assert seen.regions[m].centre == tuple((e[m].x, e[m].y) for e in entries[:5])
        assert replace(unseen, name=seen.name, description=seen.description, regions=seen.regions) == seen
        assert task_from_yaml(task_to_yaml(unseen)) == unseen
    # a tree scores differently on arenas it never met (the same seed and trials)
    evaluator = BatchEvaluator(_short("multifood-arena6").config())
    other = BatchEvaluator(_short("multifood-arena6-unseen").config())
    request = [EvaluationRequest(GATHERER, 3, 5)]
    assert evaluator.evaluate(request)[0].fitness != other.evaluate(request)[0].fitness
    with pytest.raises(TaskError, match="task 'foraging' has no unseen arenas; the tasks that have: multi"):
        unseen_twin("foraging")
    with pytest.raises(TaskError, match="first_entry applies only to the generated layouts 6-9"):
        arena_task(FORAGING, 5, first_entry=1)
    with pytest.raises(TaskError, match="first_entry must be 0 to 9, got 10"):
        arena_task(FORAGING, 6, first_entry=10)


def test_bad_settings_of_the_2026_arenas_are_refused_in_one_line():
    command = [sys.executable, "-m", "swarm_sim.tasks.cli", "arena"]
    for args, expected in (
        (["9"], "arena layout 9 needs a bias"),
        (["5", "--nest-radius", "400"], "arena 5"),
    ):
        refused = subprocess.run([*command, *args], capture_output=True, text=True)
        assert refused.returncode == 2 and refused.stderr.count("\n") == 1, args
        assert expected in refused.stderr, refused.stderr
    for layout in (1, 4):  # localised starts need a food disc (the authors refuse them too)
        with pytest.raises(TaskError, match="formation localised"):
            replace(arena_task(FORAGING, layout), robots=replace(FORAGING.robots, formation="localised"))
    with pytest.raises(TaskError, match="on_food2 reads the food2 region"):
        replace(FORAGING, nodes=replace(FORAGING.nodes, conditions=("on_food2",)))
