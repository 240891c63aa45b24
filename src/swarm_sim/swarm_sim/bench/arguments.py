"""The benchmarks' integer options, checked before any work: a value out of range is one line naming the
option, the range expected and the value given (argparse's ``PROG: error: ...``, exit status 2)."""

from __future__ import annotations

import argparse
from collections.abc import Mapping

import numba

from bt_controller.draws import MAX_SEED

__all__ = ["MAX_SEED", "check_ranges", "most_threads"]


def most_threads() -> int:
    """The most numba threads this machine allows (``--threads``' upper bound)."""
    most: int = numba.config.NUMBA_NUM_THREADS  # type: ignore[attr-defined]  # set by numba at import
    return most


def check_ranges(
    parser: argparse.ArgumentParser, args: argparse.Namespace, bounds: Mapping[str, tuple[int, int | None]]
) -> None:
    """Refuse, through ``parser.error``, the first option of ``bounds`` (attribute name: (least, most), most
    None for no upper bound) whose value in ``args`` is out of its range."""
    for name, (least, most) in bounds.items():
        value = getattr(args, name)
        option = "--" + name.replace("_", "-")
        if most is None and value < least:
            parser.error(f"{option} must be an integer >= {least}, got {value}")
        if most is not None and not least <= value <= most:
            parser.error(f"{option} must be an integer in [{least}, {most}], got {value}")
