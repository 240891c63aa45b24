"""Recompute a run's passive grids from its evaluation log with plain Python (no qdpy), for the tests."""

from __future__ import annotations

import csv
import json
from pathlib import Path

from evolution_manager.primitives import DESCRIPTORS, OBJECTIVES


def grids_from_log(root: Path) -> dict[str, dict[tuple, list[tuple[float, int]]]]:
    """Per objective, bin -> [(fitness, evaluation)] in order of arrival: a bin keeps 3 trees, and a full bin
    swaps its worst (the first of equal worsts) for a strictly better tree."""
    with open(Path(root) / "evaluations.csv", newline="") as handle:
        rows = list(csv.DictReader(handle))
    grids: dict[str, dict[tuple, list[tuple[float, int]]]] = {o: {} for o in OBJECTIVES}
    for row in rows:
        if row["error"]:
            continue
        key = tuple(min(int(float(row[d]) * 8), 7) for d in DESCRIPTORS)
        for objective in OBJECTIVES:
            items = grids[objective].setdefault(key, [])
            value = float(row[objective])
            if len(items) < 3:
                items.append((value, int(row["evaluation"])))
                continue
            worst = min(range(3), key=lambda i: (items[i][0], i))
            if value > items[worst][0]:
                del items[worst]
                items.append((value, int(row["evaluation"])))
    return grids


def check_repertoires(root: Path) -> None:
    """Assert that every repertoire file of a run equals the recomputation from its evaluation log."""
    for objective, bins in grids_from_log(root).items():
        document = json.loads((Path(root) / f"repertoire_{objective}.json").read_text())
        recomputed = [(list(k), v, e) for k in sorted(bins) for v, e in bins[k]]
        assert recomputed == [(i["bin"], i["fitness"], i["evaluation"]) for i in document["items"]]
        assert document["coverage"] == len(bins) / 512
        expected = sum(max(v for v, _ in items) for items in bins.values())
        assert abs(document["qd_score"] - expected) < 1e-9
