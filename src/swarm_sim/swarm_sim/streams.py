"""Where every random number of a chain comes from.

A chain's randomness is a pure function of ``(seed, chain, robot, purpose)``: the stream key of a purpose is

    derive(derive(derive(root_key(seed), chain), robot), purpose)

and each draw is ``bt_controller.draws.uniform(key, counter)`` with a counter fixed below, so any chain, any
robot and any step can be replayed alone, by any road, in any process. A chain is the 5 trials simulated as one
under ``paper`` (chain ``k // 5`` for trial ``k``), or one trial under ``clean`` (chain ``k``).

| purpose | counters |
|---|---|
| ``POSITION`` | trial ``t`` of the chain, attempt ``a`` of placing the robot: ``2 (10 t + a)`` (x), the next (y) |
| ``HEADING`` | trial ``t`` of the chain: ``t`` |
| ``GAINS`` | ``0`` (right wheel), ``1`` (left wheel) |
| ``DROPS`` | message from robot ``j`` to this robot at chain step ``k``: ``k * n_robots + j`` |
| ``TREE`` | the tree's stream key, passed to the tree interpreter with the chain's tick number |

(10 is ``max_start_attempts``.)
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


def stream_key(seed: int, chain: int, robot: int, purpose: int) -> np.uint64:
    """The stream key of ``(seed, chain, robot, purpose)``, from Python."""
    key = np.uint64(root_key(seed))
    for value in (chain, robot, purpose):
        key = np.uint64(derive(key, value))
    return key


@numba.njit(cache=True)
def chain_keys(seed_key: np.uint64, chain: int, n_robots: int) -> np.ndarray:
    """Every stream key of one chain: ``keys[purpose, robot]`` (``len(PURPOSES)`` x ``n_robots``, uint64)."""
    tkey = derive(seed_key, chain)
    keys = np.empty((len(PURPOSES), n_robots), dtype=np.uint64)
    for robot in range(n_robots):
        rkey = derive(tkey, robot)
        for purpose in range(len(PURPOSES)):
            keys[purpose, robot] = derive(rkey, purpose)
    return keys
