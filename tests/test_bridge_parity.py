"""Bridge parity (issue 40): the poses of a trial recorded through the node graph
(``footbot_<i>/pose``: metres and quaternions, as a tracker publishes them) and its robots' broadcasts
(``wheels``), replayed through the virtual-sensor bridge's core with the trial's seed, give every robot the
readings the bag holds, and controllers fed those readings answer with the commands the bag holds, at every
step (lockstep, the model's own losses)."""

import numpy as np
import pytest

from bt_controller.language import parse
from bt_controller.robot import FootbotController
from evolution_manager.graph.nodes.trial import run_recorded_trial
from evolution_manager.recording.bags import read_bag
from swarm_sim.core import setup_chain
from swarm_sim.model import DEFAULT
from swarm_sim.nodes.virtual_sensors import VirtualSensors

TREE = "sel(seq(robot_left, forward_left), prob(forward, reverse_right), seq(in_nest, stop))"
SEED = 6


def test_poses_replayed_from_a_trial_bag_give_its_readings_and_its_commands(tmp_path):
    bag = tmp_path / "trial.bag"
    run_recorded_trial(TREE, SEED, 0, bag, timeout=300.0)
    by_topic: dict[str, list] = {}
    for message in read_bag(bag):
        by_topic.setdefault(message.topic, []).append(message.message)
    robots = DEFAULT.n_robots
    steps = len(by_topic["/swarm_state"])
    assert steps == 160

    bridge = VirtualSensors(DEFAULT, SEED, 0)
    controllers = []
    for key in setup_chain(SEED, 0, DEFAULT).tree_keys:
        controller = FootbotController()
        controller.load(parse(TREE))
        controller.start_chain(int(key), DEFAULT.timeline, DEFAULT.perception, 1)
        controllers.append(controller)
    worst_range = worst_bearing = 0.0
    for k in range(steps):
        for i in range(robots):
            pose = by_topic[f"/footbot_{i}/pose"][k].pose
            bridge.set_pose_in_metres(
                i, pose.position.x, pose.position.y, pose.orientation.z, pose.orientation.w
            )
        sensed = bridge.sense(k + 1)
        for i, (got, controller) in enumerate(zip(sensed, controllers, strict=True)):
            ground = by_topic[f"/footbot_{i}/ground"][k]
            recorded = by_topic[f"/footbot_{i}/range_and_bearing"][k].readings
            assert ground.step == k + 1
            assert (got.in_nest, got.on_food) == (ground.in_nest, ground.on_food), (i, k + 1)
            assert got.senders.tolist() == [r.sender for r in recorded], (i, k + 1)  # the same losses
            assert got.values[:, 0].tolist() == [r.nest_estimate for r in recorded]
            assert got.values[:, 1].tolist() == [r.food_estimate for r in recorded]
            if len(recorded):
                worst_range = max(
                    worst_range, float(np.max(np.abs(got.ranges - [r.range for r in recorded])))
                )
                turn = got.bearings - [r.bearing for r in recorded]
                worst_bearing = max(
                    worst_bearing, float(np.max(np.abs(np.remainder(turn + np.pi, 2 * np.pi) - np.pi)))
                )
            answer = controller.on_step(k + 1, got)
            wheels = by_topic[f"/footbot_{i}/wheels"][k]
            assert answer.action == wheels.action, (i, k + 1)  # the same command
            assert answer.broadcast == pytest.approx((wheels.nest_estimate, wheels.food_estimate), rel=1e-12)
            bridge.set_broadcast(
                i, wheels.nest_estimate, wheels.food_estimate
            )  # what robot i broadcasts next
    assert worst_range < 1e-9 and worst_bearing < 1e-12, (worst_range, worst_bearing)  # mm; radians
