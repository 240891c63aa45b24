"""The reference interpreter: the readable definition of one tick of a tree for one robot.

This module *is* the meaning of a behaviour tree in this project (``docs/model.md``, section
"Behaviour trees"); the compiled interpreter (``bt_controller.interpreters.compiled``) is tested against it
tick for tick. All state is explicit and laid out exactly as the compiled interpreter's: ``memory`` has one
int entry per node in pre-order (root 0) -- for a composite the remembered child position (-1 for none), for
an action 1 when it returned running on its last tick (else 0), for a condition always 0.

One tick (``tick``):

- sequence: resume at the remembered child (the first if none); a failure clears memory and fails; running is
  remembered and returned; success moves on to the next child; all succeeded clears memory and succeeds.
- selector: the same with success and failure swapped.
- probabilistic: its current child is remembered; under ``paper`` the first is child 0 (A3), under ``clean``
  none; with no remembered child, pick one uniformly at random with the counter-based draw
  ``choose(derive(key, tick_index), draw_key, n_children)`` (``docs/interfaces.md``), where ``draw_key`` is
  the node's own key (``prob@K``) or else its pre-order index (``tree.draw_key_at``); tick it; running is
  remembered and returned; otherwise clear memory and return the child's status.
- condition: success if its blackboard entry is true, else failure; counted in ``counts[0]``.
- action: if it is not running, it starts (counted in ``counts[1 + action]``) and returns running; if it
  returned running last tick, it returns success now.
- success decorator: ticks its child and returns success where the child failed, else the child's status; it
  has no memory of its own (its entry is 0 while its child runs, -1 otherwise, as a composite's remembered
  position: the compiled interpreter keeps it so) and counts nothing (``CNode.cpp:508-513`` at a73e4af).

Why not py_trees for the definition: py_trees' ``Sequence``/``Selector(memory=True)`` do match our composites
(``bt_controller.interpreters.pytrees`` maps our trees onto them and ``test_pytrees.py`` shows it agrees with
this module tick for tick), but their state lives inside behaviour objects (status, ``current_child``,
``initialise``/``terminate`` hooks) rather than in the one array the compiled kernel shares, the probabilistic
composite, the counter-based draw and the counting would be our own code anyway, and a py_trees tick (a
generator walk) is slower still than this one. So the definition is this plain function, and py_trees is an
optional view for its displays and tools.
"""

from __future__ import annotations

from collections.abc import MutableSequence, Sequence

import numpy as np

from bt_controller.draws import choose, derive
from bt_controller.language.tree import Action, Composite, Condition, Node, check_tick_depth, draw_key_at
from bt_controller.language.vocabulary import ACTION_WHEELS, ACTIONS, FAILURE, RUNNING, STOP, SUCCESS
from bt_controller.model_settings import PAPER

N_COUNTS = 1 + len(ACTIONS)
"""Length of a counts vector: condition-node ticks, then starts of each action."""


def new_memory(tree: Node, profile: int = PAPER) -> list[int]:
    """Fresh memory for ``tree``: -1 (nothing remembered) for composites, 0 for leaves; under ``paper`` a
    probabilistic composite starts at its first child (A3: ``CNode.cpp:108-113``)."""
    return [
        (0 if profile == PAPER and node.kind == "prob" else -1) if isinstance(node, Composite) else 0
        for node in tree.preorder()
    ]


def new_counts() -> list[int]:
    """A zeroed counts vector (see ``N_COUNTS``)."""
    return [0] * N_COUNTS


def tick(
    tree: Node,
    memory: MutableSequence[int],
    blackboard: Sequence[bool] | np.ndarray,
    key: int,
    tick_index: int,
    counts: MutableSequence[int],
) -> tuple[int, int]:
    """Tick the root of ``tree`` once; update ``memory`` and ``counts`` in place.

    Returns ``(status, action)``: the root status and the index of the action started by this tick, or -1
    when none started. ``key`` is the robot's tree stream key, ``tick_index`` the 0-based tick in the trial.
    Trees deeper than ``tree.MAX_TICK_DEPTH`` are refused (TreeLimitError): the tick recurses.
    """
    check_tick_depth(tree, "reference interpreter")
    started = -1

    def run(node: Node, index: int) -> int:
        nonlocal started
        if isinstance(node, Condition):
            counts[0] += 1
            return SUCCESS if blackboard[node.index] else FAILURE
        if isinstance(node, Action):
            if memory[index]:
                memory[index] = 0
                return SUCCESS
            memory[index] = 1
            counts[1 + node.index] += 1
            started = node.index
            return RUNNING
        assert isinstance(node, Composite)
        if node.kind == "success":
            status = run(node.children[0], index + 1)
            memory[index] = 0 if status == RUNNING else -1
            return SUCCESS if status == FAILURE else status
        child_indices = _child_indices(node, index)
        n = len(node.children)
        if node.kind == "prob":
            position = memory[index]
            if position < 0:
                draw_key = draw_key_at(node, index)
                position = int(choose(np.uint64(derive(np.uint64(key), tick_index)), draw_key, n))
            status = run(node.children[position], child_indices[position])
            memory[index] = position if status == RUNNING else -1
            return status
        # seq stops at the first failure, sel at the first success; otherwise they move on.
        stop_at, exhausted = (FAILURE, SUCCESS) if node.kind == "seq" else (SUCCESS, FAILURE)
        for position in range(max(memory[index], 0), n):
            status = run(node.children[position], child_indices[position])
            if status == RUNNING:
                memory[index] = position
                return RUNNING
            if status == stop_at:
                memory[index] = -1
                return status
        memory[index] = -1
        return exhausted

    status = run(tree, 0)
    return status, started


def _child_indices(node: Composite, index: int) -> list[int]:
    """Pre-order indices of the children of the composite at pre-order ``index``."""
    indices = []
    next_index = index + 1
    for child in node.children:
        indices.append(next_index)
        next_index += child.size
    return indices


def wheels(status: int, action: int) -> tuple[int, int]:
    """Wheel speeds (left, right) for the next 0.5 s: the started action's while running, else stop."""
    return ACTION_WHEELS[action] if status == RUNNING and action >= 0 else ACTION_WHEELS[STOP]


class ReferenceRobot:
    """One robot running a tree: its memory, counts, stream key and tick counter, ticked by ``step``."""

    def __init__(self, tree: Node, key: int, profile: int = PAPER) -> None:
        self.tree = check_tick_depth(tree, "reference interpreter")
        self.key = int(key)
        self.memory = new_memory(tree, profile)
        self.counts = new_counts()
        self.tick_index = 0

    def step(self, blackboard: Sequence[bool] | np.ndarray) -> tuple[int, int]:
        """Tick once with ``blackboard`` and advance the tick counter; returns ``(status, action)``."""
        result = tick(self.tree, self.memory, blackboard, self.key, self.tick_index, self.counts)
        self.tick_index += 1
        return result
