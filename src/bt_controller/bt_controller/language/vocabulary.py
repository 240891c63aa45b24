"""The names of the behaviour-tree nodes and what they mean to a footbot (paper, tables 2-4).

This module is the one source of truth for node names and their order: blackboards are ``N_CONDITIONS``
booleans in ``CONDITIONS`` order, actions are indexed in ``ACTIONS`` order, and every other module refers to
these.
"""

from __future__ import annotations

from typing import NamedTuple

COMPOSITES: tuple[str, ...] = ("seq", "sel", "prob")
"""Sequence, selector and probabilistic composites, all with memory."""

DECORATORS: tuple[str, ...] = ("success",)
"""Inner nodes with exactly one child: ``success(X)`` ticks X and returns success where X failed, else X's
status; it has no memory of its own (the authors' ``successd``, ``CNode.cpp:508-513`` at a73e4af;
BehaviorTree.CPP's ``ForceSuccess``)."""

MIN_CHILDREN = 2
MAX_CHILDREN = 4


class Condition(NamedTuple):
    """One row of the conditions table: what a condition node reads, declared once.

    ``reads`` names what the task's world must offer for the condition to mean anything: a region kind
    (``nest``, ``food``) or ``robots`` (the neighbours heard). ``side``: for a condition that says on which
    side of the robot something lies, the side pair of the blackboard whose bearing it needs (``SIDES``);
    None for the others. The batch kernels compute a bearing only for a side pair some condition of the tree
    reads, and they take that from this table, so a new row needs no edit there.
    """

    name: str
    reads: tuple[str, ...]
    side: str | None
    doc: str


REGIONS: tuple[str, ...] = ("nest", "food", "food2", "food3")
"""The region kinds a robot perceives, in the order of its perception's arrays: the nest and up to three kinds
of food (the authors' 2026 code, ``docs/model.md``, "Food kinds"). ``food`` is kind 1; a task's world has the
nest and its first ``1 + kinds`` entries. Every estimate and ground reading is kept per region."""

MAX_FOOD_KINDS = len(REGIONS) - 1

SIDES: tuple[str, ...] = ("nest", "food", "robot", "food2", "food3")
"""The blackboard's side pairs, in the order the batch kernels index them: a region's pair and its smoothed
value share a column (``region_column``), the nearest robot's pair the column of the density."""


def region_column(region: int) -> int:
    """The column of region ``region`` (``REGIONS`` order) in a robot's smoothed values (nest, food, density,
    food2, food3) and in its side pairs (``SIDES``): the 2023 columns first, so that a world of one food kind
    keeps the arrays it always had."""
    return region if region < 2 else region + 1


def food_kind_name(kind: int) -> str:
    """The region name of food kind ``kind`` (1-based): ``food``, ``food2``, ``food3``."""
    return "food" if kind == 1 else f"food{kind}"


CONDITION_TABLE: tuple[Condition, ...] = (
    Condition("on_food", ("food",), None, "the ground sensor reads food"),
    Condition("in_nest", ("nest",), None, "the ground sensor reads the nest"),
    Condition("food_left", ("food",), "food", "the food estimate's source is on the left"),
    Condition("food_right", ("food",), "food", "the food estimate's source is on the right"),
    Condition("nest_left", ("nest",), "nest", "the nest estimate's source is on the left"),
    Condition("nest_right", ("nest",), "nest", "the nest estimate's source is on the right"),
    Condition("robot_left", ("robots",), "robot", "the nearest robot heard is on the left"),
    Condition("robot_right", ("robots",), "robot", "the nearest robot heard is on the right"),
    Condition("got_food", ("food", "nest"), None, "the robot carries food"),
    *(
        row
        for kind in range(1, MAX_FOOD_KINDS + 1)
        for row in (
            Condition(
                f"on_food{kind}",
                (food_kind_name(kind),),
                None,
                f"the ground sensor reads food of kind {kind}",
            ),
            Condition(
                f"got_food{kind}",
                (food_kind_name(kind), "nest"),
                None,
                f"the robot carries food of kind {kind}",
            ),
            Condition(
                f"food_left{kind}",
                (food_kind_name(kind),),
                food_kind_name(kind),
                f"the estimate's source for food of kind {kind} is on the left",
            ),
            Condition(
                f"food_right{kind}",
                (food_kind_name(kind),),
                food_kind_name(kind),
                f"the estimate's source for food of kind {kind} is on the right",
            ),
        )
    ),
)
"""Every condition, in blackboard order. ``got_food``: the robot carries food (it sensed food since its last
delivery or its trial's start; ``docs/model.md``, "Foraging"). It comes after the 2023 conditions so that
they keep their indices; then the numbered conditions of the 2026 food kinds, four per kind (``on_food1``
reads what ``on_food`` reads: the unnumbered ones are kind 1's, as in the authors' code)."""

CONDITIONS: tuple[str, ...] = tuple(row.name for row in CONDITION_TABLE)
"""Blackboard entries, in order; a condition node succeeds when its entry is true."""

CONDITION_SIDE: tuple[int, ...] = tuple(
    -1 if row.side is None else SIDES.index(row.side) for row in CONDITION_TABLE
)
"""For each condition, the index in ``SIDES`` of the side pair whose bearing it needs, or -1."""

N_CONDITIONS = len(CONDITIONS)
"""Entries of a blackboard."""

CONDITIONS_2023: tuple[str, ...] = CONDITIONS[:8]
"""The conditions of the paper's table 3 (every condition but ``got_food``): the node set of the 2023
experiment as this project runs it."""

CONDITIONS_2024: tuple[str, ...] = CONDITIONS[:9]
"""The 2023 conditions and ``got_food``: the node set of the 2024 foraging study, and of a task that names
none."""

MULTIFOOD_CONDITIONS: tuple[str, ...] = (
    "in_nest",
    "nest_left",
    "nest_right",
    *(f"{c}{kind}" for c in ("on_food", "got_food", "food_left", "food_right") for kind in (1, 2, 3)),
    "robot_left",
    "robot_right",
)
"""The authors' 2026 node set of multi-food foraging (``params.py:484-489`` at 1cd2358): the nest's
conditions, the twelve numbered food conditions and the neighbours'."""

NUMBERED_FOOD: int = 9
"""Blackboard index of the first numbered food condition (``on_food1``); kind k's four come at
``NUMBERED_FOOD + 4 (k - 1)``: on, got, left, right."""

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
