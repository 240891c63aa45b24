"""Changes to a running chain, as live adaptation makes them: faults injected at a step
(``LockstepChain.schedule_faults``, what the simulator node's ``inject_faults`` runs) and a tree swapped into
a controller at a step (``FootbotController.swap_at``, what ``load_tree`` with ``from_step`` runs)."""

from dataclasses import replace

import numpy as np
import pytest

from bt_controller.language import ACTIONS, parse
from bt_controller.robot import FootbotController
from swarm_sim.model import Config, fault_kinds_of, parse_fault_pairs
from swarm_sim.roads import LockstepChain, RobotAnswer

SHORT = Config(ticks=12)
TREE = "sel(seq(on_food, stop), seq(food_left, forward_left), seq(food_right, forward_right), forward)"


def _run(config, schedule=None, swap=None, seed=0):
    """Every step's poses and each robot's action through the in-process lockstep road; ``schedule``:
    (step, config) faults scheduled at the chain's start; ``swap``: (robot, step, tree text)."""
    sim = LockstepChain(seed, 0, 1, config)
    if schedule is not None:
        assert sim.schedule_faults(schedule[1], schedule[0]) == schedule[0]
    controllers = []
    for key in sim.setup.tree_keys:
        controller = FootbotController()
        controller.load(parse(TREE))
        controller.start_chain(int(key), config.timeline, config.perception, 1)
        controllers.append(controller)
    if swap is not None:
        controllers[swap[0]].swap_at(parse(swap[2]), swap[1])
    poses, actions, ticks = [], [], []
    while not sim.done:
        poses.append(sim.poses())
        outcomes = [c.on_step(sim.step, r) for c, r in zip(controllers, sim.readings(), strict=True)]
        actions.append([o.action for o in outcomes])
        ticks.append([o.tick.tick if o.tick is not None else -1 for o in outcomes])
        answers = [
            RobotAnswer(
                o.action,
                o.broadcast,
                o.smoothed,
                o.tick.condition_ticks if o.tick is not None else 0,
                o.tick.started if o.tick is not None else -1,
                o.carrying,
                o.deliveries,
            )
            for o in outcomes
        ]
        sim.advance(answers)
    return np.array(poses), np.array(actions), np.array(ticks), sim


def test_faults_injected_at_a_step_leave_the_world_unchanged_before_it_and_strike_from_it():
    faulty = replace(SHORT, fault_robots=((2, "wheel-reversed"), (5, "rab-deaf")))
    clean, _, _, _ = _run(SHORT)
    injected, _, _, sim = _run(SHORT, schedule=(20, faulty))
    assert np.array_equal(injected[:19], clean[:19])  # the poses of steps 1..19
    assert not np.array_equal(injected[19], clean[19])  # step 20 moves the robots with the faulty wheel
    assert [(step, fault_kinds_of(list(codes))) for step, codes in sim.fault_changes] == [
        (20, ["", "", "wheel-reversed", "", "", "rab-deaf", "", "", ""])
    ]
    assert sim.config == faulty


def test_wheel_faults_injected_at_the_second_step_equal_faults_given_from_the_start():
    """The robots stand still at a trial's first step, so a wheel fault from step 2 is one from the start."""
    faulty = replace(SHORT, fault_robots=((1, "wheel-dead"), (4, "wheel-weak")))
    given, _, _, _ = _run(faulty)
    injected, _, _, _ = _run(SHORT, schedule=(2, faulty))
    assert np.array_equal(given, injected)


def test_injected_faults_may_change_the_faults_only():
    sim = LockstepChain(0, 0, 1, SHORT)
    with pytest.raises(ValueError, match="faults only"):
        sim.schedule_faults(replace(SHORT, delivery_probability=0.5), 5)
    assert sim.schedule_faults(replace(SHORT, fault_robots=((0, "wheel-dead"),)), 0) == 2  # begun: the next


def test_fault_pairs_are_read_and_bad_ones_refused_in_one_line():
    assert parse_fault_pairs("4:disruptive 0:wheel-dead", 9) == ((0, "wheel-dead"), (4, "disruptive"))
    assert parse_fault_pairs("", 9) == ()
    for text, said in (
        ("0-wheel-dead", "ROBOT:KIND"),
        ("x:wheel-dead", "ROBOT:KIND"),
        ("9:wheel-dead", "robot id in \\[0, 8\\]"),
        ("0:wheel-gone", "unknown fault kind"),
        ("0:wheel-dead 0:rab-deaf", "two faults"),
    ):
        with pytest.raises(Exception, match=said):
            parse_fault_pairs(text, 9)


def test_a_tree_swapped_in_at_a_step_runs_from_its_first_tick_there_and_changes_nothing_before():
    _, before, ticks_before, _ = _run(SHORT)
    _, after, ticks_after, _ = _run(SHORT, swap=(3, 17, "reverse"))
    assert np.array_equal(after[:16], before[:16])  # steps 1..16
    ticked = [k for k in range(16, len(after)) if ticks_after[k, 3] >= 0]
    assert ticked and all(after[k, 3] == ACTIONS.index("reverse") for k in range(ticked[0], len(after)))
    assert np.array_equal(ticks_after, ticks_before)  # the ticks are numbered on through the swap


def test_a_swap_needs_a_chain_under_way_and_a_step_not_answered_yet():
    controller = FootbotController()
    controller.load(parse("forward"))
    with pytest.raises(ValueError, match="no chain is under way"):
        controller.swap_at(parse("reverse"), 5)
    controller.start_chain(1, SHORT.timeline, SHORT.perception, 1)
    with pytest.raises(ValueError, match="next step is 1"):
        controller.swap_at(parse("reverse"), 0)
    with pytest.raises(ValueError, match="its last"):
        controller.swap_at(parse("reverse"), 10_000)
