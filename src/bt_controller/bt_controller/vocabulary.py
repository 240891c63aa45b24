"""The names of the behaviour-tree nodes and what they mean to a footbot (paper, tables 2-4).

This module is the one source of truth for node names and their order: blackboards are ``N_CONDITIONS``
booleans in ``CONDITIONS`` order, actions are indexed in ``ACTIONS`` order, and every other module refers to
these.
"""

from __future__ import annotations

COMPOSITES: tuple[str, ...] = ("seq", "sel", "prob")
"""Sequence, selector and probabilistic composites, all with memory."""

DECORATORS: tuple[str, ...] = ("success",)
"""Inner nodes with exactly one child: ``success(X)`` ticks X and returns success where X failed, else X's
status; it has no memory of its own (the authors' ``successd``, ``CNode.cpp:508-513`` at a73e4af;
BehaviorTree.CPP's ``ForceSuccess``)."""

MIN_CHILDREN = 2
MAX_CHILDREN = 4

CONDITIONS: tuple[str, ...] = (
    "on_food",
    "in_nest",
    "food_left",
    "food_right",
    "nest_left",
    "nest_right",
    "robot_left",
    "robot_right",
    "got_food",
)
"""Blackboard entries; a condition node succeeds when its entry is true. ``got_food``: the robot carries food
(it sensed food since its last delivery or its trial's start; ``docs/model.md``, "Foraging"). It comes last
so that the 2023 conditions keep their indices."""

N_CONDITIONS = len(CONDITIONS)
"""Entries of a blackboard."""

CONDITIONS_2023: tuple[str, ...] = CONDITIONS[:8]
"""The conditions of the paper's table 3 (every condition but ``got_food``): the node set of the 2023
experiment as this project runs it."""

ACTIONS: tuple[str, ...] = (
    "stop",
    "forward",
    "forward_left",
    "forward_right",
    "reverse",
    "reverse_left",
    "reverse_right",
)
"""Locomotion actions; each sets the wheels for one tick."""

ACTION_WHEELS: tuple[tuple[int, int], ...] = (
    (0, 0),  # stop
    (1, 1),  # forward
    (0, 1),  # forward_left: right wheel forwards, anticlockwise
    (1, 0),  # forward_right: left wheel forwards, clockwise
    (-1, -1),  # reverse
    (0, -1),  # reverse_left: right wheel in reverse, clockwise
    (-1, 0),  # reverse_right: left wheel in reverse, anticlockwise
)
"""(left, right) wheel speeds of each action, in units of the nominal wheel speed."""

STOP = ACTIONS.index("stop")

SUCCESS, FAILURE, RUNNING = 0, 1, 2
STATUS_NAMES: tuple[str, ...] = ("success", "failure", "running")

CONDITION_INDEX: dict[str, int] = {name: i for i, name in enumerate(CONDITIONS)}
ACTION_INDEX: dict[str, int] = {name: i for i, name in enumerate(ACTIONS)}
