"""Where every random number of a trial comes from.

A trial's randomness is a pure function of ``(seed, trial, robot, purpose)``: the stream key of a purpose is

    derive(derive(derive(root_key(seed), trial), robot), purpose)

and each draw is ``bt_controller.draws.uniform(key, counter)`` with a counter fixed below, so any trial, any
robot and any step can be replayed alone, by any road, in any process.

| purpose | counters |
|---|---|
| ``POSITION`` | attempt ``a`` of placing the robot: ``2a`` (radius), ``2a + 1`` (angle) |
| ``HEADING`` | ``0`` |
| ``GAINS`` | ``0`` (left wheel), ``1`` (right wheel) |
| ``DROPS`` | message from robot ``j`` to this robot at sensing step ``s``: ``s * n_robots + j`` |
| ``TREE`` | the tree's stream key, passed to the tree interpreter (see ``docs/interfaces.md``) |

Sensing steps are numbered from 0 within a trial, the settling steps first. Trial ``k`` uses arena
configuration ``k % len(config.gaps)``.
"""

from __future__ import annotations

import numba
import numpy as np

from bt_controller.draws import derive, root_key
from swarm_sim._numba_cache import drop_stale_cache

drop_stale_cache(__file__, ("bt_controller.draws",))

POSITION = 0
HEADING = 1
GAINS = 2
DROPS = 3
TREE = 4
PURPOSES: tuple[str, ...] = ("position", "heading", "gains", "drops", "tree")


def stream_key(seed: int, trial: int, robot: int, purpose: int) -> np.uint64:
    """The stream key of ``(seed, trial, robot, purpose)``, from Python."""
    key = np.uint64(root_key(seed))
    for value in (trial, robot, purpose):
        key = np.uint64(derive(key, value))
    return key


@numba.njit(cache=True)
def trial_keys(seed_key: np.uint64, trial: int, n_robots: int) -> np.ndarray:
    """Every stream key of one trial: ``keys[purpose, robot]`` (``len(PURPOSES)`` x ``n_robots``, uint64)."""
    tkey = derive(seed_key, trial)
    keys = np.empty((len(PURPOSES), n_robots), dtype=np.uint64)
    for robot in range(n_robots):
        rkey = derive(tkey, robot)
        for purpose in range(len(PURPOSES)):
            keys[purpose, robot] = derive(rkey, purpose)
    return keys
