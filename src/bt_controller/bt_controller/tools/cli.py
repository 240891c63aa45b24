"""bt: check, show and export behaviour trees (run as: ws/run bt_controller bt ...).

    bt check TREE_OR_FILE                  parse; print the canonical text, size and depth
    bt show TREE_OR_FILE [--format F]      print the tree (text view by default) or draw it (--output)
    bt export TREE_OR_FILE --output PATH   write the tree in a format (default: from PATH's suffix)
    bt simplify TREE_OR_FILE               print the simplified tree: one line of tree text (it pipes);
                                           --keep-positions: no probabilistic node moves (no prob@K added)

TREE_OR_FILE is tree text such as "sel(seq(in_nest, stop), forward)", a file holding tree text or
BehaviorTree.CPP XML (recognised by a leading '<'), or '-' for standard input. Formats: text (a view with
branch lines), tree (the canonical one-line text), xml (BehaviorTree.CPP v4), dot (Graphviz), svg, png.
A simplified tree drives the wheels exactly as the tree does, tick for tick (bt_controller.language.simplify);
a probabilistic node it moves keeps its draw with an explicit key, prob@K. Any depth --max-depth allows is
handled; simplify takes at most 2000 nodes, and a PNG what matplotlib can hold. Bad input gives one line on
standard error and exit status 2. An --output that exists is refused unless --force, a symbolic link always
(swarm_ros.safe_paths: the workspace's rule for outputs).
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path
from typing import NoReturn

from bt_controller.errors import TreeError, UsageError
from bt_controller.language.formats import from_xml, to_ascii, to_dot, to_xml
from bt_controller.language.simplify import simplify
from bt_controller.language.tree import MAX_DEPTH, MAX_NODES, Node, parse, to_text
from bt_controller.language.vocabulary import ACTIONS, CONDITIONS
from bt_controller.tools.render import RENDER_FORMATS, render
from swarm_ros.safe_paths import UnsafePathError, check_output, replace_file

FORMATS = ("text", "tree", "xml", "dot", "svg", "png")
_SUFFIX_FORMAT = {".txt": "tree", ".bt": "tree", ".xml": "xml", ".dot": "dot", ".gv": "dot", ".svg": "svg",
                  ".png": "png"}  # fmt: skip
MAX_INPUT_BYTES = 10_000_000


class _Parser(argparse.ArgumentParser):
    def error(self, message: str) -> NoReturn:
        raise UsageError(f"{message} (see bt --help)")


def _load(source: str, max_nodes: int, max_depth: int) -> tuple[Node, str]:
    """The tree named by ``source`` and a label for messages (the file name, or 'argument')."""
    path = Path(source)
    if source == "-":
        text, label = sys.stdin.read(MAX_INPUT_BYTES + 1), "<stdin>"
    elif source.strip() in CONDITIONS or source.strip() in ACTIONS or "(" in source:
        text, label = source, "argument"
    elif path.is_file():
        if path.stat().st_size > MAX_INPUT_BYTES:
            raise UsageError(f"{source}: larger than {MAX_INPUT_BYTES} bytes")
        text, label = path.read_text(encoding="utf-8"), source
    elif "/" in source or "." in source:
        raise UsageError(f"{source}: no such file")
    else:
        text, label = source, "argument"
    if len(text) > MAX_INPUT_BYTES:
        raise UsageError(f"{label}: larger than {MAX_INPUT_BYTES} bytes")
    try:
        if text.lstrip("\ufeff \t\r\n").startswith("<"):
            return from_xml(text, max_nodes=max_nodes, max_depth=max_depth), label
        return parse(text, max_nodes=max_nodes, max_depth=max_depth), label
    except TreeError as error:
        raise UsageError(f"{label}: {error}") from None


def _formatted(tree: Node, fmt: str) -> str:
    if fmt == "text":
        return to_ascii(tree)
    if fmt == "tree":
        return to_text(tree) + "\n"
    if fmt == "xml":
        return to_xml(tree)
    return to_dot(tree)


def _emit(tree: Node, fmt: str, output: str | None) -> None:
    if fmt in RENDER_FORMATS:
        if output is None or output == "-":
            raise UsageError(f"--format {fmt} draws into a file: give --output PATH")
        render(tree, output, fmt)
    elif output is None or output == "-":
        sys.stdout.write(_formatted(tree, fmt))
    else:
        text = _formatted(tree, fmt)
        replace_file(output, lambda temporary: temporary.write_text(text, encoding="utf-8"))


def build_parser() -> argparse.ArgumentParser:
    """The argument parser of ``bt``."""
    description, epilog = __doc__.split("\n\n", 1)
    parser = _Parser(
        prog="bt",
        description=description,
        epilog=epilog,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    commands = parser.add_subparsers(dest="command", required=True, parser_class=_Parser)
    for name, help_text in (
        ("check", "parse a tree; print its canonical text, size and depth"),
        ("show", "print a tree (text view by default), or draw it with --output"),
        ("export", "write a tree to --output (format from the suffix unless --format)"),
        ("simplify", "print the simplified tree as one line of tree text"),
    ):
        sub = commands.add_parser(name, help=help_text)
        sub.add_argument("tree", metavar="TREE_OR_FILE", help="tree text, a file of text or XML, or -")
        if name in ("show", "export"):
            sub.add_argument("--format", "-f", choices=FORMATS, help="output format")
            sub.add_argument("--output", "-o", required=name == "export", help="output file ('-': stdout)")
            sub.add_argument("--force", action="store_true", help="overwrite an --output that exists")
        if name == "simplify":
            sub.add_argument(
                "--keep-positions",
                action="store_true",
                help="only rewrites that leave every prob at its pre-order index (no prob@K is added)",
            )
        sub.add_argument("--max-nodes", type=int, default=MAX_NODES, help=f"node limit (default {MAX_NODES})")
        sub.add_argument(
            "--max-depth", type=int, default=MAX_DEPTH, help=f"depth limit (default {MAX_DEPTH})"
        )
    return parser


def run(argv: list[str]) -> int:
    """Run ``bt`` with ``argv``; raise UsageError for bad input."""
    args = build_parser().parse_args(argv)
    if args.max_nodes < 1 or args.max_depth < 0:
        raise UsageError("--max-nodes must be at least 1 and --max-depth at least 0")
    tree, label = _load(args.tree, args.max_nodes, args.max_depth)
    if args.command == "check":
        print(f"ok: {tree.size} nodes, depth {tree.depth}: {to_text(tree)}")
        return 0
    if args.command == "simplify":
        try:
            simple = simplify(tree, keep_positions=args.keep_positions)
        except TreeError as error:  # a tree too large to simplify
            raise UsageError(f"{label}: {error}") from None
        print(to_text(simple))
        return 0
    if args.output not in (None, "-"):  # refused before anything is drawn: a link, a folder, a file there
        check_output(args.output, args.force, "--output")
    fmt = args.format
    if fmt is None:
        suffix = Path(args.output).suffix.lower() if args.output not in (None, "-") else ""
        fmt = _SUFFIX_FORMAT.get(suffix, "text" if args.command == "show" else "xml")
    try:
        _emit(tree, fmt, args.output)
    except TreeError as error:  # a picture too large
        raise UsageError(f"{label}: {error}") from None
    return 0


def main(argv: list[str] | None = None) -> int:
    """Console entry point: exit 0 on success, 2 with one line on stderr for bad input."""
    try:
        return run(sys.argv[1:] if argv is None else argv)
    except UsageError as error:
        print(f"bt: error: {error}", file=sys.stderr)
        return 2
    except UnsafePathError as error:  # a link, a folder or an existing file as --output
        print(f"bt: error: {error}", file=sys.stderr)
        return 2
    except OSError as error:
        print(f"bt: error: {error.strerror or error}: {error.filename or ''}".rstrip(": "), file=sys.stderr)
        return 2
    except UnicodeDecodeError as error:
        print(f"bt: error: input is not UTF-8 text ({error.reason})", file=sys.stderr)
        return 2


if __name__ == "__main__":
    sys.exit(main())
