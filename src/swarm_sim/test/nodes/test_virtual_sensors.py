"""The virtual-sensor bridge's core (issue 40): poses as the simulator publishes them (metres, quaternions)
and the robots' broadcasts give every robot the readings the simulator gave it, and controllers fed those
readings give the same commands, step for step through a whole trial's chain."""

import numpy as np
import pytest
from builtin_interfaces.msg import Time

from bt_controller.language import parse
from bt_controller.robot import FootbotController
from swarm_sim.model import DEFAULT
from swarm_sim.nodes import visualisation
from swarm_sim.nodes.virtual_sensors import Delivery, VirtualSensors, heading_of
from swarm_sim.roads import run_with_controllers

TREE = "sel(seq(robot_left, forward_left), prob(forward, reverse_right), seq(in_nest, stop))"
SEED, TRIAL = 4, 1


def test_a_pose_in_metres_is_the_pose_in_millimetres():
    bridge = VirtualSensors(DEFAULT)
    pose = visualisation.pose_stamped(Time(), 1234.5, -987.25, -2.5).pose
    bridge.set_pose_in_metres(3, pose.position.x, pose.position.y, pose.orientation.z, pose.orientation.w)
    assert bridge.poses[3] == pytest.approx([1234.5, -987.25, -2.5], abs=1e-9)
    assert heading_of(0.0, 1.0) == 0.0


def test_the_bridge_refuses_to_sense_before_every_robot_has_a_pose():
    bridge = VirtualSensors(DEFAULT)
    for i in range(DEFAULT.n_robots - 1):
        bridge.set_pose(i, 100.0 * i, 0.0, 0.0)
    with pytest.raises(ValueError, match="no pose yet of robot 8"):
        bridge.sense(1)


@pytest.mark.parametrize("published", [True, False], ids=["poses in metres", "poses in millimetres"])
def test_replayed_poses_give_the_simulators_readings_and_the_controllers_commands(published):
    bridge = VirtualSensors(DEFAULT, SEED, TRIAL)
    tree = parse(TREE)
    shadows: list[FootbotController] = []
    shadow_outcomes: list = []
    steps = []
    worst = {"range": 0.0, "bearing": 0.0}

    def on_step(world):
        if not shadows:  # controllers fed the bridge's readings, keyed as the graph's
            for key in world.setup.tree_keys:
                shadow = FootbotController()
                shadow.load(tree)
                shadow.start_chain(int(key), DEFAULT.timeline, DEFAULT.perception, world.trials)
                shadows.append(shadow)
        for i, (x, y, theta) in enumerate(world.poses().tolist()):
            if published:  # what <robot>/pose carries
                pose = visualisation.pose_stamped(Time(), x, y, theta).pose
                q = pose.orientation
                bridge.set_pose_in_metres(i, pose.position.x, pose.position.y, q.z, q.w)
            else:  # what swarm_state carries
                bridge.set_pose(i, x, y, theta)
        sensed = bridge.sense(world.step)
        for got, want in zip(sensed, world.readings(), strict=True):
            assert (got.in_nest, got.on_food) == (want.in_nest, want.on_food), world.step
            assert got.senders.tolist() == want.senders.tolist(), (
                world.step
            )  # the same losses, the same range
            assert got.values.tolist() == want.values.tolist()
            if published:
                worst["range"] = max(
                    worst["range"], float(np.max(np.abs(got.ranges - want.ranges), initial=0))
                )
                bearing = np.abs(np.remainder(got.bearings - want.bearings + np.pi, 2 * np.pi) - np.pi)
                worst["bearing"] = max(worst["bearing"], float(np.max(bearing, initial=0)))
            else:
                assert (
                    got.ranges.tolist() == want.ranges.tolist()
                    and got.bearings.tolist() == want.bearings.tolist()
                )
        shadow_outcomes[:] = [s.on_step(world.step, r) for s, r in zip(shadows, sensed, strict=True)]
        steps.append(world.step)

    def on_answers(world, answers):
        for i, answer in enumerate(answers):
            bridge.set_broadcast(i, *answer.broadcast)

    def on_outcomes(world, outcomes):
        for shadow, outcome in zip(shadow_outcomes, outcomes, strict=True):
            assert shadow.action == outcome.action, world.step  # the same command
            if published:  # a density or estimate from a range, a rounding apart
                assert shadow.broadcast + shadow.smoothed == pytest.approx(
                    outcome.broadcast + outcome.smoothed, rel=1e-12, abs=1e-12
                ), world.step
            else:
                assert (shadow.broadcast, shadow.smoothed) == (outcome.broadcast, outcome.smoothed), (
                    world.step
                )

    run_with_controllers(tree, SEED, TRIAL, on_step=on_step, on_answers=on_answers, on_outcomes=on_outcomes)
    assert steps == list(range(1, (TRIAL + 1) * 160 + 1))
    assert worst["range"] < 1e-9 and worst["bearing"] < 1e-12, worst  # mm; radians


def test_a_perfect_link_delivers_everything_at_once_in_order():
    link = Delivery()
    for item in "abc":
        link.send(5, item)
    assert link.due(4) == [] and link.due(5) == ["a", "b", "c"] and link.due(6) == []


def test_a_lossy_late_link_loses_about_its_share_and_holds_the_rest_back_within_its_delay():
    link = Delivery(loss=0.25, delay=3, seed=1)
    arrived = {}
    for period in range(1, 2001):
        link.send(period, period)
        for item in link.due(period):
            arrived[item] = period
    assert 0.22 < link.lost / 2000 < 0.28
    assert link.lost + len(arrived) + len(link.pending) == 2000
    held = [arrived[item] - item for item in arrived]
    assert set(held) == {0, 1, 2, 3}  # on time, or up to three periods late
    assert any(a > b for a, b in zip(list(arrived), list(arrived)[1:], strict=False))  # some overtaken


@pytest.mark.parametrize(("loss", "delay"), [(-0.1, 0), (1.5, 0), (0.0, -1)])
def test_a_link_refuses_a_loss_that_is_no_probability_or_a_negative_delay(loss, delay):
    with pytest.raises(ValueError, match=r"loss must be|delay must be"):
        Delivery(loss, delay)


def test_clearing_a_link_drops_what_it_holds_back_and_says_how_many():
    link = Delivery(delay=2, seed=1)
    for period in (1, 2, 3):
        link.send(period, period)
    held = len(link.pending) - len(link.due(3))
    assert link.clear() == held and link.due(10) == []
    assert link.clear() == 0
