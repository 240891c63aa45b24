"""What a trial starts from and what it leaves; shared by the reference road, the batch road and the nodes.

A trial runs ``settle_steps`` sensing steps with the robots still, then ``ticks`` rounds of: tick the trees
(from the latest readings), then ``steps_per_tick`` times move the robots and sense. Sensing steps are
numbered from 0 over the whole trial. Trial ``k`` uses the gap ``config.gaps[k % len(gaps)]``.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from bt_controller.draws import DROPS, GAINS, HEADING, POSITION, TREE, check_seed, root_key, trial_keys
from bt_controller.validate import integer
from swarm_sim import world
from swarm_sim.config import DEFAULT, Config

VALUE_NAMES: tuple[str, ...] = ("density", "nest", "food", "movement", "rotation", "conditionality")
"""The six values of a trial or an evaluation, in ``world.N_VALUES`` order."""


@dataclass(frozen=True)
class TrialSetup:
    """Everything random about one trial, drawn from its streams."""

    trial: int
    gap: float
    poses: np.ndarray
    """Start poses, n_robots x (x, y, heading)."""
    gains: np.ndarray
    """Wheel gains, n_robots x (left, right)."""
    drop_keys: np.ndarray
    """Each robot's message-drop stream key (uint64)."""
    tree_keys: np.ndarray
    """Each robot's tree stream key (uint64), for the tree interpreter's probabilistic choices."""


def setup_trial(seed: int, trial: int, config: Config = DEFAULT) -> TrialSetup:
    """Draw trial ``trial`` of ``seed``: start poses, wheel gains and the robots' stream keys."""
    seed = check_seed(seed)
    integer(trial, "trial", 0)
    p = config.params()
    keys = trial_keys(np.uint64(root_key(seed)), trial, p.n_robots)
    return TrialSetup(
        trial=trial,
        gap=config.gap(trial),
        poses=world.start_poses(keys[POSITION], keys[HEADING], p),
        gains=world.wheel_gains(keys[GAINS], p),
        drop_keys=keys[DROPS].copy(),
        tree_keys=keys[TREE].copy(),
    )


@dataclass(frozen=True)
class TrialRecord:
    """What one trial leaves: its six values and the robots' start and end poses."""

    trial: int
    gap: float
    values: tuple[float, ...]
    """density, nest, food, movement, rotation, conditionality (``VALUE_NAMES``)."""
    start_poses: np.ndarray
    end_poses: np.ndarray

    def as_dict(self) -> dict[str, object]:
        """JSON-ready form: values by name and poses as lists of [x, y, heading]."""
        named = dict(zip(VALUE_NAMES, self.values, strict=True))
        return {
            "trial": self.trial,
            "gap": self.gap,
            "fitness": {k: named[k] for k in VALUE_NAMES[:3]},
            "descriptors": {k: named[k] for k in VALUE_NAMES[3:]},
            "start_poses": self.start_poses.tolist(),
            "end_poses": self.end_poses.tolist(),
        }


def combine(records: list[TrialRecord]) -> tuple[float, ...]:
    """An evaluation's six values: the trials' values averaged in trial order (``world.mean_values``)."""
    per_trial = np.array([r.values for r in records], dtype=np.float64).reshape(len(records), world.N_VALUES)
    return tuple(float(v) for v in world.mean_values(per_trial))
