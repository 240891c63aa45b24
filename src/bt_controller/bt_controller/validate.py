"""One validation helper for the numbers every package takes from users, files and messages.

Python's ``True`` is an ``int`` and ``nan`` a ``float``, so "is this an integer / a number" needs more than an
``isinstance``; these functions say it once. Each returns the value converted (``int`` or ``float``) or raises
``error`` (``ValueError`` unless a package passes its own error type) with a one-line message naming the value
and saying what was expected.
"""

from __future__ import annotations

import math

import numpy as np


def integer(
    value: object,
    name: str,
    low: int | None = None,
    high: int | None = None,
    *,
    numpy: bool = False,
    error: type[Exception] = ValueError,
) -> int:
    """``value`` as an int if it is an integer (not a bool; a numpy integer too with ``numpy=True``) in
    ``[low, high]`` (either bound may be None); else raise ``error``."""
    kinds = (int, np.integer) if numpy else (int,)
    if isinstance(value, bool) or not isinstance(value, kinds):
        raise error(f"{name} must be {_integer_kind(low, high)}, got {value!r}")
    number = int(value)
    if (low is not None and number < low) or (high is not None and number > high):
        raise error(f"{name} must be {_integer_kind(low, high)}, got {value!r}")
    return number


def _integer_kind(low: int | None, high: int | None) -> str:
    if low is not None and high is not None:
        return f"an integer in [{low}, {high}]"
    if low == 1:
        return "a positive integer"
    if low == 0:
        return "a non-negative integer"
    if low is not None:
        return f"an integer of at least {low}"
    if high is not None:
        return f"an integer of at most {high}"
    return "an integer"


def number(
    value: object,
    name: str,
    *,
    positive: bool = False,
    error: type[Exception] = ValueError,
) -> float:
    """``value`` as a float if it is a finite real number (an int or a float, not a bool), positive when
    ``positive``; else raise ``error``."""
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        raise error(f"{name} must be a number, got {value!r}")
    if not math.isfinite(value):
        raise error(f"{name} must be finite, got {value!r}")
    if positive and value <= 0:
        raise error(f"{name} must be positive, got {value!r}")
    return float(value)
