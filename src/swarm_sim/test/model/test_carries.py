"""Robot groups that pick up only some food kinds (``robots.carries``, ``Config.carries``): a robot on a kind
its group cannot carry senses it as any other but never carries or delivers it; the batch kernels and the
reference road agree on it to the bit; no groups is the model as it was; bad settings are refused in one
line."""

from __future__ import annotations

import subprocess
import sys
from dataclasses import replace

import numpy as np
import pytest

from bt_controller.language import parse
from swarm_sim.core import sense_swarm, setup_chain, world
from swarm_sim.errors import ConfigError
from swarm_sim.evaluation import BatchEvaluator, EvaluationRequest
from swarm_sim.model import Config, carries_from_text, carries_to_text, config_from_dict
from swarm_sim.roads import record_trial, record_trial_reference, reference_road
from swarm_sim.tasks import (
    FORAGING,
    TaskError,
    Trials,
    arena_task,
    task_from_yaml,
    task_named,
    task_to_yaml,
    unseen_twin,
    world_parameters,
)

CARRIERS = "multifood-arena6-carriers"
FORAGER = (
    "sel(seq(sel(got_food1, got_food2, got_food3), sel(seq(nest_left, forward_left), seq(nest_right, "
    "forward_right), forward)), sel(seq(food_left2, forward_left), seq(food_right3, forward_right), "
    "prob(forward, forward_left, forward_right)))"
)
"""A tree that goes home with any kind and otherwise seeks kinds 2 and 3 or wanders, so that every robot
crosses food of every kind."""
GROUPS = (("food",), ("food2",), ("food3",))


def _short(ticks: int = 60) -> Config:
    """The carriers task in short trials (chains of five)."""
    return replace(task_named(CARRIERS), trials=Trials(ticks=ticks, chain_trials=5)).config("paper")


def _disc(config: Config, kind: int) -> tuple[float, float]:
    """The centre of the first disc of region ``kind`` (1-3: food kinds) of trial 0's entry."""
    entry, _ = config.arena_arrays(0)
    row = next(piece for piece in entry if piece[0] == kind and piece[1] == 0.0)
    return float(row[2]), float(row[3])


def test_robot_i_is_in_group_i_mod_groups_as_in_a_team_and_the_kinds_are_bits():
    config = _short()
    p = config.params()
    assert (p.carry_groups, p.carry_masks) == (3, 0b100_010_001)
    allowed = [[world.can_carry(i, f, p) for f in range(3)] for i in range(9)]
    assert allowed == [[i % 3 == f for f in range(3)] for i in range(9)]
    # the groups of a team of as many trees: robot i runs tree i mod K (evolution_manager's teams)
    # 7 robots in 3 groups are 0, 3, 6 / 1, 4 / 2, 5; a scout group carries nothing.
    seven = replace(config, n_robots=7, carries=(("food", "food3"), (), ("food2",))).params()
    assert [[world.can_carry(i, f, seven) for f in range(3)] for i in range(7)] == [
        [True, False, True],
        [False, False, False],
        [False, True, False],
        [True, False, True],
        [False, False, False],
        [False, True, False],
        [True, False, True],
    ]
    assert all(
        world.can_carry(i, f, replace(config, carries=()).params()) for i in range(9) for f in range(3)
    )


def test_a_robot_senses_a_kind_it_cannot_carry_but_stands_on_it_only_for_the_kinds_it_can():
    config = replace(_short(), n_robots=3, delivery_probability=1.0)
    food2 = _disc(config, 2)
    entry, _ = config.arena_arrays(0)
    setup = setup_chain(0, 0, config)
    x, y = np.array([food2[0]] * 3), np.array([food2[1]] * 3)
    broadcast = np.full((3, config.regions), config.estimate_cap)
    readings = sense_swarm(x, y, np.zeros(3), broadcast, setup.drop_keys, 5, entry, config.params())
    for i, reading in enumerate(readings):
        assert reading.ground.tolist() == [False, False, True, False]  # every robot reads food2
        assert reading.footing is not None  # none of them carries every kind
        assert reading.standing.tolist() == [False, False, i == 1, False]  # only robot 1 may take it
    free = sense_swarm(
        x, y, np.zeros(3), broadcast, setup.drop_keys, 5, entry, replace(config, carries=()).params()
    )
    assert all(reading.footing is None for reading in free)


@pytest.mark.parametrize("road", [record_trial, record_trial_reference], ids=["batch", "reference"])
def test_a_robot_on_a_kind_it_cannot_carry_never_carries_or_delivers_it(road):
    config = _short()
    record = road(FORAGER, 3, 1, config)  # a trial in which every kind is crossed by robots barred from it
    on = record.ground[:, :, 1:]  # what each robot reads of each food kind, step by step (no ground faults)
    group = np.arange(9) % 3
    for f in range(3):
        barred = group != f
        assert not record.carrying[:, barred, f].any(), f
        assert not record.deliveries[:, barred, f].any(), f
        assert on[:, barred, f].any(), f  # they do stand on it (the test would catch a pick-up)
    # The groups pick up their own kinds where they stand on them.
    assert any(record.carrying[:, group == f, f].any() for f in range(3))
    # Without groups the same robots pick up the kinds they cross.
    free = road(FORAGER, 3, 1, replace(config, carries=()))
    assert any(free.carrying[:, group != f, f].any() for f in range(3))


@pytest.mark.parametrize("profile", ["paper", "clean"])
def test_the_batch_and_reference_roads_agree_with_carries(profile):
    config = replace(task_named(CARRIERS), trials=Trials(ticks=60, chain_trials=5)).config(profile)
    ((result, records),) = BatchEvaluator(config).evaluate_trials([EvaluationRequest(FORAGER, 3, 6)])
    values, reference = reference_road.evaluate(parse(FORAGER), 3, 6, config)
    assert result.fitness + result.descriptors == values
    assert all((a.end_poses == b.end_poses).all() for a, b in zip(records, reference, strict=True))
    batch, ref = record_trial(FORAGER, 3, 2, config), record_trial_reference(FORAGER, 3, 2, config)
    for name in ("poses", "actions", "smoothed", "ground", "initial", "carrying", "deliveries"):
        assert (getattr(batch, name) == getattr(ref, name)).all(), name
    assert batch.values == ref.values


def test_carries_change_the_deliveries_and_no_groups_is_the_model_as_it_was():
    config = _short(ticks=200)
    plain = replace(config, carries=())
    assert plain == replace(arena_task(FORAGING, 6, balanced=True, ticks=200), trials=Trials(200, 5)).config(
        "paper"
    )
    assert "carries" in config.as_dict() and "carries" not in plain.as_dict()  # files as before carries
    assert config_from_dict(config.as_dict()) == config
    request = [EvaluationRequest(FORAGER, 3, 5)]
    (grouped,) = BatchEvaluator(config).evaluate(request)
    (free,) = BatchEvaluator(plain).evaluate(request)
    assert grouped.fitness != free.fitness
    # Every group carrying every kind is no group at all.
    everything = (("food", "food2", "food3"),) * 3
    (full,) = BatchEvaluator(replace(config, carries=everything)).evaluate(request)
    assert full == free


def test_the_registered_carriers_task_its_unseen_twin_and_the_arena_command():
    task = task_named(CARRIERS)
    assert task.robots.carries == GROUPS and task.trials.ticks == 600 and task.trial_seconds == 300.0
    assert task.objectives[-1] == "foraging_balanced" and "foraging" in task.objectives
    balanced = task_named("multifood-arena6-balanced")
    assert replace(task, name=balanced.name, description=balanced.description) == replace(
        balanced, trials=Trials(ticks=600), robots=replace(balanced.robots, carries=GROUPS)
    )
    twin = unseen_twin(CARRIERS)
    assert twin.robots.carries == GROUPS and twin.regions != task.regions
    assert task_from_yaml(task_to_yaml(task)) == task
    assert world_parameters(task.config())["carries"] == '[["food"],["food2"],["food3"]]'
    assert carries_from_text(carries_to_text(GROUPS)) == GROUPS and carries_to_text(()) == ""
    shown = subprocess.run(
        [sys.executable, "-m", "swarm_sim.tasks.cli", "arena", "6", "--balanced", "--ticks", "600",
         "--carries", "food;food2;food3"],
        capture_output=True, text=True, check=True,
    ).stdout  # fmt: skip
    made = task_from_yaml(shown)
    assert made.robots.carries == GROUPS and made.config() == task.config()
    scouts = subprocess.run(
        [sys.executable, "-m", "swarm_sim.tasks.cli", "arena", "6", "--carries", "food,food3;-"],
        capture_output=True, text=True, check=True,
    ).stdout  # fmt: skip
    assert task_from_yaml(scouts).robots.carries == (("food", "food3"), ())
    listed = subprocess.run(
        [sys.executable, "-m", "swarm_sim.tasks.cli", "list"], capture_output=True, text=True, check=True
    ).stdout
    assert f"{CARRIERS}: 300 s trials, 9 robots, 3 robot groups carrying only some food kinds" in listed


@pytest.mark.parametrize(
    ("carries", "says"),
    [
        (
            [["food"], ["food4"]],
            r"robots\.carries\[1\]: 'food4' is not a food kind; expected among food, food2",
        ),
        ([["nest"]], r"robots\.carries\[0\]: 'nest' is not a food kind"),
        ([["food"]] * 10, r"robots\.carries has 10 robot groups, more than the 9 robots"),
        ("food", r"robots\.carries must be a list, got 'food'"),
        (["food", "food2"], r"robots\.carries\[0\] must be a list, got 'food'"),
        ([["food", "food"]], r"robots\.carries\[0\] names a food kind twice"),
    ],
)
def test_bad_carries_in_a_task_file_are_refused_in_one_line(carries, says):
    text = task_to_yaml(task_named("multifood-arena6"))
    assert "carries: []" in text
    text = text.replace("carries: []", f"carries: {carries!r}".replace("'", '"'))
    with pytest.raises(TaskError, match=says) as error:
        task_from_yaml(text)
    assert "\n" not in str(error.value)


def test_bad_carries_are_refused_by_name():
    with pytest.raises(
        TaskError, match=r"robots\.carries\[0\]: the arena has no food2 \(its food kinds: food\)"
    ):
        replace(FORAGING, robots=replace(FORAGING.robots, carries=(("food2",),)))
    with pytest.raises(ConfigError, match="carries must be a list of robot groups"):
        Config(carries=["food"])  # type: ignore[arg-type]  # the wrong type is what is refused
    with pytest.raises(ConfigError, match=r"carries\[0\] must be a list of food kinds"):
        Config(carries=("food",))  # type: ignore[arg-type]  # the wrong type is what is refused
    with pytest.raises(ConfigError, match="carries has 22 robot groups; at most 21"):
        Config(n_robots=30, start_half=2000.0, carries=((),) * 22)
    with pytest.raises(ConfigError, match="carries must be a JSON list of lists of food kinds"):
        carries_from_text('["food"]')
    with pytest.raises(ConfigError, match="carries must be JSON"):
        carries_from_text("[[food]]")
