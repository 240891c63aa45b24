"""The same trees as py_trees behaviours, for py_trees' displays and tools (optional: needs py_trees 2.x).

``reference`` remains the definition of a tick (see its docstring for why); this module maps our nodes onto
py_trees: ``seq`` -> ``py_trees.composites.Sequence(memory=True)``, ``sel`` -> ``Selector(memory=True)``,
``prob`` -> ``Probabilistic`` (below), ``success`` -> ``py_trees.decorators.FailureIsSuccess``, conditions
and actions -> small ``Behaviour`` subclasses. py_trees
composites with memory resume at the RUNNING child and restart once they finish, which is our semantics;
``test_pytrees.py`` checks status, action, counts and memory against the reference tick for tick.

State is not kept on py_trees' process-wide blackboard (two robots in one process would share it): every
behaviour of one robot reads the robot's ``PyTreesContext``.
"""

from __future__ import annotations

from collections.abc import Iterator, Sequence
from dataclasses import dataclass, field

import numpy as np
import py_trees

from bt_controller.draws import choose, derive
from bt_controller.language.tree import Action, Composite, Condition, Node, check_tick_depth, draw_key_at
from bt_controller.language.vocabulary import ACTIONS, CONDITIONS, FAILURE, RUNNING, SUCCESS
from bt_controller.model_settings import PAPER

_STATUS = {py_trees.common.Status.SUCCESS: SUCCESS, py_trees.common.Status.FAILURE: FAILURE,
           py_trees.common.Status.RUNNING: RUNNING}  # fmt: skip


@dataclass
class PyTreesContext:
    """What the behaviours of one robot read and write during a tick."""

    key: int
    blackboard: Sequence[bool] = (False,) * len(CONDITIONS)
    tick_index: int = 0
    started: int = -1
    counts: list[int] = field(default_factory=lambda: [0] * (1 + len(ACTIONS)))


class ConditionBehaviour(py_trees.behaviour.Behaviour):
    """Succeeds when the robot's blackboard entry is true."""

    def __init__(self, name: str, context: PyTreesContext) -> None:
        super().__init__(name=name)
        self.index = CONDITIONS.index(name)
        self.context = context

    def update(self) -> py_trees.common.Status:
        """Read the blackboard entry; count the tick."""
        self.context.counts[0] += 1
        ok = bool(self.context.blackboard[self.index])
        return py_trees.common.Status.SUCCESS if ok else py_trees.common.Status.FAILURE


class ActionBehaviour(py_trees.behaviour.Behaviour):
    """Runs on its first tick (the wheels are set), succeeds on the next."""

    def __init__(self, name: str, context: PyTreesContext) -> None:
        super().__init__(name=name)
        self.index = ACTIONS.index(name)
        self.context = context

    def update(self) -> py_trees.common.Status:
        """Succeed if it ran last tick, else start."""
        if self.status == py_trees.common.Status.RUNNING:
            return py_trees.common.Status.SUCCESS
        self.context.counts[1 + self.index] += 1
        self.context.started = self.index
        return py_trees.common.Status.RUNNING


class Probabilistic(py_trees.composites.Composite):
    """With no remembered child, tick one drawn uniformly with the counter-based draw; remember it while
    it runs; otherwise finish with its status."""

    def __init__(self, name: str, children: list[py_trees.behaviour.Behaviour], context: PyTreesContext,
                 draw_key: int, first_child: bool = False) -> None:  # fmt: skip
        super().__init__(name=name, children=children)
        self.context = context
        self.draw_key = draw_key
        """Its draw key (``tree.draw_key_at``: its own ``prob@K`` or its pre-order index)."""
        self.pending_first = first_child
        """Under ``paper`` the first child is child 0, not drawn (A3)."""

    def tick(self) -> Iterator[py_trees.behaviour.Behaviour]:
        """Tick the remembered child, or a newly drawn one."""
        if self.status != py_trees.common.Status.RUNNING:
            for child in self.children:
                if child.status != py_trees.common.Status.INVALID:
                    child.stop(py_trees.common.Status.INVALID)
            if self.pending_first:
                self.current_child = self.children[0]
            else:
                tick_key = np.uint64(derive(np.uint64(self.context.key), self.context.tick_index))
                self.current_child = self.children[int(choose(tick_key, self.draw_key, len(self.children)))]
        self.pending_first = False
        chosen = self.current_child
        assert chosen is not None, "a running probabilistic composite remembers its child"
        yield from chosen.tick()
        if chosen.status == py_trees.common.Status.RUNNING:
            self.status = py_trees.common.Status.RUNNING
        else:
            self.stop(chosen.status)
        yield self


def build(tree: Node, context: PyTreesContext, profile: int = PAPER) -> py_trees.behaviour.Behaviour:
    """The py_trees behaviour tree of ``tree`` whose behaviours use ``context``, under ``profile``; trees
    deeper than ``tree.MAX_TICK_DEPTH`` are refused (TreeLimitError: py_trees ticks recursively)."""
    check_tick_depth(tree, "py_trees mapping")
    counter = 0

    def make(node: Node) -> py_trees.behaviour.Behaviour:
        nonlocal counter
        index = counter
        counter += 1
        if isinstance(node, Condition):
            return ConditionBehaviour(node.name, context)
        if isinstance(node, Action):
            return ActionBehaviour(node.name, context)
        assert isinstance(node, Composite)
        children = [make(child) for child in node.children]
        if node.kind == "success":
            return py_trees.decorators.FailureIsSuccess(name="success", child=children[0])
        if node.kind == "seq":
            return py_trees.composites.Sequence(name="seq", memory=True, children=children)
        if node.kind == "sel":
            return py_trees.composites.Selector(name="sel", memory=True, children=children)
        return Probabilistic(
            node.head, children, context, draw_key_at(node, index), first_child=profile == PAPER
        )

    return make(tree)


class PyTreesRobot:
    """One robot ticking its tree with py_trees; the same interface as ``reference.ReferenceRobot``."""

    def __init__(self, tree: Node, key: int, profile: int = PAPER) -> None:
        self.context = PyTreesContext(key=int(key))
        self.root = build(tree, self.context, profile)
        self.tick_index = 0

    @property
    def counts(self) -> list[int]:
        """Condition-node ticks, then starts of each action."""
        return self.context.counts

    @property
    def memory(self) -> list[int]:
        """The reference's memory layout read off py_trees' state (running child; running action)."""
        result = []
        stack = [self.root]
        while stack:  # pre-order, as the reference numbers nodes
            behaviour = stack.pop()
            stack.extend(reversed(behaviour.children))
            running = behaviour.status == py_trees.common.Status.RUNNING
            if isinstance(behaviour, Probabilistic) and behaviour.pending_first:
                result.append(0)
            elif isinstance(behaviour, py_trees.decorators.Decorator):
                result.append(0 if running else -1)
            elif isinstance(behaviour, py_trees.composites.Composite):
                current = behaviour.current_child
                result.append(behaviour.children.index(current) if running and current is not None else -1)
            else:
                result.append(1 if isinstance(behaviour, ActionBehaviour) and running else 0)
        return result

    def step(self, blackboard: Sequence[bool]) -> tuple[int, int]:
        """Tick once with ``blackboard``; returns ``(status, action)`` as ``reference.tick``."""
        self.context.blackboard = blackboard
        self.context.tick_index = self.tick_index
        self.context.started = -1
        self.root.tick_once()
        self.tick_index += 1
        status = _STATUS[self.root.status]
        return status, self.context.started if status == RUNNING else -1
