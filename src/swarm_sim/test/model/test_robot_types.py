"""The authors' two robot types (``robots.types: 2``, their ``generic`` projects at 1cd2358): an odd robot
perceives the nest and food kind 1 the other way round on its ground sensor (``footbot_bt.cpp:242-260, 269``),
in the messages it receives (``:527-533``) and in those it sends (``:482-488``), and measures its true food
distance from the nest; worked by hand, then alike on the batch road, the reference road and both
recordings; one type is the model as it was."""

from __future__ import annotations

import subprocess
import sys
from dataclasses import replace

import numpy as np
import pytest

from bt_controller.language import CONDITION_INDEX, parse
from bt_controller.robot import RobotView
from swarm_sim.core import sense_swarm, setup_chain, world
from swarm_sim.errors import ConfigError
from swarm_sim.evaluation import BatchEvaluator, EvaluationRequest
from swarm_sim.model import N_PROBES, Config
from swarm_sim.roads import record_trial, record_trial_reference, reference_road
from swarm_sim.tasks import FORAGING, TaskError, Trials, arena_task, task_from_yaml, task_named, task_to_yaml

FORAGER = (
    "sel(seq(got_food, sel(seq(nest_left, forward_left), seq(nest_right, forward_right), forward)), "
    "sel(seq(food_left, forward_left), seq(food_right, forward_right), prob(forward, forward_left, "
    "forward_right)))"
)
"""A tree that reads the ground and both gradients: back to the nest with food, else towards food."""


def _short(name: str, ticks: int = 40) -> object:
    return replace(task_named(name), trials=Trials(ticks=ticks, chain_trials=5))


def _disc(config: Config, kind: int) -> tuple[float, float, float]:
    """The first disc of region ``kind`` (0 nest, 1 food) of trial 0's entry: (x, y, radius)."""
    entry, _ = config.arena_arrays(0)
    row = next(piece for piece in entry if piece[0] == kind and piece[1] == 0.0)
    return float(row[2]), float(row[3]), float(row[4])


def _types(config: Config, types: int) -> Config:
    return replace(config, robot_types=types)


def _readings_at(config: Config, xy: list[tuple[float, float]], broadcast: np.ndarray) -> list:
    n = config.n_robots
    setup = setup_chain(0, 0, config)
    x = np.array([p[0] for p in xy])
    y = np.array([p[1] for p in xy])
    entry, _ = config.arena_arrays(0)
    return sense_swarm(x, y, np.zeros(n), broadcast, setup.drop_keys, 5, entry, config.params())


def test_an_odd_robot_on_the_food_disc_reads_in_nest_and_an_even_one_does_not():
    """Arena 7 (a nest point and a food point): robots 0 and 1 stand at the food disc's centre, 2 and 3 at
    the nest's. By hand: the even robots read the world as it is; the odd ones read the food disc as their
    nest and the nest disc as their food, and their blackboard's in_nest and on_food say so."""
    config = replace(_short("multifood-arena7-types").config("paper"), n_robots=4)
    fx, fy, _ = _disc(config, 1)
    nx, ny, _ = _disc(config, 0)
    cap = np.full((4, config.regions), config.estimate_cap)
    readings = _readings_at(config, [(fx, fy), (fx, fy), (nx, ny), (nx, ny)], cap)
    grounds = [r.ground.tolist() for r in readings]
    assert grounds == [[False, True], [True, False], [True, False], [False, True]]
    in_nest, on_food = CONDITION_INDEX["in_nest"], CONDITION_INDEX["on_food"]
    boards = []
    for r in readings:
        view = RobotView(config.perception)
        view.sense(r)
        boards.append(view.blackboard())
    assert [bool(b[in_nest]) for b in boards] == [False, True, True, False]
    assert [bool(b[on_food]) for b in boards] == [True, False, False, True]
    # One type: every robot reads the world as the even ones do.
    same = _readings_at(_types(config, 1), [(fx, fy), (fx, fy), (nx, ny), (nx, ny)], cap)
    assert [r.ground.tolist() for r in same] == [[False, True], [False, True], [True, False], [True, False]]


def test_what_is_sent_and_heard_swaps_by_hand():
    """Three robots in range of each other (no loss, no occlusion), each broadcasting (nest, food) in its own
    sense: 0 (100, 3000), 1 (200, 4000), 2 (250, 4500). On the air robot 1's are (4000, 200); so even robots
    hear it as (4000, 200) and robot 1 hears the even ones swapped, (3000, 100) and (4500, 250)."""
    config = Config(n_robots=3, robot_types=2, delivery_probability=1.0, occlusion=False)
    broadcast = np.array([[100.0, 3000.0], [200.0, 4000.0], [250.0, 4500.0]])
    sent = broadcast.copy()
    readings = _readings_at(config, [(0.0, 0.0), (300.0, 0.0), (600.0, 0.0)], broadcast)
    assert np.array_equal(broadcast, sent)  # what the robots broadcast is left as it is
    heard = [{int(s): v.tolist() for s, v in zip(r.senders, r.values, strict=True)} for r in readings]
    assert heard[0] == {1: [4000.0, 200.0], 2: [250.0, 4500.0]}
    assert heard[1] == {0: [3000.0, 100.0], 2: [4500.0, 250.0]}
    assert heard[2] == {0: [100.0, 3000.0], 1: [4000.0, 200.0]}
    # An odd robot hears another odd one in their common sense.
    four = _readings_at(replace(config, n_robots=4), [(0.0, 0.0), (300.0, 0.0), (600.0, 0.0), (900.0, 0.0)],
                        np.vstack([broadcast, [[300.0, 5000.0]]]))  # fmt: skip
    assert {int(s): v.tolist() for s, v in zip(four[1].senders, four[1].values, strict=True)}[3] == [
        300.0,
        5000.0,
    ]


def test_an_odd_robots_food_distance_is_its_distance_from_the_nest():
    config = replace(_short("multifood-arena7-types").config("paper"), n_robots=2)
    fx, fy, _ = _disc(config, 1)
    entry, _ = config.arena_arrays(0)
    x, y = np.array([fx, fx]), np.array([fy, fy])
    probes = np.zeros((2, 2, N_PROBES))
    world.take_all_probes(x, y, entry, probes, 0, config.params())
    assert probes[0, 0, 0] == 0.0  # the even robot stands on its food
    assert probes[1, 0, 0] == world.region_distance(fx, fy, entry, 0) > 0.0  # the odd one is off its food


@pytest.mark.parametrize("name", ["multifood-arena7-types", "multifood-arena8-types"])
@pytest.mark.parametrize("profile", ["paper", "clean"])
def test_a_types_task_scores_alike_on_the_batch_and_reference_roads(name, profile):
    config = _short(name).config(profile)
    assert config.robot_types == 2 and config.formation == "localised"
    ((result, records),) = BatchEvaluator(config).evaluate_trials([EvaluationRequest(FORAGER, 3, 5)])
    values, reference = reference_road.evaluate(parse(FORAGER), 3, 5, config)
    assert result.fitness + result.descriptors == values
    assert all((a.end_poses == b.end_poses).all() for a, b in zip(records, reference, strict=True))


def test_both_recordings_of_a_types_trial_are_the_same_and_odd_robots_read_the_world_swapped():
    config = _short("multifood-arena8-types").config("paper")
    batch, reference = record_trial(FORAGER, 5, 1, config), record_trial_reference(FORAGER, 5, 1, config)
    for name in ("poses", "actions", "smoothed", "ground", "initial", "carrying", "deliveries"):
        assert (getattr(batch, name) == getattr(reference, name)).all(), name
    assert np.array_equal(batch.fitness, reference.fitness, equal_nan=True)
    assert batch.values == reference.values
    entry, _ = config.arena_arrays(1)
    for step in (0, len(batch.poses) - 1):
        for i, (x, y, _) in enumerate(batch.poses[step]):
            true = np.zeros(config.regions, dtype=np.bool_)
            world.ground(x, y, entry, true)
            expected = true[::-1] if i % 2 else true
            assert batch.ground[step, i].tolist() == expected.tolist(), (step, i)
    # Each robot's first step: it carries food when it stands on its own food (odd ones: the world's nest).
    assert batch.carrying[0, :, 0].tolist() == batch.ground[0, :, 1].tolist()


def test_two_types_change_what_the_swarm_does_and_one_type_is_the_model_as_it_was():
    task = _short("multifood-arena7-types")
    two = task.config("paper")
    one = _types(two, 1)
    assert one == replace(arena_task(FORAGING, 7, formation="localised"), trials=task.trials).config("paper")
    assert "robot_types" in two.as_dict() and "robot_types" not in one.as_dict()  # files as before types
    request = [EvaluationRequest(FORAGER, 3, 5)]
    ((typed, _),) = BatchEvaluator(two).evaluate_trials(request)
    ((plain, _),) = BatchEvaluator(one).evaluate_trials(request)
    assert typed.fitness != plain.fitness
    # A tree that reads no region sees no type: the same swarm, move for move.
    blind = [EvaluationRequest("sel(seq(robot_left, forward_left), forward)", 3, 5)]
    ((a, a_records),) = BatchEvaluator(two).evaluate_trials(blind)
    ((b, b_records),) = BatchEvaluator(one).evaluate_trials(blind)
    assert a.descriptors == b.descriptors
    assert all((r.end_poses == s.end_poses).all() for r, s in zip(a_records, b_records, strict=True))


def test_the_registered_types_tasks_and_bad_settings():
    for layout in (7, 8):
        task = task_named(f"multifood-arena{layout}-types")
        assert task.robots.types == 2 and task.robots.formation == "localised"
        assert task_from_yaml(task_to_yaml(task)) == task
        assert "two robot types" in task.description
    listed = subprocess.run(
        [sys.executable, "-m", "swarm_sim.tasks.cli", "list"], capture_output=True, text=True, check=True
    ).stdout
    assert "multifood-arena7-types: 100 s trials, 9 robots, two robot types" in listed
    with pytest.raises(TaskError, match=r"robots\.types must be 1 \(one type\) or 2"):
        task_from_yaml("name: t\nrobots: {types: 3}\n")
    with pytest.raises(ConfigError, match="robot_types must be 1"):
        Config(robot_types=0)
