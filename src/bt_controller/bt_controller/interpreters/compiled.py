"""The compiled interpreter: flat trees and a numba tick loop, tick-for-tick equal to ``semantics``.

The layout is the contract of ``docs/interfaces.md`` ("Compiled tree interpreter"): a tree is flattened in
pre-order (root 0, indices local to the tree) to

- ``op`` int8: 0 seq, 1 sel, 2 prob, 3 condition, 4 action, 5 success (the decorator: one child);
- ``arg`` int8: condition or action index, -1 for composites;
- ``first`` int32: index into ``children`` of the node's first child (-1 for leaves);
- ``nchild`` int8: number of children (0 for leaves);
- ``children`` int32: the children of every composite, composite after composite in pre-order;
- ``draw`` int32: a probabilistic composite's draw key (``tree.draw_key_at``: its own ``prob@K`` or its
  pre-order index), -1 for every other node.

The six arrays travel together as a ``FlatTree`` and many trees as one ``PackedTrees`` (named tuples of
arrays, which numba passes to kernels whole); ``tree_at`` is the one place a pack is cut into trees.

A pack may also hold neural controllers (``bt_controller.interpreters.network``): a network is packed as a
single node of op 6 (``OP_NETWORK``) and its weights are row ``t`` of the pack's ``weights`` (every row but a
network's is unused; the array has no columns when the pack holds no network). The batch kernels run a network
in place of a tree (``network.act``); the tick functions of this module take trees only.

Per robot, ``memory`` is int8 with one entry per node (see ``semantics``). ``tick`` is an ``njit`` function
that other compiled kernels call with a ``FlatTree``; ``tick_batch`` and ``run_ticks`` tick many robots of
many packed trees. ``tick`` walks the tree with an explicit stack of ancestors that lives on the machine stack
(no allocation per tick), so a flat tree may be at most ``MAX_COMPILED_DEPTH`` deep.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any, NamedTuple

import numba
import numpy as np
from numba import types
from numba.core import cgutils
from numba.extending import intrinsic

import bt_controller.lean_numba  # noqa: F401  (numba without scipy and cffi: see there)
from bt_controller.draws import choose, derive
from bt_controller.interpreters.network import N_WEIGHTS, Network
from bt_controller.language.tree import (
    MAX_TICK_DEPTH,
    Action,
    Composite,
    Condition,
    Node,
    check_tick_depth,
    draw_key_at,
)
from bt_controller.language.vocabulary import ACTIONS, FAILURE, N_CONDITIONS, RUNNING, SUCCESS
from bt_controller.model_settings import PAPER

OP_SEQ, OP_SEL, OP_PROB, OP_CONDITION, OP_ACTION, OP_SUCCESS = 0, 1, 2, 3, 4, 5
OP_NETWORK = 6
"""The one node of a packed network (see the module docstring)."""
_OP_OF_KIND = {"seq": OP_SEQ, "sel": OP_SEL, "prob": OP_PROB, "success": OP_SUCCESS}
N_COUNTS = 1 + len(ACTIONS)
MAX_COMPILED_DEPTH = MAX_TICK_DEPTH
"""Deepest tree ``flatten`` accepts (the tick's ancestor stack has MAX_COMPILED_DEPTH + 1 slots)."""
_STACK_SLOTS = MAX_COMPILED_DEPTH + 1


class FlatTree(NamedTuple):
    """One tree flattened in pre-order (see the module docstring). Kernels receive it whole."""

    op: np.ndarray
    arg: np.ndarray
    first: np.ndarray
    nchild: np.ndarray
    children: np.ndarray
    draw: np.ndarray

    @property
    def n_nodes(self) -> int:
        """Number of nodes."""
        return len(self.op)


def flatten(tree: Node) -> FlatTree:
    """Flatten ``tree`` to the contract's arrays; raise TreeLimitError if deeper than MAX_COMPILED_DEPTH."""
    check_tick_depth(tree, "compiled interpreter")
    nodes = list(tree.preorder())
    op = np.empty(len(nodes), np.int8)
    arg = np.full(len(nodes), -1, np.int8)
    first = np.full(len(nodes), -1, np.int32)
    nchild = np.zeros(len(nodes), np.int8)
    draw = np.full(len(nodes), -1, np.int32)
    children: list[int] = []  # composite after composite, in pre-order
    for index, node in enumerate(nodes):
        if isinstance(node, Composite):
            op[index] = _OP_OF_KIND[node.kind]
            first[index] = len(children)
            nchild[index] = len(node.children)
            if node.kind == "prob":
                draw[index] = draw_key_at(node, index)
            child = index + 1  # the first child follows its parent in pre-order ...
            for sibling in node.children:
                children.append(child)
                child += sibling.size  # ... and each next one follows the previous one's subtree
        elif isinstance(node, Condition):
            op[index], arg[index] = OP_CONDITION, node.index
        elif isinstance(node, Action):
            op[index], arg[index] = OP_ACTION, node.index
        else:
            raise TypeError(f"not a tree node: {type(node).__name__}")
    return FlatTree(op, arg, first, nchild, np.asarray(children, np.int32), draw)


class PackedTrees(NamedTuple):
    """Many flat trees concatenated; tree ``t`` owns nodes ``node_offset[t]:node_offset[t + 1]`` and
    children ``child_offset[t]:child_offset[t + 1]`` (values inside stay local to the tree). Kernels receive
    it whole and take a tree's views with ``tree_at``."""

    op: np.ndarray
    arg: np.ndarray
    first: np.ndarray
    nchild: np.ndarray
    children: np.ndarray
    draw: np.ndarray
    node_offset: np.ndarray
    child_offset: np.ndarray
    weights: np.ndarray
    """float64 (trees, ``network.N_WEIGHTS``): row ``t`` holds network ``t``'s weights (no columns when the
    pack holds no network)."""

    @property
    def n_trees(self) -> int:
        """Number of trees."""
        return len(self.node_offset) - 1

    @property
    def max_nodes(self) -> int:
        """Node count of the largest tree (the width of a memory table)."""
        return int(np.diff(self.node_offset).max(initial=0))

    def tree(self, t: int) -> FlatTree:
        """Views of tree ``t``'s arrays (``tree_at`` from Python)."""
        return tree_at(self, t)


def _network_node() -> FlatTree:
    """The flat form of a network: one node of op ``OP_NETWORK`` (its weights go in the pack)."""
    return FlatTree(
        np.array([OP_NETWORK], np.int8),
        np.full(1, -1, np.int8),
        np.full(1, -1, np.int32),
        np.zeros(1, np.int8),
        np.zeros(0, np.int32),
        np.full(1, -1, np.int32),
    )


def pack(trees: Sequence[Node | FlatTree | Network]) -> PackedTrees:
    """Flatten (if needed) and concatenate ``trees``; a network is packed as ``OP_NETWORK`` with its
    weights."""
    flats = [
        t if isinstance(t, FlatTree) else _network_node() if isinstance(t, Network) else flatten(t)
        for t in trees
    ]
    networks = [(k, t) for k, t in enumerate(trees) if isinstance(t, Network)]
    weights = np.zeros((len(flats), N_WEIGHTS if networks else 0))
    for k, network in networks:
        weights[k] = network.weights
    node_offset = np.zeros(len(flats) + 1, np.int64)
    child_offset = np.zeros(len(flats) + 1, np.int64)
    node_offset[1:] = np.cumsum([f.n_nodes for f in flats])
    child_offset[1:] = np.cumsum([len(f.children) for f in flats])

    def cat(name: str, dtype: type) -> np.ndarray:
        parts = [getattr(f, name) for f in flats]
        return np.concatenate(parts).astype(dtype, copy=False) if parts else np.empty(0, dtype)

    return PackedTrees(
        cat("op", np.int8),
        cat("arg", np.int8),
        cat("first", np.int32),
        cat("nchild", np.int8),
        cat("children", np.int32),
        cat("draw", np.int32),
        node_offset,
        child_offset,
        weights,
    )


# ---------------------------------------------------------------------------------------------- kernels


@intrinsic
def _stack_slots(typingctx: object, n: types.Type) -> tuple[object, object] | None:
    """A pointer to ``n`` int32 slots on the machine stack of the calling function (``n`` a literal)."""
    if not isinstance(n, types.IntegerLiteral):
        return None
    size = n.literal_value

    def codegen(context: Any, builder: Any, signature: object, args: object) -> Any:  # numba's code generator
        return cgutils.alloca_once(builder, context.get_value_type(types.int32), size=size)

    return types.CPointer(types.int32)(n), codegen


@numba.njit(cache=True, error_model="numpy", inline="always")
def tree_at(trees: PackedTrees, t: int) -> FlatTree:
    """Views of tree ``t`` of a pack: the one place where a pack is cut into trees."""
    a, b = trees.node_offset[t], trees.node_offset[t + 1]
    c, d = trees.child_offset[t], trees.child_offset[t + 1]
    return FlatTree(
        trees.op[a:b],
        trees.arg[a:b],
        trees.first[a:b],
        trees.nchild[a:b],
        trees.children[c:d],
        trees.draw[a:b],
    )


@numba.njit(cache=True, error_model="numpy")
def reset_memory(op: np.ndarray, memory: np.ndarray) -> None:
    """Set ``memory`` to the fresh state of the tree ``op``: -1 for inner nodes, 0 for leaves."""
    for i in range(len(op)):
        memory[i] = -1 if op[i] <= OP_PROB or op[i] == OP_SUCCESS else 0


@numba.njit(cache=True, error_model="numpy")
def start_memory(op: np.ndarray, memory: np.ndarray, profile: int) -> None:
    """Set ``memory`` to the state a tree starts a chain with: ``reset_memory``, and under ``paper`` every
    probabilistic composite at its first child (A3, as ``semantics.new_memory``)."""
    reset_memory(op, memory)
    if profile == PAPER:
        for i in range(len(op)):
            if op[i] == OP_PROB:
                memory[i] = 0


@numba.njit(cache=True, error_model="numpy", inline="always")
def tick(
    tree: FlatTree,
    memory: np.ndarray,
    blackboard: np.ndarray,
    key: np.uint64,
    tick_index: int,
    counts: np.ndarray,
) -> tuple[int, int]:
    """Tick the root once; update ``memory`` and ``counts``; return ``(status, action started or -1)``.

    Semantics, memory and counts exactly as ``bt_controller.interpreters.semantics.tick``. ``blackboard`` is
    any array of ``N_CONDITIONS`` values read as booleans; ``key`` the robot's uint64 tree stream key;
    ``tick_index`` the 0-based tick.
    Inlined into calling kernels (a call would cost more than the tick itself).
    """
    # Locals: a field read inside the loop would cost a refcount.
    op, arg, first, nchild, children, draw = tree
    # Ancestors of ``node``, indexed as a raw pointer (an array view would need reference counting, which
    # the kernels inlining this go without).
    stack: Any = _stack_slots(_STACK_SLOTS)  # type: ignore[call-arg]  # an intrinsic: numba passes the typing context
    depth = 0
    node = 0
    while True:
        # Descend from ``node`` to a leaf, remembering the position taken at each composite.
        kind = op[node]
        while kind <= OP_PROB or kind == OP_SUCCESS:
            position = memory[node]
            if position < 0:
                position = choose(derive(key, tick_index), draw[node], nchild[node]) if kind == OP_PROB else 0
                memory[node] = position
            stack[depth] = node
            depth += 1
            node = children[first[node] + position]
            kind = op[node]
        # The leaf.
        if kind == OP_CONDITION:
            counts[0] += 1
            status = np.int64(FAILURE if blackboard[arg[node]] == 0 else SUCCESS)
        elif memory[node] == 0:
            memory[node] = 1
            action = np.int64(arg[node])
            counts[1 + action] += 1
            # Running climbs to the root with every position on the way already remembered.
            return np.int64(RUNNING), action
        else:
            memory[node] = 0
            status = np.int64(SUCCESS)
        # Climb while composites finish. A sequence (op 0) moves on after SUCCESS (0) and a selector (op 1)
        # after FAILURE (1), i.e. when ``status == op``; when it has no next child it finishes with that
        # same status. A probabilistic composite (op 2) always finishes with its child's status, a success
        # decorator (op 5, one child) with success.
        while depth > 0:
            parent = stack[depth - 1]
            if status == op[parent]:
                position = memory[parent] + 1
                if position < nchild[parent]:
                    memory[parent] = position
                    node = children[first[parent] + position]
                    break  # descend into the next child
            memory[parent] = -1
            if op[parent] == OP_SUCCESS:
                status = np.int64(SUCCESS)
            depth -= 1
        else:
            return status, np.int64(-1)


@numba.njit(cache=True, error_model="numpy")
def tick_batch(
    trees: PackedTrees,
    robot_tree: np.ndarray,
    memory: np.ndarray,
    blackboards: np.ndarray,
    keys: np.ndarray,
    tick_index: int,
    counts: np.ndarray,
    status_out: np.ndarray,
    action_out: np.ndarray,
) -> None:
    """Tick every robot ``r`` once with tree ``robot_tree[r]`` of a pack, memory row ``memory[r]``,
    blackboard ``blackboards[r]``, key ``keys[r]`` and counts row ``counts[r]``; write status and action."""
    for r in range(len(robot_tree)):
        tree = tree_at(trees, robot_tree[r])
        status, action = tick(
            tree, memory[r, : tree.op.shape[0]], blackboards[r], keys[r], tick_index, counts[r]
        )
        status_out[r] = status
        action_out[r] = action


@numba.njit(cache=True, error_model="numpy")
def run_ticks_kernel(
    trees: PackedTrees,
    robot_tree: np.ndarray,
    memory: np.ndarray,
    blackboards: np.ndarray,
    keys: np.ndarray,
    counts: np.ndarray,
    status_out: np.ndarray,
    action_out: np.ndarray,
) -> None:
    """Tick every robot ``r`` with tree ``robot_tree[r]`` through its blackboards ``blackboards[r, k]``
    (tick index ``k``); write status and action per robot and tick (``run_ticks`` from Python)."""
    for r in range(len(robot_tree)):
        tree = tree_at(trees, robot_tree[r])
        row = memory[r, : tree.op.shape[0]]
        for k in range(blackboards.shape[1]):
            status, action = tick(tree, row, blackboards[r, k], keys[r], k, counts[r])
            status_out[r, k] = status
            action_out[r, k] = action


@dataclass(frozen=True)
class Run:
    """What ``run_ticks`` returns: per tick and robot the status and action, and the final state."""

    status: np.ndarray  # int8 (robots, ticks)
    action: np.ndarray  # int8 (robots, ticks)
    counts: np.ndarray  # int64 (robots, N_COUNTS)
    memory: np.ndarray  # int8 (robots, max_nodes)


@numba.njit(cache=True, error_model="numpy")
def _reset_rows(trees: PackedTrees, robot_tree: np.ndarray, memory: np.ndarray, profile: int) -> None:
    for r in range(len(robot_tree)):
        op = tree_at(trees, robot_tree[r]).op
        start_memory(op, memory[r, : op.shape[0]], profile)


def new_memory(packed: PackedTrees, robot_tree: np.ndarray, profile: int = PAPER) -> np.ndarray:
    """Fresh memory rows (robots, max_nodes) for robots running ``robot_tree`` of ``packed``
    (``start_memory``)."""
    robot_tree = np.asarray(robot_tree, np.int64)
    memory = np.zeros((len(robot_tree), max(packed.max_nodes, 1)), np.int8)
    _reset_rows(packed, robot_tree, memory, profile)
    return memory


def run_ticks(
    packed: PackedTrees,
    robot_tree: np.ndarray,
    keys: np.ndarray,
    blackboards: np.ndarray,
    profile: int = PAPER,
) -> Run:
    """Tick robots from fresh memory for ``blackboards.shape[1]`` ticks (tick indices 0, 1, ...).

    ``robot_tree`` (robots,) picks each robot's tree in ``packed``; ``keys`` (robots,) uint64 stream keys;
    ``blackboards`` (robots, ticks, ``N_CONDITIONS``), each robot's sequence of blackboards (bool or int).
    """
    robot_tree = np.asarray(robot_tree, np.int64)
    keys = np.asarray(keys, np.uint64)
    n_robots = len(robot_tree)
    if blackboards.ndim != 3 or blackboards.shape[0] != n_robots or blackboards.shape[2] != N_CONDITIONS:
        raise ValueError(
            f"need blackboards of shape ({n_robots}, ticks, {N_CONDITIONS}), got {blackboards.shape}"
        )
    if keys.shape != (n_robots,):
        raise ValueError(f"need keys of shape ({n_robots},), got {keys.shape}")
    n_ticks = blackboards.shape[1]
    if n_robots and (robot_tree.min() < 0 or robot_tree.max() >= packed.n_trees):
        raise ValueError(f"robot_tree must index the {packed.n_trees} packed trees")
    memory = new_memory(packed, robot_tree, profile)
    counts = np.zeros((n_robots, N_COUNTS), np.int64)
    status = np.empty((n_robots, n_ticks), np.int8)
    action = np.empty((n_robots, n_ticks), np.int8)
    run_ticks_kernel(packed, robot_tree, memory, blackboards, keys, counts, status, action)
    return Run(status, action, counts, memory)


class CompiledRobot:
    """One robot ticking a flat tree from Python (for tests and tools; kernels call ``tick`` directly)."""

    def __init__(self, tree: Node | FlatTree, key: int, profile: int = PAPER) -> None:
        self.flat = tree if isinstance(tree, FlatTree) else flatten(tree)
        self.key = np.uint64(key)
        self.memory = np.empty(self.flat.n_nodes, np.int8)
        start_memory(self.flat.op, self.memory, profile)
        self.counts = np.zeros(N_COUNTS, np.int64)
        self.tick_index = 0

    def step(self, blackboard: Sequence[bool] | np.ndarray) -> tuple[int, int]:
        """Tick once with ``blackboard`` and advance the tick counter; returns ``(status, action)``."""
        board = np.asarray(blackboard, np.bool_)
        status, action = tick(self.flat, self.memory, board, self.key, self.tick_index, self.counts)
        self.tick_index += 1
        return int(status), int(action)
