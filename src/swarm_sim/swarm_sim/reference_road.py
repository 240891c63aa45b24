"""The reference road: one trial, robot by robot, with the reference tree interpreter. Slow and plain; the
oracle that the batch evaluator is tested against.

It is orchestrated the way the ROS 2 node graph is: the simulator (physics, message delivery, ground sensing)
and one controller per robot (``RobotView`` plus a ``ReferenceRobot`` ticking the tree), exchanging only
readings, broadcast estimates and wheel commands.
"""

from __future__ import annotations

import numpy as np

from bt_controller.semantics import ReferenceRobot
from bt_controller.tree import Node
from bt_controller.validate import integer
from bt_controller.vocabulary import RUNNING, STOP
from swarm_sim import world
from swarm_sim.config import DEFAULT, Config
from swarm_sim.sensing import RobotView, sense_swarm
from swarm_sim.trial_data import TrialRecord, combine, setup_trial


def run_trial(tree: Node, seed: int, trial: int, config: Config = DEFAULT) -> TrialRecord:
    """Run trial ``trial`` of ``seed`` with every robot running ``tree``."""
    p = config.params()
    setup = setup_trial(seed, trial, config)
    n = p.n_robots
    x = setup.poses[:, 0].copy()
    y = setup.poses[:, 1].copy()
    heading = setup.poses[:, 2].copy()
    x_before, y_before = np.empty(n), np.empty(n)
    views = [RobotView(p) for _ in range(n)]
    controllers = [ReferenceRobot(tree, int(setup.tree_keys[i])) for i in range(n)]
    actions = np.full(n, STOP, dtype=np.int64)

    # Before any estimate exists, a robot broadcasts 0 for a region it is in and the cap otherwise.
    broadcast_nest, broadcast_food = np.empty(n), np.empty(n)
    for i in range(n):
        in_nest, on_food = world.ground(x[i], y[i], setup.gap, p)
        broadcast_nest[i], broadcast_food[i] = world.initial_broadcast(in_nest, on_food, p)

    def sense(step: int) -> None:
        readings = sense_swarm(
            x, y, heading, broadcast_nest, broadcast_food, setup.drop_keys, step, setup.gap, p
        )
        for i in range(n):
            views[i].update(readings[i])
        for i in range(n):
            broadcast_nest[i], broadcast_food[i] = views[i].broadcast()

    step = 0
    for _ in range(p.settle_steps):
        sense(step)
        step += 1
    initial = np.array([view.smoothed() for view in views])

    for _ in range(p.ticks):
        for i in range(n):
            status, action = controllers[i].step(views[i].blackboard())
            actions[i] = action if status == RUNNING else STOP
        for _ in range(p.steps_per_tick):
            world.physics_step(x, y, heading, actions, setup.gains, p, x_before, y_before)
            sense(step)
            step += 1

    final = np.array([view.smoothed() for view in views])
    end_ground = np.zeros((n, 2), dtype=np.bool_)
    for i, view in enumerate(views):
        assert view.latest is not None, "every robot has sensed by the end of a trial"
        end_ground[i] = view.latest.in_nest, view.latest.on_food
    counts = np.array([c.counts for c in controllers], dtype=np.int64)
    values = world.trial_values(initial, final, end_ground, counts, p)
    return TrialRecord(
        trial=trial,
        gap=setup.gap,
        values=tuple(float(v) for v in values),
        start_poses=setup.poses.copy(),
        end_poses=np.stack([x, y, heading], axis=1),
    )


def evaluate(
    tree: Node, seed: int, trials: int = 10, config: Config = DEFAULT
) -> tuple[tuple[float, ...], list[TrialRecord]]:
    """Evaluate ``tree`` over trials 0 .. trials - 1 of ``seed``: the six mean values and each trial's
    record."""
    integer(trials, "trials", 1)
    records = [run_trial(tree, seed, k, config) for k in range(trials)]
    return combine(records), records
