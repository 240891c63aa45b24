"""Primitive libraries: named subtrees that a tree may use as leaves (``docs/interfaces.md``, "Primitive
libraries"; the authors' sub-behaviours, ``docs/model.md``, "Foraging and the six primitives").

A library is a JSON file::

    {"format": 1, "primitives": [{"name": "gotoNest3", "tree": "sel(in_nest, ...)", "source": {...}}]}

- ``format`` is 1; ``primitives`` a list; each primitive has a ``name`` (an identifier that is no node name
  of the tree language and no ``seq3``-style composite name; names are unique), its ``tree`` as tree text
  (no primitive names inside: the expansion is a single pass, as the authors' loop functions do it,
  ``bt_loop_functions.cpp:94-167``), and optionally ``source``, a JSON object saying where it came from;
- nothing else is allowed (a typo in a key is an error, not a silent default).

A tree text that names a primitive is parsed with the library (``tree.parse(text, library=...)``): each use
becomes ``success(<its tree>)``, a copy of its own, with its own memory (every interpreter keeps memory per
node in pre-order) and, for a probabilistic node without a ``prob@K`` key, its own draws (its key is its
pre-order index in the expanded tree). ``Library.fold`` prints an expanded tree with the names back in.
"""

from __future__ import annotations

import hashlib
import json
import re
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path

from bt_controller.errors import TreeError
from bt_controller.language.tree import Composite, Node, parse, to_text, without_draw_keys
from bt_controller.language.vocabulary import ACTIONS, CONDITIONS, DECORATORS
from bt_controller.validate import strict_json

LIBRARY_FORMAT = 1
"""The one format this module reads and writes."""
MAX_LIBRARY_BYTES = 10_000_000
"""Largest library file read."""
_NAME = re.compile(r"^[A-Za-z_][A-Za-z0-9_]*$")
_COMPOSITE_NAME = re.compile(r"^(seq|sel|prob)[0-9]*$")


class LibraryError(ValueError):
    """A library file that cannot be used; the message names the file and what is wrong."""


@dataclass(frozen=True)
class Primitive:
    """One named subtree."""

    name: str
    text: str
    """The tree text as the library gives it."""
    tree: Node
    source: Mapping[str, object] | None = None


@dataclass(frozen=True, eq=False)
class Library:
    """Named primitives (``tree.PrimitiveLibrary``): what ``parse`` expands, and the label its errors show.
    Two libraries with the same primitives have the same ``digest`` (whatever their labels)."""

    label: str
    """How messages name the library: its file."""
    primitives: tuple[Primitive, ...]
    _by_name: dict[str, Primitive] = field(init=False, repr=False, compare=False)
    _by_tree: dict[Node, str] = field(init=False, repr=False, compare=False)
    digest: str = field(init=False, repr=False, compare=False)
    """SHA-256 of the primitives' names and canonical trees, in order: what expansion depends on."""

    def __post_init__(self) -> None:
        object.__setattr__(self, "_by_name", {p.name: p for p in self.primitives})
        by_tree: dict[Node, str] = {}
        for p in self.primitives:
            by_tree.setdefault(p.tree, p.name)  # the first of equal trees names them
        object.__setattr__(self, "_by_tree", by_tree)
        canonical = json.dumps([[p.name, str(p.tree)] for p in self.primitives])
        object.__setattr__(self, "digest", hashlib.sha256(canonical.encode()).hexdigest())

    @property
    def names(self) -> tuple[str, ...]:
        """The primitives' names, in the library's order."""
        return tuple(p.name for p in self.primitives)

    def primitive(self, name: str) -> Node | None:
        """The tree of primitive ``name`` (without its ``success``), or None."""
        found = self._by_name.get(name)
        return None if found is None else found.tree

    def parse(self, text: str, **limits: int) -> Node:
        """``tree.parse(text, library=self, **limits)``."""
        return parse(text, library=self, **limits)

    def is_copy(self, node: Node) -> bool:
        """Whether ``node`` is a copy of one of the primitives: ``success(T)`` with ``T`` a primitive's tree
        (what a name expands to; ``fold`` writes it as the name)."""
        return isinstance(node, Composite) and node.kind in DECORATORS and node.children[0] in self._by_tree

    def name_of(self, node: Composite) -> str | None:
        """The name of the primitive that ``node`` is a copy of (the first such name), or None."""
        return self._by_tree.get(node.children[0]) if node.kind in DECORATORS else None

    def shown_name_of(self, node: Composite) -> str | None:
        """For drawings: the name of the primitive that ``node`` copies, draw keys aside (a copy that the
        simplifier moved keeps its draws with ``prob@K`` keys; it behaves as the primitive there, but its
        text cannot be folded to the name), or None."""
        if node.kind not in DECORATORS:
            return None
        return self._by_tree.get(without_draw_keys(node.children[0]))

    def fold(self, tree: Node) -> str:
        """The canonical text of ``tree`` with every ``success(T)`` whose ``T`` is a primitive's tree written
        as that primitive's name (the first such name): parsing it with this library gives ``tree`` back."""
        return to_text(tree, self.name_of)

    def as_json(self) -> dict[str, object]:
        """The library as its file holds it."""
        entries: list[dict[str, object]] = []
        for p in self.primitives:
            entry: dict[str, object] = {"name": p.name, "tree": p.text}
            if p.source is not None:
                entry["source"] = dict(p.source)
            entries.append(entry)
        return {"format": LIBRARY_FORMAT, "primitives": entries}


def check_name(name: object) -> str:
    """``name`` if it can name a primitive; else LibraryError (without the file) saying why."""
    if not isinstance(name, str) or not _NAME.match(name):
        raise LibraryError(f"a primitive's name must be an identifier ([A-Za-z_][A-Za-z0-9_]*), got {name!r}")
    if name in CONDITIONS or name in ACTIONS or name in DECORATORS or _COMPOSITE_NAME.match(name):
        raise LibraryError(f"{name!r} is a node of the tree language and cannot name a primitive")
    return name


def library_from_json(document: object, label: str) -> Library:
    """The library of a parsed JSON ``document``; LibraryError naming ``label`` and the problem."""

    def fail(where: str, reason: str) -> LibraryError:
        return LibraryError(f"library {label}: {where}{reason}")

    if not isinstance(document, dict):
        raise fail("", f"expected a JSON object, got {type(document).__name__}")
    unknown = sorted(set(document) - {"format", "primitives"})
    if unknown:
        raise fail("", f"unknown key {unknown[0]!r}; expected 'format' and 'primitives'")
    if document.get("format") != LIBRARY_FORMAT or isinstance(document.get("format"), bool):
        raise fail("", f"'format' must be {LIBRARY_FORMAT}, got {document.get('format')!r}")
    entries = document.get("primitives")
    if not isinstance(entries, list):
        raise fail("", "'primitives' must be a list of {name, tree, source} objects")
    primitives: list[Primitive] = []
    seen: set[str] = set()
    for k, entry in enumerate(entries):
        where = f"primitives[{k}]: "
        if not isinstance(entry, dict):
            raise fail(where, f"expected an object with 'name' and 'tree', got {type(entry).__name__}")
        unknown = sorted(set(entry) - {"name", "tree", "source"})
        if unknown:
            raise fail(where, f"unknown key {unknown[0]!r}; expected 'name', 'tree' and optionally 'source'")
        try:
            name = check_name(entry.get("name"))
        except LibraryError as error:
            raise fail(where, str(error)) from None
        where = f"primitive {name!r}: "
        if name in seen:
            raise fail(where, "named twice")
        seen.add(name)
        text = entry.get("tree")
        if not isinstance(text, str):
            raise fail(where, f"'tree' must be tree text, got {type(text).__name__}")
        try:
            tree = parse(text)
        except TreeError as error:
            raise fail(where, f"{error} (a primitive's tree uses no primitive names)") from None
        source = entry.get("source")
        if source is not None and not isinstance(source, dict):
            raise fail(where, f"'source' must be a JSON object, got {type(source).__name__}")
        primitives.append(Primitive(name, text, tree, source))
    return Library(label, tuple(primitives))


def library_option(path: str | Path | None, error: type[Exception]) -> Library | None:
    """The library of a command's ``--library`` option (None without one); ``error`` (the command's own
    usage error) with the library's one line when it cannot be used."""
    if path is None:
        return None
    try:
        return load_library(path)
    except LibraryError as problem:
        raise error(f"--library: {problem}") from None


def load_library(path: str | Path) -> Library:
    """The library in the JSON file ``path``; LibraryError naming the file and the problem."""
    path = Path(path)
    try:
        if path.stat().st_size > MAX_LIBRARY_BYTES:
            raise LibraryError(f"library {path}: larger than {MAX_LIBRARY_BYTES} bytes")
        text = path.read_text(encoding="utf-8")
    except FileNotFoundError:
        raise LibraryError(f"library {path}: no such file") from None
    except (OSError, UnicodeDecodeError) as error:
        raise LibraryError(f"library {path}: cannot be read ({error})") from None
    try:
        document = strict_json(text)  # NaN, Infinity and a key twice refused: the library is written back
    except json.JSONDecodeError as error:
        raise LibraryError(f"library {path}: not JSON ({error})") from None
    except ValueError as error:
        raise LibraryError(f"library {path}: {error}") from None
    return library_from_json(document, str(path))


def parse_with(text: str, library: Library | None, **limits: int) -> Node:
    """``tree.parse`` with an optional library (the one call every road makes for request text)."""
    return parse(text, library=library, **limits)
