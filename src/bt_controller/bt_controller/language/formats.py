"""How people see and exchange a tree: BehaviorTree.CPP v4 XML (export and import), Graphviz DOT, text views.

BehaviorTree.CPP mapping. ``seq`` is BT.CPP's built-in ``Sequence`` and ``sel`` its ``Fallback``: in BT.CPP
v4 both resume at a RUNNING child and start again from the first child once they finish, which is our memory
semantics (``SequenceWithMemory`` would not restart after a failure, and the ``Reactive*`` nodes re-tick
earlier children). ``prob`` is our control node ``Probabilistic``, and a draw key (``prob@7``) its attribute
``draw_key="7"``; the decorator ``success`` is BT.CPP's built-in ``ForceSuccess`` (running stays running,
anything else becomes success; no memory of its own, as ours: checked against BT.CPP itself, see
``docs/interfaces.md``); conditions and actions are leaves named as in the text format. The ``TreeNodesModel``
declares ``Probabilistic`` (with its ``draw_key`` input port when the tree uses one, so that the documents of
trees without keys are as before) and every condition and action, so Groot2 opens the file without complaints.
Import reads what export writes (compact ``<on_food/>`` or explicit ``<Condition ID="on_food"/>`` forms; an
empty ``draw_key=""`` means no key) with defusedxml, never following entities or external references.

Every conversion here is iterative (the XML is written line by line, not by ElementTree's recursive
serialiser), so trees of any depth the parser accepts convert.
"""

from __future__ import annotations

from xml.etree.ElementTree import Element, ParseError

import defusedxml.ElementTree as SafeET
from defusedxml import DefusedXmlException

from bt_controller.errors import TreeLimitError, TreeSyntaxError
from bt_controller.language.tree import (
    MAX_DEPTH,
    MAX_DRAW_KEY,
    MAX_NODES,
    Action,
    Composite,
    Condition,
    Node,
    leaf_name,
)
from bt_controller.language.vocabulary import ACTIONS, CONDITIONS, DECORATORS, MAX_CHILDREN, MIN_CHILDREN

BTCPP_CONTROL = {"seq": "Sequence", "sel": "Fallback", "prob": "Probabilistic", "success": "ForceSuccess"}
"""The BehaviorTree.CPP control node (or decorator, for ``success``) of each inner node."""
_KIND_OF_CONTROL = {tag: kind for kind, tag in BTCPP_CONTROL.items()}
PROBABILISTIC_DESCRIPTION = (
    "Probabilistic composite with memory: with no remembered child it ticks one child chosen uniformly at "
    "random; a RUNNING child is remembered and ticked again next time; otherwise returns the child's status."
)
DRAW_KEY_DESCRIPTION = "prob@K draws its child with K instead of its pre-order index (docs/interfaces.md)."
DRAW_KEY_ATTRIBUTE = "draw_key"
"""The attribute of a ``Probabilistic`` element that holds its draw key."""
MAX_XML_CHARS = 10_000_000
"""Longest XML document ``from_xml`` reads."""


# ---------------------------------------------------------------------------------------------- XML


def _attribute(value: str) -> str:
    """An attribute value quoted as ElementTree writes it."""
    for raw, escaped in (("&", "&amp;"), ("<", "&lt;"), (">", "&gt;"), ('"', "&quot;"), ("\r", "&#13;"),
                         ("\n", "&#10;"), ("\t", "&#09;")):  # fmt: skip
        value = value.replace(raw, escaped)
    return f'"{value}"'


XML_INDENT_LEVELS = 64
"""Levels of the XML document indented two spaces each; deeper elements are indented as this level is, so
that the document grows with the tree's size, not with its size times its depth (whitespace between
elements means nothing to BehaviorTree.CPP, Groot2 or ``from_xml``)."""


def to_xml(tree: Node, tree_id: str = "MainTree") -> str:
    """The tree as a BehaviorTree.CPP v4 XML document, with a TreeNodesModel for Groot2.

    Written line by line (two spaces per level, ``<leaf />``), byte for byte what ElementTree's ``indent`` and
    ``tostring`` wrote before, without their recursion, for trees of up to ``XML_INDENT_LEVELS`` levels;
    deeper elements keep that level's indentation (linear size at any depth)."""
    lines = [
        '<?xml version="1.0" encoding="UTF-8"?>',
        f'<root BTCPP_format="4" main_tree_to_execute={_attribute(tree_id)}>',
        f"  <BehaviorTree ID={_attribute(tree_id)}>",
    ]
    keyed = False
    stack: list[tuple[Node | str, int]] = [(tree, 2)]  # a node, or a closing tag, with its level
    while stack:
        item, level = stack.pop()
        pad = "  " * min(level, XML_INDENT_LEVELS)
        if isinstance(item, str):
            lines.append(f"{pad}</{item}>")
        elif isinstance(item, Composite):
            tag = BTCPP_CONTROL[item.kind]
            if item.draw_key is None:
                lines.append(f"{pad}<{tag}>")
            else:
                keyed = True
                lines.append(f'{pad}<{tag} {DRAW_KEY_ATTRIBUTE}="{item.draw_key}">')
            stack.append((tag, level))
            stack.extend((child, level + 1) for child in reversed(item.children))
        else:
            lines.append(f"{pad}<{leaf_name(item)} />")
    lines += ["  </BehaviorTree>", "  <TreeNodesModel>", f"    <!-- {PROBABILISTIC_DESCRIPTION} -->"]
    if keyed:
        lines += [
            '    <Control ID="Probabilistic">',
            f'      <input_port name="{DRAW_KEY_ATTRIBUTE}" type="int">{DRAW_KEY_DESCRIPTION}</input_port>',
            "    </Control>",
        ]
    else:
        lines.append('    <Control ID="Probabilistic" />')
    lines += [f'    <Condition ID="{name}" />' for name in CONDITIONS]
    lines += [f'    <Action ID="{name}" />' for name in ACTIONS]
    lines += ["  </TreeNodesModel>", "</root>"]
    return "\n".join(lines) + "\n"


def _known_xml_names() -> str:
    return (
        "known elements: Sequence, Fallback, Probabilistic (or Control ID=...), ForceSuccess (or "
        "Decorator ID=...); conditions "
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
        if tag in ("Control", "Decorator", "Condition", "Action"):
            tag = element.get("ID", "")
        if tag in _KIND_OF_CONTROL:
            stack.append((element, path, []))
            return None
        if (element.get(DRAW_KEY_ATTRIBUTE) or "").strip():
            raise TreeSyntaxError(f"{DRAW_KEY_ATTRIBUTE} at {path}: only Probabilistic takes a draw key")
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
        tag = element.tag if element.tag not in ("Control", "Decorator") else element.get("ID", "")
        if _KIND_OF_CONTROL[tag] in DECORATORS:
            if len(children) != 1:
                raise TreeSyntaxError(f"{path} has {len(children)} children; {tag} takes exactly one")
        elif len(children) > MAX_CHILDREN or len(children) < MIN_CHILDREN:
            raise TreeSyntaxError(
                f"{path} has {len(children)} children; a composite takes {MIN_CHILDREN} to {MAX_CHILDREN}"
            )
        if len(done) < len(children):
            child = children[len(done)]
            node = open_element(child, f"{path}/{child.tag}[{len(done)}]")
            continue
        stack.pop()
        node = Composite(_KIND_OF_CONTROL[tag], tuple(done), _draw_key(element, tag, path))
    assert node is not None
    return node


def _draw_key(element: Element, tag: str, path: str) -> int | None:
    """The draw key of a control element (None when it has none); raise TreeSyntaxError for a bad one."""
    value = (element.get(DRAW_KEY_ATTRIBUTE) or "").strip()
    if not value:
        return None
    if tag != "Probabilistic":
        raise TreeSyntaxError(f"{DRAW_KEY_ATTRIBUTE} at {path}: only Probabilistic takes a draw key")
    digits = value.lstrip("0") or "0"
    if (
        not value.isascii()
        or not value.isdigit()
        or len(digits) > len(str(MAX_DRAW_KEY))
        or int(digits) > MAX_DRAW_KEY
    ):
        shown = value if len(value) <= 20 else value[:12] + "..."
        raise TreeSyntaxError(
            f"{DRAW_KEY_ATTRIBUTE}={shown!r} at {path}: expected an integer in [0, {MAX_DRAW_KEY}]"
        )
    return int(digits)


# ---------------------------------------------------------------------------------------------- DOT

COMPOSITE_FILL = {"seq": "#cfe2f3", "sel": "#fce5cd", "prob": "#d9ead3", "success": "#fff2cc"}
"""The fill colour of each inner node in drawings (DOT, ``render``)."""


def composite_label(node: Composite) -> str:
    """The label of an inner node in drawings: ``seq →``, ``sel ?``, ``prob %``, ``prob % @7`` for a key,
    ``success ✓`` for the decorator."""
    label = {"seq": "seq →", "sel": "sel ?", "prob": "prob %", "success": "success ✓"}[node.kind]
    return label if node.draw_key is None else f"{label} @{node.draw_key}"


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
            fill, label = COMPOSITE_FILL[node.kind], composite_label(node)
            lines.append(
                f'  n{index} [shape=box, style="rounded,filled", fillcolor="{fill}", label="{label}"];'
            )
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
            lines.append(f"{lead}{node.head}")
            n = len(node.children)
            for i in reversed(range(n)):
                last = i == n - 1
                stack.append((node.children[i], child_lead + ("└── " if last else "├── "),
                              child_lead + ("    " if last else "│   ")))  # fmt: skip
        else:
            suffix = "?" if isinstance(node, Condition) else ""
            lines.append(f"{lead}{leaf_name(node)}{suffix}")
    return "\n".join(lines) + "\n"
