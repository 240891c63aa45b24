"""Every random number of the project: counter-based draws, and the one table of where each stream comes from.

Each random number is a pure function of a 64-bit stream key and a counter, so a draw never depends on
how many other draws were made before it, on the batch a trial sits in, or on the process that runs it.
That is what lets the compiled batch evaluator, the reference simulator and the ROS 2 node graph draw
exactly the same numbers for the same (seed, trial, robot, step).

The mixing function is SplitMix64's finaliser (Steele, Lea and Flood, 2014). Keys are derived by
chaining from a seed's root key: ``key_path(seed, a, b, ...) = derive(derive(root_key(seed), a), b) ...``.

Streams of a chain (``swarm_sim``; a chain is the 5 trials simulated as one under the ``paper`` profile, chain
``k // 5`` for trial ``k``, or one trial under ``clean``, chain ``k``): the key of a purpose is
``key_path(seed, chain, robot, purpose)`` and each draw is ``uniform(key, counter)`` with a counter fixed
below, so any chain, any robot and any step can be replayed alone, by any road, in any process.

| purpose | counters |
|---|---|
| ``POSITION`` | trial ``t`` of the chain, try ``a`` (of 10) to place the robot: ``2 (10 t + a)``, + 1 |
| ``HEADING`` | trial ``t`` of the chain: ``t`` |
| ``GAINS`` | ``0`` (right wheel), ``1`` (left wheel) |
| ``DROPS`` | message from robot ``j`` to this robot at the chain's control step ``k``: ``k * n_robots + j`` |
| ``TREE`` | the tree's stream key, passed to the tree interpreter with the chain's tick number |
| ``BEARINGS`` | a ``rab-noisy`` receiver's error on robot ``j``'s bearing at step ``k``: ``k n_robots + j`` |

Per-robot faults of an evaluation (``swarm_sim.model.faults``, ``fault_rate``) are drawn from
``derive(root_key(seed), FAULT_DRAWS)``, the same for every chain: robot ``i``'s draw ``2 i`` says whether it
is faulty, draw ``2 i + 1`` which kind.

Seeds of a run (``evolution_manager``), each ``derive_seed(run seed, purpose, ...)``:
``RUN_EVALUATION, i`` is the simulator seed of evaluation ``i``; ``RUN_ALGORITHM`` seeds the algorithm's own
generator; ``RUN_EXPERIMENT, a, o, r`` is the run seed of repetition ``r`` of algorithm ``a`` and objective
``o`` in an experiment (keyed by the experiment's seed); ``RUN_SCENARIO`` is the default scenario seed of a
run under fixed scenarios, ``RUN_HELDOUT, k`` (keyed by the scenario seed) the seed of held-out
evaluation ``k`` at the end of a run, and ``RUN_VALIDATION, k`` (keyed by the scenario seed) that of
validation scenario ``k``, on which a run's best candidates are re-scored to choose its final one;
``RUN_STUDY, ...`` the run seeds of a study.

All draw functions are numba ``njit`` functions: they can be called from other compiled kernels and, more
slowly, from plain Python. From Python, pass keys as ``np.uint64`` (e.g. ``derive(np.uint64(key), 3)``): a
plain int of 2**63 or more raises OverflowError once a function has been compiled for int64 arguments, and
the functions return plain ints, so wrap a returned key in ``np.uint64`` before passing it on (``key_path``
does).
"""

from __future__ import annotations

import numba
import numpy as np

import bt_controller.lean_numba  # noqa: F401  (numba without scipy and cffi: see there)
from bt_controller.validate import integer

_GOLDEN = np.uint64(0x9E3779B97F4A7C15)
_MUL1 = np.uint64(0xBF58476D1CE4E5B9)
_MUL2 = np.uint64(0x94D049BB133111EB)
_SEED_SALT = np.uint64(0x5EED5EED5EED5EED)
_TO_UNIT = 1.0 / 9007199254740992.0  # 2**-53

MAX_SEED = 2**63 - 1
"""Seeds are integers in [0, MAX_SEED]."""


@numba.njit(cache=True, error_model="numpy", inline="always")
def mix64(z: np.uint64) -> np.uint64:
    """SplitMix64 finaliser: a bijective avalanche of 64 bits."""
    z = np.uint64(z)
    z = (z ^ (z >> np.uint64(30))) * _MUL1
    z = (z ^ (z >> np.uint64(27))) * _MUL2
    return z ^ (z >> np.uint64(31))


@numba.njit(cache=True, error_model="numpy", inline="always")
def derive(key: np.uint64, value: int) -> np.uint64:
    """The key of the sub-stream ``value`` of stream ``key``."""
    return mix64(np.uint64(key) ^ mix64(np.uint64(value) + _GOLDEN))


@numba.njit(cache=True, error_model="numpy", inline="always")
def uniform(key: np.uint64, counter: int) -> float:
    """Draw number ``counter`` of stream ``key``: a float uniform in [0, 1) with 53 random bits."""
    return float(derive(key, counter) >> np.uint64(11)) * _TO_UNIT


@numba.njit(cache=True, error_model="numpy", inline="always")
def choose(key: np.uint64, counter: int, n: int) -> int:
    """Draw number ``counter`` of stream ``key`` as an integer uniform in [0, n)."""
    return min(int(uniform(key, counter) * n), n - 1)


@numba.njit(cache=True, error_model="numpy")
def root_key(seed: int) -> np.uint64:
    """The root stream key of a seed."""
    return mix64(np.uint64(seed) ^ _SEED_SALT)


def check_seed(seed: object) -> int:
    """Return ``seed`` as an int, or raise ValueError saying what a seed must be."""
    return integer(seed, "seed", 0, MAX_SEED, numpy=True)


# --------------------------------------------------------------------------------------- stream paths

POSITION = 0
HEADING = 1
GAINS = 2
DROPS = 3
TREE = 4
BEARINGS = 5
PURPOSES: tuple[str, ...] = ("position", "heading", "gains", "drops", "tree", "bearings")
"""The purposes of a chain's per-robot streams, in index order."""

FAULT_DRAWS = 2**62
"""The sub-stream of a seed's root key that per-robot faults are drawn from (beyond any chain number)."""

RUN_EVALUATION = 1
RUN_ALGORITHM = 2
RUN_EXPERIMENT = 3
RUN_SCENARIO = 4
RUN_HELDOUT = 5
RUN_STUDY = 6
RUN_VALIDATION = 7


def key_path(seed: int, *path: int) -> np.uint64:
    """The stream key reached from ``root_key(seed)`` by deriving along ``path``, from Python."""
    key = np.uint64(root_key(seed))
    for value in path:
        key = np.uint64(derive(key, int(value)))
    return key


def stream_key(seed: int, chain: int, robot: int, purpose: int) -> np.uint64:
    """The stream key of ``(seed, chain, robot, purpose)``, from Python."""
    return key_path(seed, chain, robot, purpose)


def derive_seed(seed: int, *path: int) -> int:
    """A seed in [0, MAX_SEED] derived from ``seed`` along ``path`` (the key of ``key_path``, top bit off)."""
    return int(key_path(seed, *path)) & MAX_SEED


@numba.njit(cache=True, error_model="numpy")
def chain_keys(seed_key: np.uint64, chain: int, n_robots: int) -> np.ndarray:
    """Every stream key of one chain: ``keys[purpose, robot]`` (``len(PURPOSES)`` x ``n_robots``, uint64)."""
    tkey = derive(seed_key, chain)
    keys = np.empty((len(PURPOSES), n_robots), dtype=np.uint64)
    for robot in range(n_robots):
        rkey = derive(tkey, robot)
        for purpose in range(len(PURPOSES)):
            keys[purpose, robot] = derive(rkey, purpose)
    return keys
