"""bt_controller: the behaviour-tree engine of the swarm (see the package README).

The light public API is re-exported here (no numba, no matplotlib on import); the interpreters live in
``bt_controller.interpreters.semantics`` (the definition of a tick) and
``bt_controller.interpreters.compiled`` (numba kernels).
"""

from bt_controller.errors import TreeError, TreeLimitError, TreeSyntaxError
from bt_controller.language.formats import from_xml, to_ascii, to_dot, to_xml
from bt_controller.language.tree import (
    MAX_DEPTH,
    MAX_NODES,
    Action,
    Composite,
    Condition,
    Node,
    check_limits,
    leaf,
    parse,
    prob,
    sel,
    seq,
    to_indented,
    to_text,
)

__all__ = [
    "MAX_DEPTH",
    "MAX_NODES",
    "Action",
    "Composite",
    "Condition",
    "Node",
    "TreeError",
    "TreeLimitError",
    "TreeSyntaxError",
    "check_limits",
    "from_xml",
    "leaf",
    "parse",
    "prob",
    "sel",
    "seq",
    "to_ascii",
    "to_dot",
    "to_indented",
    "to_text",
    "to_xml",
]
