"""A task travels whole through the node graph: an edited task's world (trial length, chain, arena, robot
count, regions) runs in the simulator node as on the batch road, its bag says that world, and a replay and an
animation rebuild it from the bag alone."""

from dataclasses import replace

import numpy as np
import pytest

from evolution_manager.graph.nodes.trial import TrialGraph
from evolution_manager.recording.reproduce import verify_trial_bag
from evolution_manager.viewing.frames import frames_from_bag
from swarm_sim.evaluation import BatchEvaluator, EvaluationRequest
from swarm_sim.model import N_OBJECTIVES, OBJECTIVES
from swarm_sim.tasks import AGGREGATION, FORAGING, Arena, Region, Robots, Trials, task_named

SMALL = replace(
    FORAGING,
    name="small-foraging",
    arena=Arena(half_size=1800.0),
    regions=(Region("nest", "disc", (400.0,)), Region("food", "beyond", (700.0, 900.0))),
    trials=Trials(ticks=14, chain_trials=2),
    robots=Robots(count=5, start_half_size=800.0),
)
DISCS = replace(
    SMALL,
    name="two-discs",
    arena=Arena(half_size=1800.0, trial_entries=2),
    regions=(
        Region("nest", "disc", (400.0,), ((0.0, 600.0),)),
        Region("food", "disc", (450.0, 350.0, 450.0, 350.0), ((0.0, -700.0), (700.0, -300.0)) * 2),
        Region("food", "below", (1500.0,)),
    ),
    robots=Robots(count=5, start_half_size=800.0, formation="localised"),
)
"""Regions of the task's own (a layout): the food disc moves between the two trials of a chain, and the
robots start around it (even ones) and around the nest (odd ones)."""
KINDS = replace(
    task_named("multifood-arena9-kind2"),
    trials=Trials(ticks=14, chain_trials=2),
    robots=Robots(count=5, start_half_size=800.0),
)
"""Three kinds of food (the authors' arena 9, kind 2 preferred): the numbered conditions, carrying and
deliveries per kind and the biased objective travel through the graph's messages and its bag."""
TYPES = replace(
    task_named("multifood-arena7-types"),
    trials=Trials(ticks=14, chain_trials=2),
    robots=replace(task_named("multifood-arena7-types").robots, count=5),
)
"""The authors' two robot types (arena 7, localised starts): the odd robots' swapped ground and messages are
made on the simulator's side, so the graph's controllers run unchanged and the bag's world says the types."""
CARRIERS = replace(
    task_named("multifood-arena6-carriers"),
    trials=Trials(ticks=14, chain_trials=2),
    robots=replace(task_named("multifood-arena6-carriers").robots, count=5, start_half_size=800.0),
)
"""Robot groups that pick up one kind each (ids 0-1 food, 2-3 food2, 4 food3 of five): the simulator node
takes the groups as a parameter and tells each controller where it stands for picking up food
(``Readings.footing``, the ground message's ``footing``), so the controllers run unchanged."""
TREE = "sel(seq(got_food, nest_left, forward_left), seq(food_right, forward_right), forward)"
KINDS_TREE = (
    "sel(seq(sel(got_food1, got_food2, got_food3), sel(seq(nest_left, forward_left), seq(nest_right, "
    "forward_right), forward)), sel(seq(food_left2, forward_left), seq(food_right3, forward_right), forward))"
)
CARRY_TREE = "sel(seq(got_food1, forward_left), seq(got_food2, forward_right), forward)"
"""A tree whose moves follow what a robot carries, so that a pick-up the groups forbid would show."""


@pytest.mark.parametrize(
    ("task", "tree"),
    [(SMALL, TREE), (DISCS, TREE), (KINDS, KINDS_TREE), (TYPES, TREE), (CARRIERS, CARRY_TREE)],
    ids=["small", "discs", "kinds", "types", "carriers"],
)
def test_an_edited_task_runs_through_the_graph_as_on_the_batch_road_and_replays_from_its_bag(
    task, tree, tmp_path
):
    config = task.config("paper")
    evaluator = BatchEvaluator(config)
    seed, trial, bag = 11, 3, tmp_path / "bag"  # trial 3: the second chain's second (food at 900 mm; disc 2)
    with TrialGraph(timeout=120.0, task=task) as graph:
        assert graph.robots == 5
        record = graph.run(tree, seed, trial, bag)
    _, records = evaluator.evaluate_trials([EvaluationRequest(tree, seed, trial + 1)])[0]
    assert record.values == records[trial].values
    assert np.array_equal(record.end_poses, records[trial].end_poses)
    if task.robots.carries:  # the groups change this trial: a graph that ignored them would differ
        free = BatchEvaluator(replace(config, carries=())).evaluate_trials(
            [EvaluationRequest(tree, seed, trial + 1)]
        )
        assert not np.array_equal(record.end_poses, free[0][1][trial].end_poses)
    replay = verify_trial_bag(bag)
    assert replay.reproduced, replay
    frames = frames_from_bag(bag)
    assert len(frames.steps) == task.trials.ticks * 4 and frames.poses.shape[1] == 5
    assert frames.regions == (config.arena_entry(trial) if config.layout else ())
    # Every objective, the newest (aggregation) included, as the animation scores the bag's last step.
    assert frames.fitness[-1].tolist() == list(record.values[:N_OBJECTIVES])


def test_the_aggregation_task_runs_through_the_graph_and_replays_from_its_bag(tmp_path):
    """This project's own task, registered by name, with its own objective, as docs/tasks.md walks it."""
    short = replace(AGGREGATION, trials=Trials(ticks=16, chain_trials=1))
    tree = "sel(seq(robot_left, forward_left), seq(robot_right, forward_right), forward)"
    seed, trial, bag = 3, 0, tmp_path / "bag"
    with TrialGraph(timeout=120.0, task=short) as graph:
        record = graph.run(tree, seed, trial, bag)
    _, records = BatchEvaluator(short.config("paper")).evaluate_trials([EvaluationRequest(tree, seed, 1)])[0]
    assert record.values == records[0].values
    assert 0.0 < record.values[OBJECTIVES.index("aggregation")] < 1.0
    replay = verify_trial_bag(bag)
    assert replay.reproduced, replay
