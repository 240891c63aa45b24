"""One validation helper for the numbers every package takes from users, files and messages.

Python's ``True`` is an ``int`` and ``nan`` a ``float``, so "is this an integer / a number" needs more than an
``isinstance``; these functions say it once. Each returns the value converted (``int`` or ``float``) or raises
``error`` (``ValueError`` unless a package passes its own error type) with a one-line message naming the value
and saying what was expected.
"""

from __future__ import annotations

import json
import math
from collections.abc import Mapping

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


def check_options(
    args: object,
    bounds: Mapping[str, tuple[int | None, int | None]],
    *,
    error: type[Exception] = ValueError,
) -> None:
    """Each integer option of ``args`` (an argparse namespace) that ``bounds`` names (attribute: (low, high),
    either bound None) in its range, checked in ``bounds``' order; else raise ``error`` naming the option as
    it is typed (``reference_trees``: ``--reference-trees``)."""
    for name, (low, high) in bounds.items():
        integer(getattr(args, name), "--" + name.replace("_", "-"), low, high, error=error)


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


def strict_json(text: str) -> object:
    """``json.loads`` of a file a user hands in, refusing what ``json.loads`` lets through silently:
    ``NaN``, ``Infinity`` and ``-Infinity`` (not JSON; they cannot be written back), numbers beyond a float
    (``1e400``) and a key given twice in one object (JSON keeps the last without a word). Raises
    ``json.JSONDecodeError`` for text that is not JSON and ``ValueError`` (one line, naming the value or the
    key) for the others."""
    return json.loads(text, parse_constant=_no_constant, parse_float=_finite, object_pairs_hook=_unique_keys)


def _no_constant(name: str) -> float:
    raise ValueError(f"{name} is not a JSON number (expected a finite number)")


def _finite(text: str) -> float:
    value = float(text)
    if not math.isfinite(value):
        raise ValueError(f"the number {text} is out of range (expected a finite number)")
    return value


def _unique_keys(pairs: list[tuple[str, object]]) -> dict[str, object]:
    document: dict[str, object] = {}
    for key, value in pairs:
        if key in document:
            raise ValueError(f"the key {key!r} appears twice in one object (expected each key once)")
        document[key] = value
    return document
