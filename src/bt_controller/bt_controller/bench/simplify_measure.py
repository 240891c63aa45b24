"""How much the simplifier shrinks real trees: a measurement script, not a test.

    python -m bt_controller.bench.simplify_measure RUN_DIR/repertoire_food.json [MORE.json ...]

For every tree of the repertoires (``items[*].tree``, as evolved) it simplifies twice: keeping every
probabilistic node at its pre-order index (``keep_positions=True``, the simplifier before draw keys) and
freely (the default, which writes ``prob@K`` where a probabilistic node moved). It prints one Markdown table
per file, for all trees and for the trees with a probabilistic node: how many, how many are not simplified at
all, the mean number of nodes (original, kept positions, free), and how many simplified trees carry a draw
key.
"""

from __future__ import annotations

import argparse
import json
import sys
from dataclasses import dataclass
from pathlib import Path

from bt_controller.errors import TreeError, UsageError
from bt_controller.language.simplify import simplify
from bt_controller.language.tree import MAX_DEPTH, MAX_NODES, Composite, Node, parse, to_text


@dataclass(frozen=True)
class Measure:
    """Node counts of one set of trees before and after both simplifiers."""

    trees: int
    unchanged_kept: int
    unchanged_free: int
    nodes_original: float
    nodes_kept: float
    nodes_free: float
    keyed_free: int


def measure(trees: list[Node]) -> dict[str, Measure]:
    """Simplify each tree both ways and count, for all trees and for those with a probabilistic node."""
    kept = [simplify(tree, keep_positions=True) for tree in trees]
    free = [simplify(tree) for tree in trees]
    with_prob = [any(_is_prob(node) for node in tree.preorder()) for tree in trees]
    out = {}
    for name, chosen in (("all trees", [True] * len(trees)), ("trees with a prob", with_prob)):
        rows = [(t, k, f) for t, k, f, c in zip(trees, kept, free, chosen, strict=True) if c]
        n = max(len(rows), 1)
        out[name] = Measure(
            trees=len(rows),
            unchanged_kept=sum(t == k for t, k, _ in rows),
            unchanged_free=sum(t == f for t, _, f in rows),
            nodes_original=sum(t.size for t, _, _ in rows) / n,
            nodes_kept=sum(k.size for _, k, _ in rows) / n,
            nodes_free=sum(f.size for _, _, f in rows) / n,
            keyed_free=sum("@" in to_text(f) for _, _, f in rows),
        )
    return out


def _is_prob(node: Node) -> bool:
    return isinstance(node, Composite) and node.kind == "prob"


def table(measures: dict[str, Measure]) -> str:
    """The measures as a Markdown table: one row per set of trees."""
    rows = [
        "| | trees | not simplified at all: probs kept in place / moved | mean nodes: original / probs kept "
        "in place / moved | simplified with a draw key |",
        "|---|---:|---:|---:|---:|",
    ]
    for name, m in measures.items():
        rows.append(
            f"| {name} | {m.trees} | {m.unchanged_kept} / {m.unchanged_free} | {m.nodes_original:.2f} / "
            f"{m.nodes_kept:.2f} / {m.nodes_free:.2f} | {m.keyed_free} |"
        )
    return "\n".join(rows)


def _trees(path: Path) -> list[Node]:
    try:
        items = json.loads(path.read_text(encoding="utf-8"))["items"]
        return [parse(item["tree"], max_nodes=MAX_NODES, max_depth=MAX_DEPTH) for item in items]
    except (OSError, ValueError, KeyError, TypeError) as error:
        reason = error.strerror if isinstance(error, OSError) else error
        if isinstance(error, (KeyError, TypeError)) and not isinstance(error, TreeError):
            reason = "expected a repertoire file: an object with items[*].tree"
        raise UsageError(f"{path}: {reason}") from None


def main(argv: list[str] | None = None) -> int:
    """Print the table of each repertoire file; exit 2 with one line for a bad file."""
    parser = argparse.ArgumentParser(prog="simplify_measure", description=__doc__.split("\n\n")[0])
    parser.add_argument("repertoires", nargs="+", type=Path, help="repertoire_<objective>.json files")
    args = parser.parse_args(argv)
    try:
        for path in args.repertoires:
            print(f"{path}:\n\n{table(measure(_trees(path)))}\n")
    except UsageError as error:
        print(f"simplify_measure: error: {error}", file=sys.stderr)
        return 2
    return 0


if __name__ == "__main__":
    sys.exit(main())
