"""The tree model, its text format, parser and canonical printer.

A tree is immutable data: ``Condition``, ``Action`` and ``Composite`` nodes, all frozen, hashable and
ordered (by canonical text, so that sets of trees can be sorted deterministically). The text format is::

    sel(seq(in_nest, stop), prob(forward, forward_left))

- composites ``seq``, ``sel``, ``prob`` take 2, 3 or 4 children in parentheses, separated by commas;
  DEAP's arity-suffixed names (``seq2``, ``sel3``, ``prob4``) are accepted as input and the suffix must match
  the number of children;
- the decorator ``success(X)`` takes exactly one child (``vocabulary.DECORATORS``); in the tree model it is a
  ``Composite`` of kind ``success`` with one child (an *inner node*; ``is_decorator``);
- with a primitive library (``parse(text, library=...)``, ``bt_controller.language.library``) a primitive's
name is a
  leaf of the text that stands for ``success(<its tree>)``: the parser puts a separate copy there;
- conditions and actions (see ``bt_controller.language.vocabulary``) are bare names; a single leaf is a tree;
- a probabilistic composite may name its **draw key**: ``prob@7(a, b)`` draws its child with 7 where a
  plain ``prob`` uses its pre-order index (``semantics``; ``docs/interfaces.md``, "Random draws"); a key is
  an integer in [0, ``MAX_DRAW_KEY``]; two probabilistic nodes of one tree may share a key (they then draw
  alike);
- whitespace and newlines are free anywhere between tokens.

``to_text`` writes the one canonical form (no suffixes, ``", "`` between children, a key only where one was
given) and ``parse(to_text(t)) == t`` for every tree ``t``. The parser is iterative (no recursion, no
``eval``); it refuses trees with more than ``max_nodes`` nodes or deeper than ``max_depth`` (a single leaf has
depth 0, as DEAP's height) with a ``TreeLimitError``, and malformed input with a ``TreeSyntaxError``; both say
the line and column. Every operation on trees in this package (printing, comparing, converting, simplifying)
is iterative too, so any tree the parser accepts can be handled; only the tick interpreters stop at
``MAX_TICK_DEPTH``.
"""

from __future__ import annotations

import re
from bisect import bisect_right
from collections.abc import Callable, Iterator
from dataclasses import dataclass, field
from typing import Protocol

from bt_controller.errors import TreeLimitError, TreeSyntaxError
from bt_controller.language.vocabulary import (
    ACTIONS,
    COMPOSITES,
    CONDITIONS,
    DECORATORS,
    MAX_CHILDREN,
    MIN_CHILDREN,
)

MAX_NODES = 1000
"""Default limit on the number of nodes of a parsed tree."""

MAX_DEPTH = 17
"""Default limit on the depth of a parsed tree (a single leaf has depth 0; DEAP's usual static limit)."""

MAX_DRAW_KEY = 2**31 - 1
"""Largest draw key of a probabilistic composite (``prob@K``): keys are int32 in the compiled layout."""

MAX_TICK_DEPTH = 63
"""Deepest tree the interpreters tick: the compiled tick keeps its ancestors on the machine stack, and the
reference and py_trees interpreters recurse (``compiled.MAX_COMPILED_DEPTH`` is this value)."""


class Node:
    """Base of the three node types. Trees compare equal by structure and order by canonical text."""

    __slots__ = ()
    size: int
    depth: int

    def to_text(self) -> str:
        """The canonical one-line text of this tree."""
        return to_text(self)

    def __str__(self) -> str:
        return to_text(self)

    def __repr__(self) -> str:
        return f"{type(self).__name__}<{to_text(self)}>"

    def _key(self) -> str:
        return to_text(self)

    def __lt__(self, other: object) -> bool:
        if not isinstance(other, Node):
            return NotImplemented
        return self._key() < other._key()

    def __le__(self, other: object) -> bool:
        if not isinstance(other, Node):
            return NotImplemented
        return self._key() <= other._key()

    def __gt__(self, other: object) -> bool:
        if not isinstance(other, Node):
            return NotImplemented
        return self._key() > other._key()

    def __ge__(self, other: object) -> bool:
        if not isinstance(other, Node):
            return NotImplemented
        return self._key() >= other._key()

    def preorder(self) -> Iterator[Node]:
        """The nodes of this tree in pre-order (the node itself first); index i is the node's local index."""
        stack: list[Node] = [self]
        while stack:
            node = stack.pop()
            yield node
            if isinstance(node, Composite):
                stack.extend(reversed(node.children))


@dataclass(frozen=True, repr=False)
class Condition(Node):
    """A condition leaf: succeeds when its blackboard entry is true, else fails."""

    name: str
    size: int = field(init=False, compare=False, default=1)
    depth: int = field(init=False, compare=False, default=0)

    def __post_init__(self) -> None:
        if self.name not in CONDITIONS:
            raise TreeSyntaxError(
                f"unknown condition {self.name!r}; known conditions: {', '.join(CONDITIONS)}"
            )

    @property
    def index(self) -> int:
        """The blackboard index of this condition."""
        return CONDITIONS.index(self.name)

    def __hash__(self) -> int:
        return hash(("condition", self.name))


@dataclass(frozen=True, repr=False)
class Action(Node):
    """An action leaf: on its first tick it sets the wheels and runs; on the next tick it succeeds."""

    name: str
    size: int = field(init=False, compare=False, default=1)
    depth: int = field(init=False, compare=False, default=0)

    def __post_init__(self) -> None:
        if self.name not in ACTIONS:
            raise TreeSyntaxError(f"unknown action {self.name!r}; known actions: {', '.join(ACTIONS)}")

    @property
    def index(self) -> int:
        """The index of this action in ``ACTIONS``."""
        return ACTIONS.index(self.name)

    def __hash__(self) -> int:
        return hash(("action", self.name))


def leaf_name(node: Node) -> str:
    """The name of a leaf (a condition or an action); TypeError for a composite."""
    if isinstance(node, (Condition, Action)):
        return node.name
    raise TypeError(f"not a leaf: {node!r}")


@dataclass(frozen=True, repr=False, eq=False)
class Composite(Node):
    """An inner node: a composite with memory (``kind`` ``seq``, ``sel`` or ``prob``; 2, 3 or 4 children) or
    the decorator ``success`` (one child). A ``prob`` may carry a ``draw_key`` (``None``: its pre-order index
    is its key; see ``draw_key_at``)."""

    kind: str
    children: tuple[Node, ...]
    draw_key: int | None = None
    size: int = field(init=False, compare=False)
    depth: int = field(init=False, compare=False)
    _hash: int = field(init=False, compare=False)

    def __post_init__(self) -> None:
        if self.kind not in COMPOSITES and self.kind not in DECORATORS:
            raise TreeSyntaxError(
                f"unknown composite {self.kind!r}; known composites: {', '.join(COMPOSITES)}; "
                f"decorators: {', '.join(DECORATORS)}"
            )
        children = tuple(self.children)
        object.__setattr__(self, "children", children)
        if self.kind in DECORATORS:
            if len(children) != 1:
                raise TreeSyntaxError(f"{self.kind} takes exactly one child, got {len(children)}")
        elif not MIN_CHILDREN <= len(children) <= MAX_CHILDREN:
            raise TreeSyntaxError(
                f"{self.kind} takes {MIN_CHILDREN} to {MAX_CHILDREN} children, got {len(children)}"
            )
        for child in children:
            if not isinstance(child, Node):
                raise TypeError(f"a child of {self.kind} must be a Node, got {type(child).__name__}")
        if self.draw_key is not None:
            if self.kind != "prob":
                raise TreeSyntaxError(f"{self.kind} takes no draw key; only prob does (prob@K)")
            check_draw_key(self.draw_key)
        object.__setattr__(self, "size", 1 + sum(child.size for child in children))
        object.__setattr__(self, "depth", 1 + max(child.depth for child in children))
        object.__setattr__(self, "_hash", hash((self.kind, self.draw_key, children)))

    @property
    def head(self) -> str:
        """The composite as written before its ``(``: its kind, with ``@K`` when it names a draw key."""
        return self.kind if self.draw_key is None else f"{self.kind}@{self.draw_key}"

    def __hash__(self) -> int:
        return self._hash

    def __eq__(self, other: object) -> bool:
        # Iterative, so that trees of any depth compare (a generated __eq__ would recurse).
        if not isinstance(other, Node):
            return NotImplemented
        pairs: list[tuple[Node, Node]] = [(self, other)]
        while pairs:
            a, b = pairs.pop()
            if a is b:
                continue
            if not (isinstance(a, Composite) and isinstance(b, Composite)):
                if type(a) is not type(b) or leaf_name(a) != leaf_name(b):
                    return False
                continue
            if (
                a._hash != b._hash
                or a.kind != b.kind
                or a.draw_key != b.draw_key
                or len(a.children) != len(b.children)
            ):
                return False
            pairs.extend(zip(a.children, b.children, strict=True))
        return True


def is_decorator(node: Node) -> bool:
    """Whether ``node`` is a decorator (an inner node with one child: ``success``)."""
    return isinstance(node, Composite) and node.kind in DECORATORS


def without_draw_keys(tree: Node) -> Node:
    """``tree`` with every ``prob@K`` written as a plain ``prob`` (its draws then follow its position)."""
    if not isinstance(tree, Composite):
        return tree
    return Composite(tree.kind, tuple(without_draw_keys(child) for child in tree.children))


def check_draw_key(key: object) -> int:
    """``key`` if it is a draw key (an int in [0, ``MAX_DRAW_KEY``], not a bool); else TreeSyntaxError."""
    if isinstance(key, bool) or not isinstance(key, int) or not 0 <= key <= MAX_DRAW_KEY:
        raise TreeSyntaxError(f"a draw key must be an integer in [0, {MAX_DRAW_KEY}], got {key!r}")
    return key


def draw_key_at(node: Composite, index: int) -> int:
    """The draw key of the composite ``node`` at pre-order ``index`` of its tree: its own key if it names
    one, else ``index`` (the one rule every interpreter and the simplifier follow)."""
    return index if node.draw_key is None else node.draw_key


def leaf(name: str) -> Condition | Action:
    """The condition or action called ``name``."""
    if name in CONDITIONS:
        return Condition(name)
    if name in ACTIONS:
        return Action(name)
    raise TreeSyntaxError(f"unknown leaf {name!r}; {_known_names()}")


def seq(*children: Node | str) -> Composite:
    """A sequence with memory; string children are leaf names."""
    return Composite("seq", tuple(_as_node(c) for c in children))


def sel(*children: Node | str) -> Composite:
    """A selector with memory; string children are leaf names."""
    return Composite("sel", tuple(_as_node(c) for c in children))


def prob(*children: Node | str, draw_key: int | None = None) -> Composite:
    """A probabilistic composite with memory; string children are leaf names; ``draw_key`` as ``prob@K``."""
    return Composite("prob", tuple(_as_node(c) for c in children), draw_key)


def success(child: Node | str) -> Composite:
    """The success decorator over ``child``: success where ``child`` fails, else ``child``'s status."""
    return Composite("success", (_as_node(child),))


def _as_node(child: Node | str) -> Node:
    return leaf(child) if isinstance(child, str) else child


# ---------------------------------------------------------------------------------------------- printing


def to_text(tree: Node, name_of: Callable[[Composite], str | None] | None = None) -> str:
    """The canonical one-line text: no arity suffixes, ``", "`` between children. ``name_of``, when given,
    may name a composite: it is written as that name instead of its subtree (a library's primitives)."""
    parts: list[str] = []
    # Iterative, so that even trees built in code far beyond the parse limits print.
    stack: list[Node | str] = [tree]
    while stack:
        item = stack.pop()
        if isinstance(item, str):
            parts.append(item)
        elif isinstance(item, Composite):
            name = None if name_of is None else name_of(item)
            if name is not None:
                parts.append(name)
                continue
            parts.append(item.head + "(")
            stack.append(")")
            for i, child in enumerate(reversed(item.children)):
                stack.append(child)
                if i < len(item.children) - 1:
                    stack.append(", ")
        else:
            parts.append(leaf_name(item))
    return "".join(parts)


def to_indented(tree: Node, indent: str = "    ") -> str:
    """A multi-line view, one node per line, children indented under their parent (also parseable)."""
    lines: list[str] = []
    # (node or closing text, level, whether it is its parent's last child); iterative for any depth.
    stack: list[tuple[Node | str, int, bool]] = [(tree, 0, True)]
    while stack:
        item, level, last = stack.pop()
        pad = indent * level
        tail = "" if last else ","
        if isinstance(item, str):
            lines.append(f"{pad}){tail}")
        elif isinstance(item, Composite):
            lines.append(f"{pad}{item.head}(")
            stack.append(("", level, last))
            n = len(item.children)
            stack.extend((item.children[i], level + 1, i == n - 1) for i in reversed(range(n)))
        else:
            lines.append(f"{pad}{leaf_name(item)}{tail}")
    return "\n".join(lines) + "\n"


# ---------------------------------------------------------------------------------------------- parsing

_TOKEN = re.compile(r"\s*(?:([A-Za-z_][A-Za-z0-9_]*)|([0-9]+)|([(),@])|(\S))")
_COMPOSITE_NAME = re.compile(r"^(seq|sel|prob)([0-9]*)$")


class PrimitiveLibrary(Protocol):
    """What the parser reads of a primitive library (``bt_controller.language.library.Library``)."""

    @property
    def label(self) -> str:
        """How messages name the library (its file)."""
        ...

    @property
    def names(self) -> tuple[str, ...]:
        """The primitives' names, in the library's order."""
        ...

    def primitive(self, name: str) -> Node | None:
        """The tree of primitive ``name`` (without its ``success``), or None if the library has none."""
        ...


def _known_names(library: PrimitiveLibrary | None = None) -> str:
    known = (
        f"known names: composites {', '.join(COMPOSITES)} (with 2 to 4 children); "
        f"decorators {', '.join(DECORATORS)} (with one child); "
        f"conditions {', '.join(CONDITIONS)}; actions {', '.join(ACTIONS)}"
    )
    if library is not None:
        names = ", ".join(library.names) if library.names else "none"
        known += f"; primitives of library {library.label}: {names}"
    else:
        known += " (a primitive's name needs a library: --library FILE)"
    return known


class _Tokens:
    """Tokens of the text with their offsets; offsets turn into 1-based line and column on demand."""

    def __init__(self, text: str) -> None:
        self.text = text
        self.pos = 0
        self._line_starts = [0] + [m.end() for m in re.finditer(r"\n", text)]

    def where(self, offset: int) -> tuple[int, int]:
        line = bisect_right(self._line_starts, offset)
        return line, offset - self._line_starts[line - 1] + 1

    def next(self) -> tuple[str, str, int]:
        """(kind, value, offset) of the next token; kind is 'name', 'number', 'punct', 'bad' or 'end'."""
        match = _TOKEN.match(self.text, self.pos)
        if match is None:  # only whitespace is left
            self.pos = len(self.text)
            return "end", "", len(self.text)
        self.pos = match.end()
        if match.group(1) is not None:
            return "name", match.group(1), match.start(1)
        if match.group(2) is not None:
            return "number", match.group(2), match.start(2)
        if match.group(3) is not None:
            return "punct", match.group(3), match.start(3)
        return "bad", match.group(4), match.start(4)

    def error(self, offset: int, reason: str) -> TreeSyntaxError:
        line, column = self.where(offset)
        return TreeSyntaxError(reason, line, column)


def _describe(kind: str, value: str) -> str:
    if kind == "end":
        return "end of input"
    if kind == "bad":
        return f"unexpected character {value!r}"
    return repr(value)


@dataclass
class _Frame:
    kind: str
    arity: int | None
    draw_key: int | None
    offset: int
    children: list[Node]


def _draw_key(tokens: _Tokens, head: str) -> int:
    """The draw key after ``head@`` (``prob@7``), checked; raise a located TreeSyntaxError."""
    kind, value, offset = tokens.next()
    expected = f"an integer in [0, {MAX_DRAW_KEY}]"
    if kind != "number":
        found = _describe(kind, value)
        raise tokens.error(offset, f"expected a draw key ({expected}) after '{head}@', found {found}")
    digits = value.lstrip("0") or "0"
    # Compare lengths first: a huge number is refused without converting it.
    if len(digits) > len(str(MAX_DRAW_KEY)) or int(digits) > MAX_DRAW_KEY:
        shown = value if len(value) <= 20 else value[:12] + "..."
        raise tokens.error(offset, f"draw key {shown} of {head} is out of range: expected {expected}")
    return int(digits)


def parse(
    text: str,
    *,
    max_nodes: int = MAX_NODES,
    max_depth: int = MAX_DEPTH,
    library: PrimitiveLibrary | None = None,
) -> Node:
    """Parse tree text (see the module docstring); raise TreeSyntaxError or TreeLimitError.

    ``max_nodes`` and ``max_depth`` bound the accepted trees as written (defaults ``MAX_NODES`` and
    ``MAX_DEPTH``). With a ``library``, a leaf that names one of its primitives becomes ``success(<its
    tree>)``, a copy of its own (in one pass: the library's trees name no primitives); a name that is neither
    a node nor a primitive is refused naming the library. A primitive's name counts as one node of depth 0,
    as the authors' GP counts it (gp/ea.py:949-959 at a73e4af) and as evolution's own limits see it: the
    expanded tree may be larger, up to the library's trees (each within the default limits) in every leaf.
    """
    if not isinstance(text, str):
        raise TypeError(f"tree text must be a str, got {type(text).__name__}")
    if max_nodes < 1 or max_depth < 0:
        raise ValueError(f"max_nodes must be >= 1 and max_depth >= 0, got {max_nodes} and {max_depth}")
    tokens = _Tokens(text)
    stack: list[_Frame] = []
    count = 0
    while True:
        # A node is expected here.
        kind, value, offset = tokens.next()
        if kind != "name":
            what = "the tree" if not stack else f"a child of {stack[-1].kind}"
            raise tokens.error(offset, f"expected a node name for {what}, found {_describe(kind, value)}")
        primitive = None
        if library is not None and value not in CONDITIONS and value not in ACTIONS:
            primitive = library.primitive(value)
        # The limits bound the tree as written: a primitive's name is one node (its expansion is bounded by
        # its library, whose trees are within the default limits).
        count += 1
        if count > max_nodes:
            line, column = tokens.where(offset)
            raise TreeLimitError(f"tree has more than max_nodes={max_nodes} nodes", line, column)
        if len(stack) > max_depth:
            line, column = tokens.where(offset)
            raise TreeLimitError(f"tree is deeper than max_depth={max_depth}", line, column)
        composite = _COMPOSITE_NAME.match(value)
        node: Node
        if value in DECORATORS:
            kind2, value2, offset2 = tokens.next()
            if (kind2, value2) == ("punct", "@"):
                raise tokens.error(offset2, f"{value} takes no draw key; only prob does (prob@K)")
            if (kind2, value2) != ("punct", "("):
                raise tokens.error(offset2, f"expected '(' after {value!r}, found {_describe(kind2, value2)}")
            stack.append(_Frame(value, 1, None, offset, []))
            continue
        if composite is not None:
            arity = int(composite.group(2)) if composite.group(2) else None
            if arity is not None and not MIN_CHILDREN <= arity <= MAX_CHILDREN:
                raise tokens.error(
                    offset, f"{value!r}: a composite takes {MIN_CHILDREN} to {MAX_CHILDREN} children"
                )
            kind2, value2, offset2 = tokens.next()
            draw_key = None
            if (kind2, value2) == ("punct", "@"):
                if composite.group(1) != "prob":
                    raise tokens.error(offset2, f"{value} takes no draw key; only prob does (prob@K)")
                draw_key = _draw_key(tokens, value)
                value = f"{value}@{draw_key}"
                kind2, value2, offset2 = tokens.next()
            if (kind2, value2) != ("punct", "("):
                raise tokens.error(offset2, f"expected '(' after {value!r}, found {_describe(kind2, value2)}")
            stack.append(_Frame(composite.group(1), arity, draw_key, offset, []))
            continue
        if value in CONDITIONS:
            node = Condition(value)
        elif value in ACTIONS:
            node = Action(value)
        elif primitive is not None:
            node = Composite(DECORATORS[0], (primitive,))
        else:
            raise tokens.error(offset, f"unknown node {value!r}; {_known_names(library)}")
        written = value  # the leaf as written (a primitive's name, not its expansion)
        # Attach finished nodes to their parents until one expects another child.
        while True:
            kind, value, offset = tokens.next()
            if not stack:
                if kind != "end":
                    if (kind, value) == ("punct", "(") and written:
                        reason = f"{written} is a leaf and takes no children"
                    elif (kind, value) == ("punct", "@") and written:
                        reason = f"{written} is a leaf and takes no draw key; only prob does (prob@K)"
                    else:
                        reason = f"expected end of input after the tree, found {_describe(kind, value)}"
                    raise tokens.error(offset, reason)
                return node
            frame = stack[-1]
            frame.children.append(node)
            if (kind, value) == ("punct", ","):
                if frame.kind in DECORATORS:
                    raise tokens.error(offset, f"expected ')': {frame.kind} takes exactly one child")
                if len(frame.children) >= MAX_CHILDREN:
                    raise tokens.error(
                        offset, f"expected ')': {frame.kind} takes at most {MAX_CHILDREN} children"
                    )
                break
            if (kind, value) == ("punct", ")"):
                n = len(frame.children)
                if n < MIN_CHILDREN and frame.kind not in DECORATORS:
                    raise tokens.error(
                        offset, f"expected ',': {frame.kind} takes at least {MIN_CHILDREN} children"
                    )
                if frame.arity is not None and frame.arity != n:
                    raise tokens.error(
                        offset, f"{frame.kind}{frame.arity} expects {frame.arity} children, found {n}"
                    )
                stack.pop()
                node = Composite(frame.kind, tuple(frame.children), frame.draw_key)
                written = ""
                continue
            if (kind, value) == ("punct", "(") and written:
                raise tokens.error(offset, f"{written} is a leaf and takes no children")
            if (kind, value) == ("punct", "@") and written:
                reason = f"{written} is a leaf and takes no draw key; only prob does (prob@K)"
                raise tokens.error(offset, reason)
            raise tokens.error(offset, f"expected ',' or ')' in {frame.kind}, found {_describe(kind, value)}")


def check_tick_depth(tree: Node, interpreter: str) -> Node:
    """Return ``tree`` if an interpreter can tick it (at most ``MAX_TICK_DEPTH`` deep), else raise
    TreeLimitError naming ``interpreter`` and the limit."""
    if tree.depth > MAX_TICK_DEPTH:
        raise TreeLimitError(f"tree has depth {tree.depth}; the {interpreter} takes {MAX_TICK_DEPTH}")
    return tree


def check_limits(tree: Node, *, max_nodes: int = MAX_NODES, max_depth: int = MAX_DEPTH) -> Node:
    """Return ``tree`` if it is within the limits, else raise TreeLimitError (for trees built in code)."""
    if tree.size > max_nodes:
        raise TreeLimitError(f"tree has {tree.size} nodes, more than max_nodes={max_nodes}")
    if tree.depth > max_depth:
        raise TreeLimitError(f"tree has depth {tree.depth}, more than max_depth={max_depth}")
    return tree
