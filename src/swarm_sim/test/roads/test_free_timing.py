"""The free-stepping simulator's answers (swarm_sim.roads.free_timing), without ROS: each robot's latest
answer, statuses credited at tick steps, deliveries counted per trial, and a free-run chain the world
accepts."""

from __future__ import annotations

import pytest

from bt_controller.language import STOP
from swarm_sim.model import DEFAULT
from swarm_sim.roads import FreeAnswers, LockstepChain, RobotAnswer

CAP = DEFAULT.params().estimate_cap


def answer(action: int = 1, deliveries: int = 0, nest: float = 10.0) -> RobotAnswer:
    return RobotAnswer(
        action=action, broadcast=(nest, 20.0), smoothed=(1.0, 2.0, 0.5), condition_ticks=7, started=3,
        deliveries=(deliveries,),
    )  # fmt: skip


def test_a_robot_that_never_answered_is_stopped_and_broadcasts_the_cap() -> None:
    free = FreeAnswers(2, CAP)
    free.answer(1, answer())
    first, second = free.answers(ticks=False)
    assert first == RobotAnswer(action=STOP, broadcast=(CAP, CAP), smoothed=(0.0, 0.0, 0.0))
    assert second.action == 1 and second.broadcast == (10.0, 20.0)


def test_the_latest_answer_wins_and_is_kept_until_a_newer_one() -> None:
    free = FreeAnswers(1, CAP)
    free.answer(0, answer(action=1, nest=5.0))
    free.answer(0, answer(action=4, nest=6.0))
    for _ in range(3):  # no new answer: the same one, step after step
        (used,) = free.answers(ticks=False)
        assert used.action == 4 and used.broadcast == (6.0, 20.0)


def test_statuses_count_at_the_next_tick_step_only_once() -> None:
    free = FreeAnswers(1, CAP)
    free.answer(0, answer())
    (plain,) = free.answers(ticks=False)
    assert (plain.condition_ticks, plain.started) == (0, -1)  # the answer's own fields are never used
    free.status(0, condition_ticks=3, started=2)
    free.status(0, condition_ticks=4, started=-1)
    (off_tick,) = free.answers(ticks=False)
    assert (off_tick.condition_ticks, off_tick.started) == (0, -1)
    (tick,) = free.answers(ticks=True)
    assert (tick.condition_ticks, tick.started) == (7, 2)
    (next_tick,) = free.answers(ticks=True)
    assert (next_tick.condition_ticks, next_tick.started) == (0, -1)


def test_deliveries_count_from_each_trials_first_step() -> None:
    free = FreeAnswers(1, CAP)
    free.answer(0, answer(deliveries=2))
    assert free.answers(ticks=False)[0].deliveries == (2,)
    free.begin_trial()
    assert free.answers(ticks=False)[0].deliveries == (0,)
    free.answer(0, answer(deliveries=5))
    assert free.answers(ticks=False)[0].deliveries == (3,)
    free.start_chain()  # a new chain forgets everything
    assert free.answers(ticks=False)[0] == RobotAnswer(action=STOP, broadcast=(CAP, CAP), smoothed=(0.0,) * 3)


def test_no_robots_is_refused() -> None:
    with pytest.raises(ValueError, match="at least one robot"):
        FreeAnswers(0, CAP)


def test_a_chain_advanced_by_free_answers_finishes_with_a_record() -> None:
    world = LockstepChain(3, 0, 1, DEFAULT)
    free = FreeAnswers(DEFAULT.n_robots, CAP)
    free.begin_trial()
    record = None
    while not world.done:
        if world.step == 40:  # every robot drives forward from here, ticking once
            for robot in range(DEFAULT.n_robots):
                free.answer(robot, answer(action=1))
                free.status(robot, 1, 1)
        record = world.advance(free.answers(world.ticks_now()))
    assert record is not None and record.trial == 0
    assert (record.end_poses != record.start_poses).any()  # the robots moved once they answered
