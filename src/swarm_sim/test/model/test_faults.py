"""Per-robot faults: each kind changes exactly the robots it names, the batch kernels and the reference road
agree on it to the bit, a rate draws the same faulty robots on every road, and bad faults are refused in one
line."""

import json
from dataclasses import replace

import numpy as np
import pytest

from bt_controller.language import parse
from swarm_sim.core import robot_faults, setup_chain
from swarm_sim.errors import ConditionError, ConfigError
from swarm_sim.evaluation import BatchEvaluator, EvaluationRequest
from swarm_sim.model import FAULT_KINDS, Config, apply_conditions, condition_texts
from swarm_sim.roads import record_trial, record_trial_reference, reference_road, run_with_controllers

SHORT = Config(ticks=12)
"""Short trials keep these checks quick; faults do not depend on a trial's length."""
TREE = (
    "sel(seq(on_food, stop), seq(food_left, forward_left), seq(food_right, forward_right), "
    "sel(seq(robot_left, forward_left), forward))"
)
"""A tree that reads the ground, the food's side and the nearest robot's side, so every fault shows."""
NAMED = (1, 4)
"""The faulty robots of the kind-by-kind tests (under seed 0, robot 4 starts in the nest)."""


def _faulty(kind: str, config: Config = SHORT) -> Config:
    return replace(config, fault_robots=tuple((robot, kind) for robot in NAMED))


def _run(config: Config, seed: int = 0, trial: int = 0) -> tuple[np.ndarray, list]:
    """Every step's poses and readings of ``trial`` through the reference road (the simulator node's code)."""
    poses, readings = [], []

    def on_step(world):
        if world.trial == trial:
            poses.append(world.poses())
            readings.append(world.readings())

    run_with_controllers(parse(TREE), seed, trial, config, on_step)
    return np.array(poses), readings


def _reading_differs(a, b) -> bool:
    return not (
        np.array_equal(a.ground, b.ground)
        and np.array_equal(a.senders, b.senders)
        and np.array_equal(a.ranges, b.ranges)
        and np.array_equal(a.bearings, b.bearings)
        and np.array_equal(a.values, b.values)
    )


@pytest.mark.parametrize("kind", FAULT_KINDS)
def test_a_fault_changes_the_robots_it_names_first_and_only_them(kind):
    """Without and with the fault, the world is the same up to a first step where it differs; there only the
    named robots differ (a wheel: their poses; a sensor: their readings; a disruptive robot: what its
    messages carry to the others). Later the others react to them: that is interaction, not the fault."""
    plain_poses, plain = _run(SHORT)
    poses, faulty = _run(_faulty(kind))
    steps = len(plain)
    first = next(
        s
        for s in range(steps)
        if not np.array_equal(plain_poses[s], poses[s])
        or any(_reading_differs(a, b) for a, b in zip(plain[s], faulty[s], strict=True))
    )
    moved = {i for i in range(SHORT.n_robots) if not np.array_equal(plain_poses[first, i], poses[first, i])}
    read = {i for i in range(SHORT.n_robots) if _reading_differs(plain[first][i], faulty[first][i])}
    if kind.startswith("wheel"):
        assert moved and moved <= set(NAMED)
    elif kind == "disruptive":
        assert not moved and read
        for i in read:  # what changed is what the named robots' messages carry, nothing else
            a, b = plain[first][i], faulty[first][i]
            assert np.array_equal(a.senders, b.senders) and np.array_equal(a.bearings, b.bearings)
            for m, sender in enumerate(a.senders):
                if sender in NAMED:
                    assert (b.values[m] == 0.0).all()
                else:
                    assert np.array_equal(a.values[m], b.values[m])
    else:
        assert not moved and read and read <= set(NAMED)


@pytest.mark.parametrize("kind", FAULT_KINDS)
def test_the_batch_kernels_record_a_faulty_trial_as_the_reference_road_does(kind):
    config = _faulty(kind)
    kernel, reference = record_trial(TREE, 5, 1, config), record_trial_reference(TREE, 5, 1, config)
    for name in ("poses", "actions", "ticks", "smoothed", "ground", "initial", "carrying", "deliveries"):
        assert np.array_equal(getattr(kernel, name), getattr(reference, name)), name
    assert all(np.array_equal(a, b) for a, b in zip(kernel.links, reference.links, strict=True))
    assert kernel.values == reference.values
    plain = record_trial(TREE, 5, 1, SHORT)
    assert not (np.array_equal(plain.poses, kernel.poses) and np.array_equal(plain.smoothed, kernel.smoothed))


def test_a_rate_draws_the_same_faulty_robots_for_a_seed_on_every_road_and_chain():
    config, record = apply_conditions(["faults=0.5:rab-deaf,wheel-reversed"], SHORT)
    assert record == {"faults": [0.5, "rab-deaf,wheel-reversed"]}
    assert condition_texts(record) == ["faults=0.5:rab-deaf,wheel-reversed"]
    drawn = [setup_chain(seed, 0, config).faults for seed in range(20)]
    assert all((setup_chain(seed, 3, config).faults == drawn[seed]).all() for seed in range(20))
    codes = np.concatenate(drawn)
    deaf, reversed_ = FAULT_KINDS.index("rab-deaf") + 1, FAULT_KINDS.index("wheel-reversed") + 1
    assert set(codes.tolist()) == {0, deaf, reversed_}
    assert 0.3 < (codes > 0).mean() < 0.7
    every, _ = apply_conditions(["faults=1"], SHORT)
    assert set(np.concatenate([setup_chain(s, 0, every).faults for s in range(20)]).tolist()) == set(
        range(1, len(FAULT_KINDS) + 1)
    )
    # The same seed, the same values on the batch road and the reference road.
    ((result, _),) = BatchEvaluator(config).evaluate_trials([EvaluationRequest(TREE, 3, 2)])
    values, _ = reference_road.evaluate(parse(TREE), 3, 2, config)
    assert result.fitness + result.descriptors == values
    assert BatchEvaluator(SHORT).evaluate([EvaluationRequest(TREE, 3, 2)])[0].fitness != result.fitness


def test_a_fault_file_names_robots_and_kinds(tmp_path):
    path = tmp_path / "faults.json"
    path.write_text(json.dumps({"4": "disruptive", "0": "wheel-dead"}))
    config, record = apply_conditions([f"faults={path}"], SHORT)
    assert config.fault_robots == ((0, "wheel-dead"), (4, "disruptive"))
    assert record == {"faults": str(path)}
    assert setup_chain(1, 0, config).faults.tolist() == [6, 0, 0, 0, 9, 0, 0, 0, 0]
    assert robot_faults(config, np.uint64(123)).tolist() == [6, 0, 0, 0, 9, 0, 0, 0, 0]  # every seed
    yaml_file = tmp_path / "faults.yaml"
    yaml_file.write_text("2: rab-mirrored\n")
    assert apply_conditions([f"faults={yaml_file}"], SHORT)[0].fault_robots == ((2, "rab-mirrored"),)
    assert setup_chain(1, 0, config).gains[0].tolist() == [0.0, setup_chain(1, 0, SHORT).gains[0, 1]]


@pytest.mark.parametrize(
    ("text", "says"),
    [
        ("faults=1.5", "condition faults=1.5: expected RATE, a probability in [0, 1], got '1.5'"),
        ("faults=0.2:wheel-broken", "unknown fault kind 'wheel-broken'; expected one of ground-stuck,"),
        ("faults=no.json", "expected RATE, RATE:KIND,KIND or a fault file (JSON or YAML), and there is no"),
        ("faults={path}", "condition faults={path}: a faulty robot must be a robot id in [0, 8], got 12"),
    ],
)
def test_bad_faults_are_refused_in_one_line(text, says, tmp_path):
    path = tmp_path / "bad.yaml"
    path.write_text("12: wheel-dead\n")
    with pytest.raises(ConditionError) as caught:
        apply_conditions([text.format(path=path)], SHORT)
    message = str(caught.value)
    assert says.format(path=path) in message and "\n" not in message


def test_bad_fault_settings_are_refused_by_name():
    with pytest.raises(ConfigError, match="fault_rate must be a probability"):
        Config(fault_rate=-0.1)
    with pytest.raises(ConfigError, match="not both"):
        Config(fault_rate=0.1, fault_robots=((0, "rab-deaf"),))
    with pytest.raises(ConfigError, match="robot 3 is given two faults"):
        Config(fault_robots=((3, "rab-deaf"), (3, "wheel-dead")))


GROUND_KINDS = ("ground-stuck", "ground-inverted")
ALL_ROBOTS = tuple(range(SHORT.n_robots))


def _every_robot(kind: str, config: Config = SHORT) -> Config:
    return replace(config, fault_robots=tuple((robot, kind) for robot in ALL_ROBOTS))


@pytest.mark.parametrize("kind", GROUND_KINDS)
@pytest.mark.parametrize("road", [record_trial, record_trial_reference])
def test_a_faulty_ground_sensor_makes_no_food_where_the_robot_stands_still(kind, road):
    """Robots that never move deliver nothing, whatever their ground sensors read: a robot off food and out of
    the nest that reads the nest and food (ground-inverted) neither picks up nor delivers there."""
    plain = road("stop", 2, 0, SHORT)
    faulty = road("stop", 2, 0, _every_robot(kind))
    assert plain.deliveries.sum() == 0 and faulty.deliveries.sum() == 0
    assert np.array_equal(plain.carrying, faulty.carrying)
    assert not np.array_equal(plain.ground, faulty.ground)  # the sensors do read falsely
    if kind == "ground-inverted":  # some robot stands off food and out of the nest, and reads both
        assert (faulty.ground[-1].all(axis=1) & ~plain.ground[-1].any(axis=1)).any()
    else:
        assert not faulty.ground.any()


@pytest.mark.parametrize("kind", GROUND_KINDS)
@pytest.mark.parametrize("seed", [0, 3])
def test_a_faulty_robot_carries_and_delivers_as_it_would_without_the_fault(kind, seed):
    """Along a path that does not depend on what the robots read (forward), the carrying flags and the
    deliveries of robots with a faulty ground sensor are those of the same robots without it, on both roads;
    only what they read differs."""
    config = replace(SHORT, ticks=60)
    plain = record_trial("forward", seed, 1, config)
    assert plain.carrying.any()  # some robot does pick up food on the way
    for road in (record_trial, record_trial_reference):
        faulty = road("forward", seed, 1, _every_robot(kind, config))
        assert np.array_equal(plain.poses, faulty.poses)
        assert np.array_equal(plain.carrying, faulty.carrying)
        assert np.array_equal(plain.deliveries, faulty.deliveries)
        assert not np.array_equal(plain.ground, faulty.ground)


def test_a_faulty_robot_broadcasts_what_it_reads_and_knows_truly_whether_it_carries():
    """At a chain's first step a ground-inverted robot standing in the nest reads itself on food and out of
    the nest: it broadcasts so (the cap for the nest, 0 for food: it says what it believes), while its
    carrying flag, which its got_food condition reads, stays false (it is not on food). The simulator tells it
    where it stands (``Readings.footing``) and tells a sound robot nothing more."""
    config = replace(SHORT, fault_robots=((4, "ground-inverted"),))
    readings, outcomes = [], []

    def on_step(world):
        if not readings:
            readings.append(world.readings())

    def on_outcomes(world, answers):
        if not outcomes:
            outcomes.append(answers)

    run_with_controllers(parse("stop"), 0, 0, config, on_step, on_outcomes=on_outcomes)
    faulty, sound = readings[0][4], readings[0][3]
    assert faulty.footing is not None and faulty.footing.tolist() == [True, False]  # it stands in the nest
    assert faulty.ground.tolist() == [False, True] and sound.footing is None
    first = outcomes[0][4]
    assert first.broadcast == (SHORT.estimate_cap, 0.0)
    assert first.carrying == (False,) and first.deliveries == (0,)
