"""Command-line helpers shared by every command of the package: a parser whose errors are one line (exit
status 2), argument types that say what they expected, and the exit statuses."""

from __future__ import annotations

import argparse
import math
import sys
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import NoReturn

from bt_controller.draws import MAX_SEED
from evolution_manager.errors import UsageError
from swarm_sim.nodes.settings import RATE_RANGE

EXIT_USAGE = 2
EXIT_INTERRUPTED = 130
EXIT_IO = 74
"""A result or checkpoint could not be written (sysexits' EX_IOERR): a full disk, a read-only folder."""


class Parser(argparse.ArgumentParser):
    def error(self, message: str) -> NoReturn:  # argparse prints usage and exits 2; we keep 2, in one line
        raise UsageError(message)


class OneLineParser(argparse.ArgumentParser):
    """argparse's parser for commands that have no error handling of their own around parsing: a bad option
    is one line, ``PROG: error: MESSAGE``, and exit status 2 (argparse prints its usage block first)."""

    def error(self, message: str) -> NoReturn:
        print(f"{self.prog}: error: {' '.join(message.split())}", file=sys.stderr)
        raise SystemExit(EXIT_USAGE)


def tree_argument(argument: str) -> str:
    """The tree text of a ``--tree``-like option: the text itself, unless it names an existing file (as ``bt``
    reads it); ``ValueError`` for a file that cannot be read."""
    try:
        is_file = len(argument) < 4096 and "\n" not in argument and Path(argument).is_file()
    except (OSError, ValueError):  # a name too long for the file system, a NUL byte
        is_file = False
    if not is_file:
        return argument
    try:
        return Path(argument).read_text()
    except (OSError, UnicodeDecodeError) as error:
        raise ValueError(f"cannot read the tree file {argument}: {error}") from None


def positive_int(text: str) -> int:
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a positive integer, got {text!r}") from None
    if value < 1:
        raise argparse.ArgumentTypeError(f"expected a positive integer, got {value}")
    return value


def seed_int(text: str) -> int:
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected an integer seed, got {text!r}") from None
    return value


def seconds(text: str) -> float:
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a number of seconds, got {text!r}") from None
    if not 0 <= value < math.inf:  # NaN and infinity too: "never" is not a number of seconds
        raise argparse.ArgumentTypeError(f"expected a finite number of seconds >= 0, got {text!r}")
    return value


def seed_in_range(text: str) -> int:
    """A seed of a run or a trial: an integer in [0, 2**63 - 1], the range the model draws from."""
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(
            f"expected an integer seed in [0, {MAX_SEED}], got {text!r}"
        ) from None
    if not 0 <= value <= MAX_SEED:
        raise argparse.ArgumentTypeError(f"expected an integer seed in [0, {MAX_SEED}], got {value}")
    return value


def non_negative_int(text: str) -> int:
    """An index counted from 0 (a trial, a step): an integer >= 0."""
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected an integer >= 0, got {text!r}") from None
    if value < 0:
        raise argparse.ArgumentTypeError(f"expected an integer >= 0, got {value}")
    return value


def int_in(low: int, high: int, what: str = "an integer") -> Callable[[str], int]:
    """An argument type: an integer in [low, high] (``what`` names it in the message)."""

    def parse(text: str) -> int:
        try:
            value = int(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"expected {what} in [{low}, {high}], got {text!r}") from None
        if not low <= value <= high:
            raise argparse.ArgumentTypeError(f"expected {what} in [{low}, {high}], got {value}")
        return value

    parse.__name__ = what  # argparse names the type in "invalid ... value" messages
    return parse


def finite(low: float, strictly: bool = False, what: str = "a number") -> Callable[[str], float]:
    """An argument type: a finite number >= ``low`` (> ``low`` when ``strictly``); NaN and the infinities
    are refused, as Python's ``float`` would take them."""
    relation = ">" if strictly else ">="

    def parse(text: str) -> float:
        try:
            value = float(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"expected {what} {relation} {low:g}, got {text!r}") from None
        if not math.isfinite(value) or value < low or (strictly and value == low):
            raise argparse.ArgumentTypeError(f"expected a finite {what} {relation} {low:g}, got {text!r}")
        return value

    parse.__name__ = what
    return parse


def without_ros_args(argv: Sequence[str]) -> list[str]:
    """``argv`` without the ROS arguments (``--ros-args ... [--]``), as ``rclpy.utilities.remove_ros_args``
    gives it, which raises ``UnicodeEncodeError`` on an argument that is not UTF-8 (a file name's bytes,
    which Python keeps as surrogates): such an argument is kept as it is, for the parser to refuse or use."""
    # rclpy: a base module, which the ROS-free wings import
    from rclpy.utilities import remove_ros_args

    argv = list(argv)
    if "--ros-args" not in argv:
        return argv
    kept: dict[str, str] = {}
    for k, argument in enumerate(argv):
        try:
            argument.encode()
        except UnicodeEncodeError:
            kept[f"swarm-bt-qd-argument-{k}"] = argument
            argv[k] = f"swarm-bt-qd-argument-{k}"
    return [kept.get(argument, argument) for argument in remove_ros_args(argv)]


def rate_argument(text: str) -> float:
    """``--rate``: simulated seconds per second of wall time, a number in ``RATE_RANGE``."""
    low, high = RATE_RANGE
    try:
        value = float(text)
    except ValueError:
        value = math.nan
    if not low <= value <= high:
        raise argparse.ArgumentTypeError(f"expected a number in {low:g}..{high:g}, got {text!r}")
    return value
