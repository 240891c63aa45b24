"""The interpreters: what a controller does at one tick, for one robot or for a whole batch (numba).

``semantics`` is the reference interpreter, the readable definition of a tick (``ReferenceRobot``; its own
``tick`` and ``new_memory`` are reached as ``semantics.tick``); ``compiled`` flat trees and the numba tick
loop that the simulator runs, tick for tick equal to the reference (its ``tick``, ``new_memory`` and batch
kernels are the ones offered here); ``network`` the neural controller beside the trees (the authors' 9-5-1
perceptron, its text ``nn(...)`` and file; its printer is offered as ``network_text``); ``agreement`` the
checker that runs both tree interpreters tick for tick; ``pytrees`` the same trees as py_trees behaviours
(imported by its own name: it loads py_trees).
"""

from bt_controller.interpreters.agreement import Mismatch, check_random, compare, random_forest
from bt_controller.interpreters.compiled import (
    MAX_COMPILED_DEPTH,
    N_COUNTS,
    OP_CONDITION,
    OP_NETWORK,
    CompiledRobot,
    FlatTree,
    PackedTrees,
    flatten,
    new_memory,
    pack,
    reset_memory,
    run_ticks,
    start_memory,
    tick,
    tick_batch,
    tree_at,
)
from bt_controller.interpreters.network import (
    INPUT_NAMES,
    INPUTS,
    N_INPUTS,
    N_WEIGHTS,
    Network,
    NetworkError,
    NetworkRobot,
    act,
    controller_text,
    is_network_text,
    load_network,
    network_document,
    parse_controller,
    parse_network,
)
from bt_controller.interpreters.network import to_text as network_text
from bt_controller.interpreters.semantics import ReferenceRobot, wheels

__all__ = [
    "INPUTS",
    "INPUT_NAMES",
    "MAX_COMPILED_DEPTH",
    "N_COUNTS",
    "N_INPUTS",
    "N_WEIGHTS",
    "OP_CONDITION",
    "OP_NETWORK",
    "CompiledRobot",
    "FlatTree",
    "Mismatch",
    "Network",
    "NetworkError",
    "NetworkRobot",
    "PackedTrees",
    "ReferenceRobot",
    "act",
    "check_random",
    "compare",
    "controller_text",
    "flatten",
    "is_network_text",
    "load_network",
    "network_document",
    "network_text",
    "new_memory",
    "pack",
    "parse_controller",
    "parse_network",
    "random_forest",
    "reset_memory",
    "run_ticks",
    "start_memory",
    "tick",
    "tick_batch",
    "tree_at",
    "wheels",
]
