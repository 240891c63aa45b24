"""The node graph's logic without ROS: the lockstep world driven by footbot controllers reproduces the
reference road exactly, and refuses misuse clearly."""

import numpy as np
import pytest

from bt_controller.random_trees import random_trees
from bt_controller.tree import parse
from swarm_sim.lockstep import LockstepTrial, RobotAnswer, action_of_wheels, run_with_controllers
from swarm_sim.reference_road import run_trial

TREES = [
    "forward",
    "sel(seq(in_nest, stop), forward)",
    "prob(forward_left, seq(food_left, forward), reverse)",
    *random_trees(seed=11, count=5),
]


@pytest.mark.parametrize("text", TREES)
def test_controllers_in_lockstep_reproduce_the_reference_road(text):
    tree = parse(text)
    for trial in (0, 1):
        graph_like = run_with_controllers(tree, 5, trial)
        reference = run_trial(tree, 5, trial)
        assert graph_like.values == reference.values
        assert np.array_equal(graph_like.end_poses, reference.end_poses)


def test_on_step_sees_every_sensing_step_once():
    steps = []
    run_with_controllers(parse("forward"), 1, 0, on_step=lambda world: steps.append(world.step))
    assert steps == list(range(176))


def test_wheels_map_to_actions_and_others_are_refused():
    assert action_of_wheels(0.0, 1.0) == 2
    assert action_of_wheels(-1, -1) == 4
    with pytest.raises(ValueError, match=r"not a footbot action"):
        action_of_wheels(0.5, 1.0)


def test_advance_checks_its_answers():
    world = LockstepTrial(0, 0)
    with pytest.raises(ValueError, match="expected 9 answers"):
        world.advance([RobotAnswer(0, (0.0, 0.0), (0.0, 0.0, 0.0))])
    with pytest.raises(RuntimeError, match="not finished"):
        world.record(np.zeros((9, 8), dtype=np.int64))
