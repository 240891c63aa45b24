"""The exceptions of the evolution manager; each message says what was expected."""

from __future__ import annotations

import signal

from bt_controller.errors import UsageError
from swarm_ros.safe_paths import UnsafePathError
from swarm_sim.errors import ConfigError as WorldConfigError

__all__ = [
    "AnimationError",
    "AskTellError",
    "BagError",
    "ConfigError",
    "DispatchError",
    "EvolutionError",
    "ExplorerError",
    "GraphError",
    "Interrupted",
    "LockHeldError",
    "NoEvaluatorError",
    "RunDirectoryError",
    "TreeTextError",
    "TrialFailedError",
    "UsageError",
    "WriteError",
]


class EvolutionError(Exception):
    """Base class of every error raised on purpose by this package."""


class ConfigError(EvolutionError, WorldConfigError):
    """A run, experiment or command-line option has a value this package cannot use (a ``ConfigError`` of
    ``swarm_sim`` too, so one ``except`` catches a bad configuration of either)."""


class AskTellError(EvolutionError, RuntimeError):
    """``ask`` and ``tell`` were called out of order, or ``tell`` got the wrong number of results."""


class TreeTextError(EvolutionError, ValueError):
    """A tree text does not describe a tree of the primitive set."""


class RunDirectoryError(EvolutionError):
    """A run directory is missing, damaged, or would be overwritten."""


class DispatchError(EvolutionError, RuntimeError):
    """The work cannot be finished (a request nobody answers); the message says which and why."""


class NoEvaluatorError(DispatchError):
    """No evaluator service answered within the wait; the message says how long it waited."""


class BagError(RuntimeError):
    """A bag could not be written, read or recovered; the message says which and why, in one line: the
    message of a library it carries (a YAML parser's runs over many lines and may quote a whole file) is
    joined into one and cut at ``LIMIT`` characters."""

    LIMIT = 400

    def __init__(self, message: object) -> None:
        text = " ".join(str(message).split())
        super().__init__(text if len(text) <= self.LIMIT else text[: self.LIMIT - 4] + " ...")


class GraphError(RuntimeError):
    """A node of the graph could not be started or died; the message says which and why."""


class TrialFailedError(RuntimeError):
    """The trial could not be run through the graph; the message says why."""


class WriteError(EvolutionError):
    """A result or checkpoint could not be written (a full disk, a read-only folder); the message names the
    file and the system's error. What was saved before stays whole: files are replaced atomically and the
    logs are cut back to the last checkpoint on resume."""

    @classmethod
    def of(cls, path: object, error: OSError) -> WriteError:
        """The error of writing ``path`` (its message survives pickling, e.g. from a worker process); a
        refused path (a planted link, ``swarm_ros.safe_paths``) says so itself."""
        if isinstance(error, UnsafePathError):
            return cls(str(error))
        # The file the system names may be another (a temporary beside it, a font, a module being
        # reinstalled): said too, so a missing file elsewhere is not taken for the output's folder.
        other = error.filename is not None and str(error.filename) != str(path)
        return cls(
            f"cannot write {path}: {error.strerror or error}" + (f" ({error.filename})" if other else "")
        )


class LockHeldError(EvolutionError):
    """Another process holds a lock (of a run directory or a bag); the message names it and its PID."""


class Interrupted(KeyboardInterrupt):
    """SIGINT or SIGTERM arrived; ``exit_status`` is 128 + the signal number (130 or 143)."""

    def __init__(self, signum: int = signal.SIGINT) -> None:
        super().__init__(signal.Signals(signum).name)
        self.signum = signum

    @property
    def exit_status(self) -> int:
        return 128 + self.signum


class AnimationError(EvolutionError):
    """A trial animation could not be made (a bag that is no trial bag, a format or encoder missing)."""


class ExplorerError(EvolutionError):
    """A run directory's explorer page could not be built (no repertoire files, a damaged file)."""
