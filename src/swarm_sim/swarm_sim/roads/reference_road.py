"""The reference road: chains run step by step in plain Python, robot by robot, with the reference tree
interpreter. Slow and plain; the oracle that the batch evaluator is tested against.

It is orchestrated the way the ROS 2 node graph is: the simulator's side (``swarm_sim.roads.lockstep``:
teleports, physics, message delivery, ground sensing, scoring) and one
``bt_controller.robot.controller.FootbotController`` per robot (perception, the tree, the motors), exchanging
only readings and answers.
"""

from __future__ import annotations

from collections.abc import Sequence

from bt_controller.interpreters import Network
from bt_controller.language import Node
from swarm_sim.core import TrialRecord, chain_plan, combine
from swarm_sim.model import DEFAULT, Config
from swarm_sim.roads.lockstep import run_chain_with_controllers


def run_chain(
    tree: Node | Network | Sequence[Node | Network],
    seed: int,
    chain: int,
    trials: int,
    config: Config = DEFAULT,
) -> list[TrialRecord]:
    """Run the first ``trials`` trials of chain ``chain`` of ``seed`` with every robot running ``tree``, or
    robot ``i`` running ``tree[i]`` (a heterogeneous swarm: ``swarm_layout.SwarmLayout.parsed``)."""
    return run_chain_with_controllers(tree, seed, chain, trials, config)


def evaluate(
    tree: Node | Network | Sequence[Node | Network], seed: int, trials: int = 10, config: Config = DEFAULT
) -> tuple[tuple[float, ...], list[TrialRecord]]:
    """Evaluate ``tree`` (every robot's, or one per robot) over trials 0 .. trials - 1 of ``seed``: the mean
    values and each trial's record."""
    records: list[TrialRecord] = []
    for chain, length in chain_plan(trials, config):
        records.extend(run_chain(tree, seed, chain, length, config))
    return combine(records), records
