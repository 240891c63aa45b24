"""What a chain starts from and what its trials leave; shared by the reference road, the batch road and the
nodes.

A chain is one continuous simulation of one or more trials (``bt_controller.robot.timeline``): the 5 trials of
a block under ``paper``, a single trial under ``clean``. ``setup_chain`` draws what is fixed for the whole
chain (wheel gains, the robots' stream keys, their faults: ``robot_faults``, the same for every chain of a
seed); start poses are drawn at each trial's first step by ``world.place_robots``. Trial ``k`` of an
evaluation is trial ``k % chain_length`` of chain ``k // chain_length`` and uses the gap ``config.gap(k)``.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from bt_controller.draws import (
    BEARINGS,
    DROPS,
    FAULT_DRAWS,
    GAINS,
    HEADING,
    POSITION,
    TREE,
    chain_keys,
    check_seed,
    choose,
    derive,
    root_key,
    uniform,
)
from bt_controller.model_settings import chain_of_trial
from bt_controller.validate import integer
from swarm_sim.core import world
from swarm_sim.model import DEFAULT, DESCRIPTORS, FAULT_KINDS, OBJECTIVES, VALUE_NAMES, Config
from swarm_sim.model.faults import fault_code

__all__ = ["ChainSetup", "TrialRecord", "chain_plan", "combine", "robot_faults", "setup_chain"]


@dataclass(frozen=True)
class ChainSetup:
    """Everything random about one chain that is drawn at its start, from its streams."""

    chain: int
    first_trial: int
    """The evaluation's index of the chain's first trial."""
    gap: float
    position_keys: np.ndarray
    """Each robot's start-position stream key (uint64)."""
    heading_keys: np.ndarray
    """Each robot's start-heading stream key (uint64)."""
    gains: np.ndarray
    """Wheel gains, n_robots x (left, right)."""
    drop_keys: np.ndarray
    """Each robot's message-drop stream key (uint64)."""
    tree_keys: np.ndarray
    """Each robot's tree stream key (uint64), for the tree interpreter's probabilistic choices."""
    faults: np.ndarray
    """Each robot's fault code (``swarm_sim.model.faults``; 0: none), int64; the gains include them."""
    bearing_keys: np.ndarray
    """Each robot's ``BEARINGS`` stream key (uint64), for a ``rab-noisy`` receiver's errors."""


def robot_faults(config: Config, seed_key: np.uint64) -> np.ndarray:
    """Each robot's fault code (``swarm_sim.model.faults``; 0: none) in evaluations of the seed whose root
    key is ``seed_key``, int64: ``config.fault_robots`` as given, or under ``fault_rate`` robot ``i`` faulty
    when draw ``2 i`` of ``derive(seed_key, FAULT_DRAWS)`` is below the rate, of the kind draw ``2 i + 1``
    chooses among ``fault_kinds`` (all kinds when empty). A robot's fault depends on the seed, the rate and
    the kinds only (not on the chain, the road or the swarm's size)."""
    faults = np.zeros(config.n_robots, dtype=np.int64)
    for robot, kind in config.fault_robots:
        faults[robot] = fault_code(kind)
    if config.fault_rate > 0.0:
        kinds = config.fault_kinds or FAULT_KINDS
        key = np.uint64(derive(np.uint64(seed_key), FAULT_DRAWS))
        for i in range(config.n_robots):
            if uniform(key, 2 * i) < config.fault_rate:
                faults[i] = fault_code(kinds[choose(key, 2 * i + 1, len(kinds))])
    return faults


def setup_chain(seed: int, chain: int, config: Config = DEFAULT) -> ChainSetup:
    """Draw chain ``chain`` of ``seed``: wheel gains and the robots' stream keys."""
    seed = check_seed(seed)
    integer(chain, "chain", 0)
    p = config.params()
    seed_key = np.uint64(root_key(seed))
    keys = chain_keys(seed_key, chain, p.n_robots)
    first = chain * config.chain_length
    faults = robot_faults(config, seed_key)
    gains = world.wheel_gains(keys[GAINS], p)
    world.faulty_wheels(gains, faults)
    return ChainSetup(
        chain=chain,
        first_trial=first,
        gap=config.gap(first),
        position_keys=keys[POSITION].copy(),
        heading_keys=keys[HEADING].copy(),
        gains=gains,
        drop_keys=keys[DROPS].copy(),
        tree_keys=keys[TREE].copy(),
        faults=faults,
        bearing_keys=keys[BEARINGS].copy(),
    )


def chain_plan(trials: int, config: Config = DEFAULT) -> list[tuple[int, int]]:
    """The chains that trials ``0 .. trials - 1`` of an evaluation take: ``(chain, trials to run)`` each."""
    integer(trials, "trials", 1)
    last_chain, last_position = chain_of_trial(config.timeline, trials - 1)
    return [(c, config.chain_length if c < last_chain else last_position + 1) for c in range(last_chain + 1)]


@dataclass(frozen=True)
class TrialRecord:
    """What one trial leaves: its six values and the robots' start and end poses."""

    trial: int
    gap: float
    values: tuple[float, ...]
    """Every objective, then movement, rotation, conditionality (``VALUE_NAMES``)."""
    start_poses: np.ndarray
    end_poses: np.ndarray

    def as_dict(self) -> dict[str, object]:
        """JSON-ready form: values by name and poses as lists of [x, y, heading]."""
        named = dict(zip(VALUE_NAMES, self.values, strict=True))
        return {
            "trial": self.trial,
            "gap": self.gap,
            "fitness": {k: named[k] for k in OBJECTIVES},
            "descriptors": {k: named[k] for k in DESCRIPTORS},
            "start_poses": self.start_poses.tolist(),
            "end_poses": self.end_poses.tolist(),
        }


def combine(records: list[TrialRecord]) -> tuple[float, ...]:
    """An evaluation's six values: the trials' values averaged in trial order (``world.mean_values``)."""
    per_trial = np.array([r.values for r in records], dtype=np.float64).reshape(len(records), world.N_VALUES)
    return tuple(float(v) for v in world.mean_values(per_trial))
