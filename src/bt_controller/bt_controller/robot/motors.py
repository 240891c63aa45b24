"""What drives a footbot's wheels after a tick, and how the descriptors count it (``docs/model.md``).

Every action ticked sets the motors to its command, on its starting tick (running) and on its finishing tick
(success), and each tick starts from stop (``footbot_bt.cpp:506``, ``CNode.cpp:456-532``), so the last action
ticked wins. The interpreters report the action a tick *started*; the last action ticked follows from it:

- a tick that returns running ended at the action it started (running climbs straight to the root);
- otherwise the only action it can have ticked is the one that was running since the last tick, which
  finishes first thing (memory leads back to it); any later action would have started and returned running.

So the motors after a tick are ``motors_after_tick(status, started, resumed)`` with ``resumed`` the action
left running by the previous tick (``running_action``), and no interpreter needs to change.
"""

from __future__ import annotations

import numba

import bt_controller.lean_numba  # noqa: F401  (numba without scipy and cffi: see there)
from bt_controller.language.vocabulary import ACTION_INDEX, RUNNING, STOP

_FORWARD = ACTION_INDEX["forward"]
_REVERSE = ACTION_INDEX["reverse"]
_FORWARD_LEFT = ACTION_INDEX["forward_left"]
_FORWARD_RIGHT = ACTION_INDEX["forward_right"]
_REVERSE_LEFT = ACTION_INDEX["reverse_left"]
_REVERSE_RIGHT = ACTION_INDEX["reverse_right"]


@numba.njit(cache=True, error_model="numpy")
def running_action(status: int, started: int) -> int:
    """The action a tick leaves running (finishing at the next tick), or -1."""
    return started if status == RUNNING else -1


@numba.njit(cache=True, error_model="numpy")
def motors_after_tick(status: int, started: int, resumed: int) -> int:
    """The motors (an action index) after a tick that returned ``status`` and started ``started`` (-1 for
    none), ``resumed`` being the action the previous tick left running (-1 for none)."""
    if status == RUNNING:
        return started
    if resumed >= 0:
        return resumed
    return STOP


@numba.njit(cache=True, error_model="numpy")
def movement_of(motors: int) -> int:
    """A tick's contribution to the movement descriptor: +1 forward, -1 reverse
    (``CBlackBoard.cpp:494-504``)."""
    if motors == _FORWARD:
        return 1
    if motors == _REVERSE:
        return -1
    return 0


@numba.njit(cache=True, error_model="numpy")
def rotation_of(motors: int) -> int:
    """A tick's contribution to the rotation descriptor: +1 forward_left or reverse_right, -1 forward_right or
    reverse_left (``CBlackBoard.cpp:506-516``)."""
    if motors in (_FORWARD_LEFT, _REVERSE_RIGHT):
        return 1
    if motors in (_FORWARD_RIGHT, _REVERSE_LEFT):
        return -1
    return 0
