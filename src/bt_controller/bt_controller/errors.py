"""The errors of bt_controller: every refusal of a tree is a ValueError that says where and why; and the
``UsageError`` of every command-line tool of the workspace.

``TreeSyntaxError`` is raised for text (or XML) that is not a tree: a malformed expression, an unknown node
name, a wrong number of children. ``TreeLimitError`` is raised for a well-formed tree that is larger or deeper
than the configured limits. Both carry the 1-based ``line`` and ``column`` of the offending place (``None``
when there is no text, e.g. for a tree built in code) and the bare ``reason``.
"""

from __future__ import annotations


class TreeError(ValueError):
    """A tree was refused; ``str(error)`` is one line: ``line L, column C: reason``."""

    def __init__(self, reason: str, line: int | None = None, column: int | None = None) -> None:
        self.reason = reason
        self.line = line
        self.column = column
        where = f"line {line}, column {column}: " if line is not None and column is not None else ""
        super().__init__(where + reason)


class TreeSyntaxError(TreeError):
    """The input is not a well-formed tree (or names a node that does not exist)."""


class TreeLimitError(TreeError):
    """The tree is well formed but exceeds the node-count or depth limit."""


class UsageError(Exception):
    """Bad command-line input to any of the workspace's tools; printed as one line, exit status 2."""
