"""The errors of swarm_sim; each message names the bad value and says what was expected."""

from __future__ import annotations

from bt_controller.errors import UsageError

__all__ = ["ConditionError", "ConfigError", "ReferenceFileError", "TrialAbandonedError", "UsageError"]


class ConfigError(ValueError):
    """A configuration value is out of its allowed range; the message names it and says why."""


class ConditionError(ValueError):
    """A condition (``swarm_sim.model.conditions``) that cannot be applied; the message names it and says what
    was expected."""


class TrialAbandonedError(RuntimeError):
    """A trial could not go on (the simulator node); the message says which robot and step."""


class ReferenceFileError(ValueError):
    """A validation reference TSV that cannot be read; the message names the file, the row and what was
    expected."""
