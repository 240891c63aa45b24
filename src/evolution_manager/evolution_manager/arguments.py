"""Command-line helpers shared by every command of the package: a parser whose errors are one line (exit
status 2), argument types that say what they expected, and the exit statuses."""

from __future__ import annotations

import argparse
import sys
from typing import NoReturn

from evolution_manager.errors import UsageError

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
    if not value >= 0:
        raise argparse.ArgumentTypeError(f"expected a number of seconds >= 0, got {text!r}")
    return value
