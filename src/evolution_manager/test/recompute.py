"""Recompute a run's metrics from its files with plain Python (no qdpy, no project code), for the tests."""

from __future__ import annotations

import csv
import json
import math
from collections.abc import Callable
from pathlib import Path

OBJECTIVES = ("density", "nest", "food")
DESCRIPTORS = ("movement", "rotation", "conditionality")


def grids_from_log(
    root: Path, form: Callable[[str], str] | None = None
) -> dict[str, dict[tuple, list[tuple[str, float, int]]]]:
    """Per objective, bin -> [(tree, fitness, evaluation)] in order of arrival, from ``evaluations.csv``: a
    bin keeps 3 trees, a full bin swaps its worst (the first of equal worsts) for a strictly better tree,
    and a tree text already held anywhere in the grid is refused; with ``form`` (the ``clean`` profile's
    simplified form of a tree text), so is a tree with the form of a tree its bin holds."""
    with open(Path(root) / "evaluations.csv", newline="") as handle:
        rows = list(csv.DictReader(handle))
    grids: dict[str, dict[tuple, list[tuple[str, float, int]]]] = {o: {} for o in OBJECTIVES}
    for row in rows:
        if row["error"]:
            continue
        key = tuple(min(int(float(row[d]) * 8), 7) for d in DESCRIPTORS)
        for objective in OBJECTIVES:
            grid = grids[objective]
            if any(row["tree"] == t for items in grid.values() for t, _, _ in items):
                continue
            items = grid.setdefault(key, [])
            if form is not None and any(form(row["tree"]) == form(t) for t, _, _ in items):
                continue
            value = float(row[objective])
            if len(items) < 3:
                items.append((row["tree"], value, int(row["evaluation"])))
                continue
            worst = min(range(3), key=lambda i: (items[i][1], i))
            if value > items[worst][1]:
                del items[worst]
                items.append((row["tree"], value, int(row["evaluation"])))
    return grids


def metrics_from_items(items: list[dict]) -> dict:
    """Coverage, QD score (/ 512), repertoire size (filled bins) and best fitness of a repertoire file's
    items, as the authors' analysis computes them."""
    best: dict[tuple, float] = {}
    for item in items:
        key = tuple(item["bin"])
        best[key] = max(best.get(key, -1.0), item["fitness"])
    return {
        "coverage": len(best) / 512,
        "qd_score": math.fsum(best.values()) / 512,
        "repertoire_size": len(best),
        "best": max(best.values()) if best else None,
    }


def check_repertoires(root: Path, form: Callable[[str], str] | None = None) -> None:
    """Assert that every repertoire file of a run whose repertoires are its passive grids (MAP-Elites) equals
    the recomputation from its evaluation log (``form``: see :func:`grids_from_log`), and that the summary
    reports the same metrics."""
    summary = json.loads((Path(root) / "summary.json").read_text())
    for objective, bins in grids_from_log(root, form).items():
        document = json.loads((Path(root) / f"repertoire_{objective}.json").read_text())
        recomputed = [(list(k), t, v, e) for k in sorted(bins) for t, v, e in bins[k]]
        stored = [(i["bin"], i["tree"], i["fitness"], i["evaluation"]) for i in document["items"]]
        assert recomputed == stored
        check_metrics(root, objective, summary)


def check_metrics(root: Path, objective: str, summary: dict) -> None:
    """Assert that the summary's coverage, QD score and repertoire size of ``objective`` equal those
    recomputed from its repertoire file, and its held-out QD score those of ``heldout.json``."""
    document = json.loads((Path(root) / f"repertoire_{objective}.json").read_text())
    metrics = metrics_from_items(document["items"])
    reported = summary["objectives"][objective]
    assert reported["coverage"] == metrics["coverage"]
    assert abs(reported["qd_score"] - metrics["qd_score"]) < 1e-12
    assert reported["repertoire_size"] == metrics["repertoire_size"]
    heldout_path = Path(root) / "heldout.json"
    if reported["evolved"] and heldout_path.exists():
        heldout = json.loads(heldout_path.read_text())["objectives"][objective]
        assert len(heldout["bins"]) == metrics["repertoire_size"]
        expected = math.fsum(b["heldout_fitness"] for b in heldout["bins"]) / 512
        assert abs(reported["heldout_qd_score"] - expected) < 1e-12
        best_by_bin = {tuple(b["bin"]): b["fitness"] for b in heldout["bins"]}
        assert abs(math.fsum(best_by_bin.values()) / 512 - metrics["qd_score"]) < 1e-12
