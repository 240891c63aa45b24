"""How people see and exchange a tree: BehaviorTree.CPP v4 XML (export and import), Graphviz DOT, text views.

BehaviorTree.CPP mapping. ``seq`` is BT.CPP's built-in ``Sequence`` and ``sel`` its ``Fallback``: in BT.CPP
v4 both resume at a RUNNING child and start again from the first child once they finish, which is our memory
semantics (``SequenceWithMemory`` would not restart after a failure, and the ``Reactive*`` nodes re-tick
earlier children). ``prob`` is our control node ``Probabilistic``; conditions and actions are leaves named
as in the text format. The ``TreeNodesModel`` declares ``Probabilistic`` and every condition and action, so
Groot2 opens the file without complaints. Import reads what export writes (compact ``<on_food/>`` or explicit
``<Condition ID="on_food"/>`` forms) with defusedxml, never following entities or external references.
"""

from __future__ import annotations

from xml.etree.ElementTree import Comment, Element, ParseError, SubElement, indent, tostring

import defusedxml.ElementTree as SafeET
from defusedxml import DefusedXmlException

from bt_controller.errors import TreeLimitError, TreeSyntaxError
from bt_controller.tree import MAX_DEPTH, MAX_NODES, Action, Composite, Condition, Node, leaf_name
from bt_controller.vocabulary import ACTIONS, CONDITIONS, MAX_CHILDREN, MIN_CHILDREN

BTCPP_CONTROL = {"seq": "Sequence", "sel": "Fallback", "prob": "Probabilistic"}
"""The BehaviorTree.CPP control node of each composite."""
_KIND_OF_CONTROL = {tag: kind for kind, tag in BTCPP_CONTROL.items()}
PROBABILISTIC_DESCRIPTION = (
    "Probabilistic composite with memory: with no remembered child it ticks one child chosen uniformly at "
    "random; a RUNNING child is remembered and ticked again next time; otherwise returns the child's status."
)
MAX_XML_CHARS = 10_000_000
"""Longest XML document ``from_xml`` reads."""


# ---------------------------------------------------------------------------------------------- XML


def to_xml(tree: Node, tree_id: str = "MainTree") -> str:
    """The tree as a BehaviorTree.CPP v4 XML document, with a TreeNodesModel for Groot2."""
    root = Element("root", {"BTCPP_format": "4", "main_tree_to_execute": tree_id})
    behavior_tree = SubElement(root, "BehaviorTree", {"ID": tree_id})
    stack: list[tuple[Node, Element]] = [(tree, behavior_tree)]
    while stack:
        node, parent = stack.pop()
        if isinstance(node, Composite):
            element = SubElement(parent, BTCPP_CONTROL[node.kind])
            stack.extend((child, element) for child in reversed(node.children))
        else:
            SubElement(parent, leaf_name(node))
    model = SubElement(root, "TreeNodesModel")
    model.append(Comment(f" {PROBABILISTIC_DESCRIPTION} "))
    SubElement(model, "Control", {"ID": "Probabilistic"})
    for name in CONDITIONS:
        SubElement(model, "Condition", {"ID": name})
    for name in ACTIONS:
        SubElement(model, "Action", {"ID": name})
    indent(root, space="  ")
    return '<?xml version="1.0" encoding="UTF-8"?>\n' + tostring(root, encoding="unicode") + "\n"


def _known_xml_names() -> str:
    return (
        "known elements: Sequence, Fallback, Probabilistic (or Control ID=...); conditions "
        f"{', '.join(CONDITIONS)}; actions {', '.join(ACTIONS)} (or Condition/Action ID=...)"
    )


def from_xml(text: str, *, max_nodes: int = MAX_NODES, max_depth: int = MAX_DEPTH) -> Node:
    """Read the main tree of a BehaviorTree.CPP v4 document written by ``to_xml`` (or by hand, Groot2).

    Raises TreeSyntaxError (with line and column for malformed XML, with the element path otherwise) or
    TreeLimitError.
    """
    if not isinstance(text, str):
        raise TypeError(f"XML text must be a str, got {type(text).__name__}")
    if len(text) > MAX_XML_CHARS:
        raise TreeLimitError(f"XML document longer than {MAX_XML_CHARS} characters")
    try:
        root = SafeET.fromstring(text.lstrip("\ufeff"))
    except ParseError as error:
        line, column = error.position
        reason = str(error).split(":")[0]
        raise TreeSyntaxError(f"malformed XML: {reason}", line, column + 1) from None
    except DefusedXmlException as error:
        raise TreeSyntaxError(
            f"refused XML: {type(error).__name__} (entities and DTDs are not allowed)"
        ) from None
    except ValueError as error:  # e.g. an encoding declaration in a str, or characters XML forbids
        raise TreeSyntaxError(f"malformed XML: {error}") from None
    if root.tag != "root":
        raise TreeSyntaxError(f"expected a <root> element, found <{root.tag}>")
    version = root.get("BTCPP_format")
    if version is not None and version != "4":
        raise TreeSyntaxError(f'expected BTCPP_format="4", found {version!r}')
    trees = root.findall("BehaviorTree")
    if not trees:
        raise TreeSyntaxError("expected a <BehaviorTree> element in <root>")
    main = root.get("main_tree_to_execute")
    chosen = [t for t in trees if t.get("ID") == main] if main is not None else trees[:1]
    if not chosen:
        raise TreeSyntaxError(f"main_tree_to_execute={main!r} names no <BehaviorTree>")
    behavior_tree = chosen[0]
    top = list(behavior_tree)
    if len(top) != 1:
        raise TreeSyntaxError(
            f"<BehaviorTree ID={behavior_tree.get('ID')!r}> must hold one root node, found {len(top)}"
        )
    return _element_to_tree(top[0], max_nodes, max_depth)


def _element_to_tree(top: Element, max_nodes: int, max_depth: int) -> Node:
    """Convert iteratively (post-order) so that deep documents cannot exhaust the Python stack."""
    count = 0
    # Each frame: element, its path, the converted children so far.
    stack: list[tuple[Element, str, list[Node]]] = []

    def open_element(element: Element, path: str) -> Node | None:
        nonlocal count
        count += 1
        if count > max_nodes:
            raise TreeLimitError(f"tree has more than max_nodes={max_nodes} nodes (at {path})")
        if len(stack) > max_depth:
            raise TreeLimitError(f"tree is deeper than max_depth={max_depth} (at {path})")
        tag = element.tag
        if not isinstance(tag, str):
            raise TreeSyntaxError(f"unexpected XML node at {path}")
        if tag in ("Control", "Condition", "Action"):
            tag = element.get("ID", "")
        if tag in _KIND_OF_CONTROL:
            stack.append((element, path, []))
            return None
        if tag in CONDITIONS or tag in ACTIONS:
            if len(element):
                raise TreeSyntaxError(f"{tag} is a leaf and takes no children (at {path})")
            return Condition(tag) if tag in CONDITIONS else Action(tag)
        raise TreeSyntaxError(f"unknown element <{element.tag}> at {path}; {_known_xml_names()}")

    node = open_element(top, top.tag)
    while stack:
        element, path, done = stack[-1]
        if node is not None:
            done.append(node)
            node = None
        children = list(element)
        if len(children) > MAX_CHILDREN or len(children) < MIN_CHILDREN:
            raise TreeSyntaxError(
                f"{path} has {len(children)} children; a composite takes {MIN_CHILDREN} to {MAX_CHILDREN}"
            )
        if len(done) < len(children):
            child = children[len(done)]
            node = open_element(child, f"{path}/{child.tag}[{len(done)}]")
            continue
        stack.pop()
        tag = element.tag if element.tag != "Control" else element.get("ID", "")
        node = Composite(_KIND_OF_CONTROL[tag], tuple(done))
    assert node is not None
    return node


# ---------------------------------------------------------------------------------------------- DOT

_DOT_STYLE = {
    "seq": 'shape=box, style="rounded,filled", fillcolor="#cfe2f3", label="seq →"',
    "sel": 'shape=box, style="rounded,filled", fillcolor="#fce5cd", label="sel ?"',
    "prob": 'shape=box, style="rounded,filled", fillcolor="#d9ead3", label="prob %"',
}


def to_dot(tree: Node, name: str = "behaviour_tree") -> str:
    """Graphviz DOT text: composites as rounded boxes, conditions as ellipses, actions as boxes."""
    lines = [
        f"digraph {name} {{",
        "  ordering=out;",
        '  node [fontname="Helvetica", fontsize=11];',
        "  edge [arrowhead=none];",
    ]
    edges: list[str] = []
    parents: list[int] = []
    remaining: list[int] = []
    for index, node in enumerate(tree.preorder()):
        if parents:
            edges.append(f"  n{parents[-1]} -> n{index};")
            remaining[-1] -= 1
        if isinstance(node, Composite):
            lines.append(f"  n{index} [{_DOT_STYLE[node.kind]}];")
            parents.append(index)
            remaining.append(len(node.children))
        elif isinstance(node, Condition):
            lines.append(f'  n{index} [shape=ellipse, label="{node.name}?"];')
        else:
            lines.append(f'  n{index} [shape=box, label="{leaf_name(node)}"];')
        while remaining and remaining[-1] == 0:
            parents.pop()
            remaining.pop()
    return "\n".join([*lines, *edges, "}"]) + "\n"


# ---------------------------------------------------------------------------------------------- text


def to_ascii(tree: Node) -> str:
    """An indented view with branch lines, one node per line (conditions end with '?')."""
    lines: list[str] = []
    stack: list[tuple[Node, str, str]] = [(tree, "", "")]
    while stack:
        node, lead, child_lead = stack.pop()
        if isinstance(node, Composite):
            lines.append(f"{lead}{node.kind}")
            n = len(node.children)
            for i in reversed(range(n)):
                last = i == n - 1
                stack.append((node.children[i], child_lead + ("└── " if last else "├── "),
                              child_lead + ("    " if last else "│   ")))  # fmt: skip
        else:
            suffix = "?" if isinstance(node, Condition) else ""
            lines.append(f"{lead}{leaf_name(node)}{suffix}")
    return "\n".join(lines) + "\n"
