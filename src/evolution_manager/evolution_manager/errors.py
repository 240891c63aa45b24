"""The exceptions of the evolution manager; each message says what was expected."""

from __future__ import annotations


class EvolutionError(Exception):
    """Base class of every error raised on purpose by this package."""


class ConfigError(EvolutionError, ValueError):
    """A run, experiment or command-line option has a value this package cannot use."""


class AskTellError(EvolutionError, RuntimeError):
    """``ask`` and ``tell`` were called out of order, or ``tell`` got the wrong number of results."""


class TreeTextError(EvolutionError, ValueError):
    """A tree text does not describe a tree of the primitive set."""


class RunDirectoryError(EvolutionError):
    """A run directory is missing, damaged, or would be overwritten."""
