"""Calling the shared draws from Python with keys of 2**63 and more (as the reference interpreter does)."""

from __future__ import annotations

import numpy as np

from bt_controller.draws import choose, derive, uniform

MASK = 2**64 - 1


def _mix64(z: int) -> int:
    """SplitMix64's finaliser on Python ints: the documented function, written independently of numba."""
    z = ((z ^ (z >> 30)) * 0xBF58476D1CE4E5B9) & MASK
    z = ((z ^ (z >> 27)) * 0x94D049BB133111EB) & MASK
    return z ^ (z >> 31)


def _derive(key: int, value: int) -> int:
    return _mix64(key ^ _mix64((value + 0x9E3779B97F4A7C15) & MASK))


def test_large_keys_as_uint64_from_python():
    derive(np.uint64(5), 1)  # compile for small keys first: the case that trips plain ints
    for key in (2**64 - 5, 2**63, 2**63 - 1, 12345):
        sub = derive(np.uint64(key), 1)
        assert int(sub) == _derive(key, 1), hex(key)
        assert uniform(np.uint64(sub), 3) == (_derive(int(sub), 3) >> 11) / 2.0**53
        assert choose(np.uint64(sub), 3, 4) == min(int((_derive(int(sub), 3) >> 11) / 2.0**53 * 4), 3)
