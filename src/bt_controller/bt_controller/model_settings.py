"""The model's settings as plain named tuples, free of compiled code: the profiles, the trial timeline's
parameters and a robot's perception parameters.

``bt_controller.robot.timeline`` and ``bt_controller.robot.perception`` hold the ``njit`` functions that read
these; everything that only needs the settings (``swarm_sim.model``, the command lines, the evolution manager)
imports them from here without starting numba.
"""

from __future__ import annotations

from typing import NamedTuple, Protocol

PAPER, CLEAN = 0, 1
PROFILES: tuple[str, ...] = ("paper", "clean")
"""Profile names, indexed by the profile number (``PAPER``, ``CLEAN``)."""

CODE_2024, CODE_2026 = 2024, 2026
AUTHORS_CODES: tuple[int, ...] = (CODE_2024, CODE_2026)
"""The versions of the authors' code whose artefacts ``paper`` reproduces (``docs/model.md``, "Two profiles"):
2024, the code of both papers (6c65001 and a73e4af, which compute the same model), and 2026, their commit
1cd2358, whose robots start their estimates afresh at every trial and see no robot when nobody is heard."""


def check_authors_code(code: object) -> int:
    """``code`` if it is one of ``AUTHORS_CODES``; ValueError naming the choices otherwise."""
    for known in AUTHORS_CODES:
        if code == known and not isinstance(code, bool):
            return known
    raise ValueError(f"authors_code must be one of {', '.join(map(str, AUTHORS_CODES))}, got {code!r}")


def profile_number(name: str) -> int:
    """The number of profile ``name``; ValueError naming the choices for anything else."""
    if name not in PROFILES:
        raise ValueError(f"profile must be one of {', '.join(PROFILES)}, got {name!r}")
    return PROFILES.index(name)


class CodeSettings(Protocol):
    """The two settings that say which of the authors' artefacts hold: any of the named tuples below."""

    @property
    def profile(self) -> int: ...
    @property
    def authors_code(self) -> int: ...


class Timeline(NamedTuple):
    """The timeline's parameters with the model's defaults."""

    profile: int = PAPER
    """``PAPER`` (the authors' experiment) or ``CLEAN`` (artefacts A1-A4 removed)."""
    steps_per_tick: int = 4
    """Control steps per behaviour-tree tick: 8 Hz steps, 2 Hz ticks (paper, section 4)."""
    ticks: int = 40
    """Ticks per trial: a 20 s trial (paper, section 4)."""
    initial_step: int = 16
    """A trial's step at which the objectives' initial values are taken (``footbot_bt.cpp:539``)."""
    chain_trials: int = 5
    """Trials run as one simulation under ``paper`` (the authors' ``iterations``, ``params.py``)."""
    authors_code: int = CODE_2024
    """The authors' code ``paper`` follows (``AUTHORS_CODES``): under 2026 each trial of a chain starts its
    estimates afresh (``timeline.trials_restart``)."""


class TimelineSettings(Protocol):
    """What the timeline reads of its parameters: ``Timeline`` or any named tuple with its fields
    (``swarm_sim.model.config.Params``)."""

    @property
    def profile(self) -> int: ...
    @property
    def steps_per_tick(self) -> int: ...
    @property
    def ticks(self) -> int: ...
    @property
    def initial_step(self) -> int: ...
    @property
    def chain_trials(self) -> int: ...
    @property
    def authors_code(self) -> int: ...


def chain_of_trial(t: TimelineSettings, trial: int) -> tuple[int, int]:
    """``(chain, position)``: the chain that trial ``trial`` of an evaluation belongs to, and its place
    in it."""
    length = t.chain_trials if t.profile == PAPER else 1
    return trial // length, trial % length


def arena_of_trial(t: TimelineSettings, trial: int, n_arenas: int) -> int:
    """The arena configuration (gap) of trial ``trial``: trial k belongs to block k // chain_trials, and
    blocks alternate arenas (``utilities.py:59-71`` runs one chain per gap), under both profiles."""
    return (trial // t.chain_trials) % n_arenas


class PerceptionParams(NamedTuple):
    """The parameters of a robot's perception, with the model's defaults (``docs/model.md``, "One step")."""

    window: int = 7
    """Raw samples averaged into a smoothed value (``CBlackBoard.cpp:45``: at most 7 kept)."""
    estimate_cap: float = 5000.0
    """Largest nest/food distance estimate, and the estimate when nothing better was heard: 500 cm
    (``footbot_bt.cpp:281-282``) (mm)."""
    density_range: float = 10_000.0
    """A neighbour at range r adds 1 / (pi (r / density_range)^2) to the density sum: ARGoS's range in cm
    divided by 1000 (``footbot_bt.cpp:334``) is the range in mm divided by 10000 (mm)."""
    density_divisor: float = 1107.0 * 6.0
    """The density sum is divided by this: 1107 per touching neighbour, 6 neighbours
    (``CBlackBoard.cpp:295``)."""
    profile: int = PAPER
    """``timeline.PAPER`` or ``timeline.CLEAN``: under ``paper`` robot_left holds when nobody was heard
    (A2), unless ``authors_code`` is 2026."""
    regions: int = 2
    """The regions a robot perceives: the nest and the world's food kinds (2-4, ``vocabulary.REGIONS``)."""
    authors_code: int = CODE_2024
    """The authors' code ``paper`` follows (``AUTHORS_CODES``): under 2026 a trial's end empties the
    estimate windows, and nobody heard means no robot on either side."""


class PerceptionSettings(Protocol):
    """What perception reads of its parameters: ``PerceptionParams`` or any named tuple with its fields."""

    @property
    def window(self) -> int: ...
    @property
    def estimate_cap(self) -> float: ...
    @property
    def density_range(self) -> float: ...
    @property
    def density_divisor(self) -> float: ...
    @property
    def profile(self) -> int: ...
    @property
    def regions(self) -> int: ...
    @property
    def authors_code(self) -> int: ...
