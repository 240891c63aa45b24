"""The node graph's logic without ROS: the lockstep chain driven by footbot controllers, its timeline, and
clear refusals of misuse."""

import numpy as np
import pytest

from bt_controller.language import parse
from swarm_sim.model import Config
from swarm_sim.roads import (
    LockstepChain,
    RobotAnswer,
    action_of_wheels,
    run_chain_with_controllers,
    run_with_controllers,
)


@pytest.mark.parametrize("profile", ["paper", "clean"])
def test_trial_k_alone_is_trial_k_of_its_chain(profile):
    config = Config(profile=profile)
    tree = parse("sel(seq(robot_left, forward_left), seq(nest_right, forward_right), forward)")
    chain = run_chain_with_controllers(tree, 5, 1, config.chain_length, config)
    position = config.chain_length - 1
    alone = run_with_controllers(tree, 5, config.chain_length + position, config)
    assert alone.trial == chain[-1].trial == config.chain_length + position
    assert alone.values == chain[-1].values
    assert np.array_equal(alone.end_poses, chain[-1].end_poses)


def test_on_step_sees_every_step_of_the_chain_once():
    steps = []
    run_chain_with_controllers(parse("forward"), 1, 0, 2, on_step=lambda sim: steps.append(sim.step))
    assert steps == list(range(1, 321))
    steps.clear()
    run_with_controllers(
        parse("forward"), 1, 0, Config(profile="clean"), on_step=lambda s: steps.append(s.step)
    )
    assert steps == list(range(1, 177))


def test_a_teleport_moves_every_robot_at_a_trials_first_step():
    starts = []
    records = run_chain_with_controllers(parse("stop"), 2, 0, 2)
    for record in records:
        starts.append(record.start_poses)
    # A stopped swarm ends a trial where it started; the next trial starts elsewhere.
    assert np.array_equal(records[0].end_poses, records[0].start_poses)
    assert not np.array_equal(records[1].start_poses, records[0].end_poses)


def test_wheels_map_to_actions_and_others_are_refused():
    assert action_of_wheels(0.0, 1.0) == 2
    assert action_of_wheels(-1, -1) == 4
    with pytest.raises(ValueError, match=r"not a footbot action"):
        action_of_wheels(0.5, 1.0)


def test_advance_checks_its_answers():
    sim = LockstepChain(0, 0, 1)
    with pytest.raises(ValueError, match="expected 9 answers"):
        sim.advance([RobotAnswer(0, (0.0, 0.0), (0.0, 0.0, 0.0))])
    with pytest.raises(ValueError, match="a chain has 1 to 5 trials"):
        LockstepChain(0, 0, 6)
