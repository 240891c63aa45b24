"""The one home of the trial timeline: what a footbot does at each control step, under each profile.

A *chain* is one continuous simulation; its control steps are counted ``k = 1, 2, ...`` (the authors'
``m_count``, ``footbot_bt.cpp:491``). Under ``paper`` a chain holds ``chain_trials`` (5) trials of
``ticks * steps_per_tick`` (160) steps each, with teleports between them; under ``clean`` a chain is one trial
of ``initial_step + ticks * steps_per_tick`` (176) steps. At step ``k`` a robot (``docs/model.md``, "One
control step"):

1. at a trial's first step does not sense (``senses``); at ``k = 1`` (at every trial's first step where
   ``trials_restart``) broadcasts its region values (``region_broadcast``);
2. otherwise senses, and refreshes its smoothed values at ``k = 2`` (a trial's step 2 where
   ``trials_restart``) and whenever ``k % steps_per_tick == 0`` (``refreshes``);
3. ticks its tree when ``ticks_at`` (``paper``: every ``k % 4 == 0``; ``clean``: only after the trial's
   ``initial_step``);
4. otherwise broadcasts its smoothed values, and drives its wheels.

Objectives take their initial values at a trial's ``initial_step`` (``is_initial``) and their final values at
its last step (``is_final``), where the estimate windows are emptied if ``trials_restart``. Every function
takes ``t``, any object with the fields of ``Timeline`` (``swarm_sim.model.config.Params`` has them all),
and is an ``njit`` function so that the batch kernels, the reference road and the nodes all run this very
code.
"""

from __future__ import annotations

import numba

import bt_controller.lean_numba  # noqa: F401  (numba without scipy and cffi: see there)
from bt_controller.model_settings import CLEAN, CODE_2026, PAPER, CodeSettings, TimelineSettings


@numba.njit(cache=True, error_model="numpy", inline="always")
def trial_steps(t: TimelineSettings) -> int:
    """Control steps in one trial: 160 under ``paper``, 176 under ``clean``."""
    controlled = t.ticks * t.steps_per_tick
    return controlled + t.initial_step if t.profile == CLEAN else controlled


@numba.njit(cache=True, error_model="numpy", inline="always")
def chain_length(t: TimelineSettings) -> int:
    """Trials per chain: ``chain_trials`` under ``paper``, 1 under ``clean`` (every trial a fresh start)."""
    return t.chain_trials if t.profile == PAPER else 1


@numba.njit(cache=True, error_model="numpy", inline="always")
def step_in_trial(t: TimelineSettings, k: int) -> int:
    """The 1-based step of chain step ``k`` within its trial."""
    return (k - 1) % trial_steps(t) + 1


@numba.njit(cache=True, error_model="numpy", inline="always")
def trial_in_chain(t: TimelineSettings, k: int) -> int:
    """The 0-based position within its chain of the trial that chain step ``k`` belongs to."""
    return (k - 1) // trial_steps(t)


@numba.njit(cache=True, error_model="numpy", inline="always")
def senses(t: TimelineSettings, k: int) -> bool:
    """Whether the robot reads its sensors at step ``k``: every step but a trial's first."""
    return step_in_trial(t, k) != 1


@numba.njit(cache=True, error_model="numpy", inline="always")
def trials_restart(t: CodeSettings) -> bool:
    """Whether every trial starts the robots' estimates afresh: under ``clean`` (a chain is one trial), and
    under ``paper`` with the authors' 2026 code, whose trial end empties the estimate windows
    (``CBlackBoard.cpp:4-19`` at 1cd2358) and whose every trial samples at its step 2 and broadcasts region
    values at its first (``footbot_bt.cpp:741-794, 855-859``). The 2024 code does neither after the chain's
    first trial (A1)."""
    return t.profile == CLEAN or t.authors_code == CODE_2026


@numba.njit(cache=True, error_model="numpy", inline="always")
def region_broadcast(t: TimelineSettings, k: int) -> bool:
    """Whether step ``k`` broadcasts the region values (0 inside a region, else the cap) instead of the
    smoothed values: the chain's first step, or every trial's first where ``trials_restart``."""
    return step_in_trial(t, k) == 1 if trials_restart(t) else k == 1


@numba.njit(cache=True, error_model="numpy", inline="always")
def refreshes(t: TimelineSettings, k: int) -> bool:
    """Whether step ``k`` (a sensing step) refreshes the smoothed values: every tick step, and the chain's
    step 2 (every trial's where ``trials_restart``)."""
    if k % t.steps_per_tick == 0:
        return True
    return step_in_trial(t, k) == 2 if trials_restart(t) else k == 2


@numba.njit(cache=True, error_model="numpy", inline="always")
def ticks_at(t: TimelineSettings, k: int) -> bool:
    """Whether the robot ticks its tree at step ``k``."""
    if k % t.steps_per_tick != 0:
        return False
    return t.profile == PAPER or step_in_trial(t, k) > t.initial_step


@numba.njit(cache=True, error_model="numpy", inline="always")
def tick_number(t: TimelineSettings, k: int) -> int:
    """The 0-based number within the chain of the tick at step ``k`` (a tick step): the tree's draw
    counter."""
    if t.profile == PAPER:
        return k // t.steps_per_tick - 1
    return (step_in_trial(t, k) - t.initial_step) // t.steps_per_tick - 1


@numba.njit(cache=True, error_model="numpy", inline="always")
def is_initial(t: TimelineSettings, k: int) -> bool:
    """Whether step ``k`` takes a trial's initial values."""
    return step_in_trial(t, k) == t.initial_step


@numba.njit(cache=True, error_model="numpy", inline="always")
def is_final(t: TimelineSettings, k: int) -> bool:
    """Whether step ``k`` is a trial's last: final values, descriptors, counters reset."""
    return step_in_trial(t, k) == trial_steps(t)
