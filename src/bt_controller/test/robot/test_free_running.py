"""The free-running controller's policy, without ROS: lost, late and duplicated readings never stop it from
ticking; a sensing timeout stops the robot without ticking the tree, and it ticks again when readings come
back."""

import numpy as np
import pytest

from bt_controller.language.tree import parse
from bt_controller.language.vocabulary import ACTION_WHEELS, ACTIONS, STOP
from bt_controller.model_settings import PerceptionParams
from bt_controller.robot.free_running import FreeRunningController, empty_readings

FORWARD = ACTIONS.index("forward")


def controller(tree="forward", timeout=1.0):
    return FreeRunningController(parse(tree), 3, PerceptionParams(), timeout, now=0.0)


def offer(c, step, now, ground=True, rab=True, in_nest=False):
    if ground:
        c.offer_ground(step, (in_nest, False), now)
    if rab:
        c.offer_range_and_bearing(step, empty_readings(), now)


def test_lost_late_and_duplicated_readings_are_counted_and_the_tree_ticks_on_the_newest():
    c = controller("sel(seq(in_nest, stop), forward)")
    offer(c, 1, 0.1)
    offer(c, 2, 0.2)
    offer(c, 3, 0.3, rab=False)  # half of step 3: lost once a newer step completes
    offer(c, 5, 0.4)  # step 4 never sent
    offer(c, 5, 0.45)  # both readings of step 5 again
    offer(c, 4, 0.5)  # step 4 after all, too late
    offer(c, 7, 0.6, ground=False)
    offer(c, 6, 0.6, in_nest=True)  # 6 completes before 7 does: used
    offer(c, 7, 0.7, rab=False, in_nest=True)
    offer(c, 7, 0.7, rab=False)  # a second ground reading of step 7
    assert (c.counts.used, c.counts.lost, c.counts.late, c.counts.duplicated) == (5, 2, 2, 3)
    assert c.newest == 7
    outcome = c.tick(0.75)
    assert not outcome.timed_out and outcome.tick == 0 and outcome.step == 7
    assert outcome.action == STOP  # in_nest at step 7: the tree's seq(in_nest, stop)
    offer(c, 8, 0.8)
    assert c.tick(1.25).tick == 1  # the running stop finishes
    outcome = c.tick(1.5)  # no new reading since: the tree ticks on step 8's, out of the nest
    assert outcome.tick == 2 and outcome.step == 8
    assert outcome.action == FORWARD and outcome.wheels == ACTION_WHEELS[FORWARD]
    # the estimate window holds one sample per used step, as the model keeps it
    assert c.view.samples == 6


def test_a_sensing_timeout_stops_the_robot_keeps_the_tree_and_ticking_resumes_with_the_readings():
    c = controller(timeout=1.0)
    first = c.tick(0.5)  # nothing sensed yet: stopped, not yet timed out
    assert first.action == STOP and first.tick == -1 and not first.timed_out
    assert c.tick(1.5).timed_out  # nothing at all for 1.5 s
    offer(c, 1, 1.6)
    moving = c.tick(2.0)
    assert moving.action == FORWARD and moving.tick == 0 and not moving.timed_out
    stopped = c.tick(2.7)  # 1.1 s without a reading
    assert stopped.timed_out and stopped.action == STOP and stopped.wheels == ACTION_WHEELS[STOP]
    assert stopped.tick == -1 and stopped.silence == pytest.approx(1.1)
    assert c.robot.tick_index == 1  # the tree was not ticked while stopped
    offer(c, 9, 2.8)  # steps 2-8 never came
    again = c.tick(3.0)
    assert not again.timed_out and again.tick == 1 and again.action == FORWARD
    assert c.counts.lost == 7


def test_the_timeout_must_be_positive():
    with pytest.raises(ValueError, match="sensing_timeout must be positive"):
        controller(timeout=0.0)


def test_readings_arrays_reach_the_estimates():
    c = controller()
    readings = empty_readings()
    assert readings.senders.dtype == np.int64 and len(readings.ranges) == 0
    offer(c, 1, 0.0, in_nest=True)
    c.tick(0.1)
    assert c.view.smoothed()[0] == 0.0  # in the nest: the nest estimate is 0 mm


def test_a_clock_not_started_counts_the_timeout_from_the_first_tick():
    c = FreeRunningController(parse("forward"), 0, PerceptionParams(), 1.0, now=None)
    assert not c.tick(100.0).timed_out  # a simulated clock that started at 100 s: not 100 s of silence
    assert not c.tick(100.9).timed_out
    assert c.tick(101.1).timed_out


def test_a_faulty_ground_reading_is_perceived_and_food_follows_where_the_robot_stands():
    """A ground message with a footing (a faulty ground sensor): the tree reads the reading, while the robot
    picks up and delivers where it stands; a footing of the wrong size is refused by name."""
    c = controller("sel(seq(on_food, stop), forward)")
    c.offer_ground(1, (True, True), 0.1, footing=(False, False))  # reads nest and food, stands on neither
    c.offer_range_and_bearing(1, empty_readings(), 0.1)
    assert c.tick(0.15).action == STOP  # it perceives food
    assert c.view.carrying.tolist() == [False] and c.view.deliveries.tolist() == [0]
    c.offer_ground(2, (False, False), 0.2, footing=(False, True))  # on food, reads nothing
    c.offer_range_and_bearing(2, empty_readings(), 0.2)
    c.offer_ground(3, (False, True), 0.3, footing=(True, False))  # in the nest, reads food
    c.offer_range_and_bearing(3, empty_readings(), 0.3)
    assert c.view.carrying.tolist() == [False] and c.view.deliveries.tolist() == [1]
    with pytest.raises(ValueError, match="a footing of 3 regions, expected 2"):
        c.offer_ground(4, (False, False), 0.4, footing=(False, False, True))
