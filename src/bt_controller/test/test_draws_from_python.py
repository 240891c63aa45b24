"""Calling the shared draws from Python with keys of 2**63 and more (as the reference interpreter does)."""

from __future__ import annotations

import numpy as np

from bt_controller.draws import choose, derive, uniform


def test_large_keys_as_uint64_from_python():
    derive(np.uint64(5), 1)  # compile for small keys first: the case that trips plain ints
    key = np.uint64(2**64 - 5)
    sub = np.uint64(derive(key, 1))
    assert 0 <= int(sub) < 2**64
    assert 0.0 <= uniform(sub, 3) < 1.0
    assert 0 <= choose(sub, 3, 4) < 4
    assert derive(key, 1) == derive(np.uint64(2**64 - 5), 1)
