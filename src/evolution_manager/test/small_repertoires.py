"""Small hand-made repertoires for the tests of the commands that read one (``adapt``,
``adapt-benchmark``)."""

from __future__ import annotations

import json
from pathlib import Path

from bt_controller.language import random_trees
from evolution_manager.evolution.run_config import RunConfig

REPOSITORY = Path(__file__).resolve().parents[3]


def food_repertoire(folder: Path, count: int, seed: int = 3) -> Path:
    """A run folder at ``folder`` as ``adapt`` and ``adapt-benchmark`` read one: ``repertoire_food.json``
    with ``count`` random trees (of ``seed``) in bins ``(k, 4, 2)``, fitness rising with ``k``, and the
    ``config.json`` of a QD food run. Returns ``folder``."""
    folder.mkdir(parents=True, exist_ok=True)
    items = [
        {"bin": [k, 4, 2], "tree": tree, "fitness": 0.5 + k / 20, "descriptors": [k / 8, 0.5, 0.3]}
        for k, tree in enumerate(random_trees(seed, count))
    ]
    (folder / "repertoire_food.json").write_text(json.dumps({"objective": "food", "items": items}))
    (folder / "config.json").write_text(json.dumps(RunConfig.make("qd", "food", 50, 0).to_json()))
    return folder


def top_food_repertoire(folder: Path, count: int) -> Path:
    """A run folder at ``folder`` holding the ``count`` fittest bins (each its best item) of the committed QD
    food repertoire (``experiments/foraging/primitives/QD_food/run00``) and that run's ``config.json``: trees
    that find food, so a harsh condition costs them much of their score. Returns ``folder``."""
    source = REPOSITORY / "experiments/foraging/primitives/QD_food/run00"
    document = json.loads((source / "repertoire_food.json").read_text())
    best: dict[tuple[int, ...], dict] = {}
    for item in document["items"]:
        key = tuple(item["bin"])
        if key not in best or item["fitness"] > best[key]["fitness"]:
            best[key] = item
    items = sorted(best.values(), key=lambda item: -item["fitness"])[:count]
    folder.mkdir(parents=True, exist_ok=True)
    (folder / "repertoire_food.json").write_text(json.dumps({"objective": "food", "items": items}))
    (folder / "config.json").write_text((source / "config.json").read_text())
    return folder


def adapt_benchmark_argv(repertoire: Path, budget: int, ceiling: int, trials: int) -> list[str]:
    """``adapt-benchmark``'s options for ``repertoire`` under one condition (``dead-robots=3``, kept whatever
    it costs: ``--keep-below 10``) and one seed, two filter and two held-out scenarios, without progress
    lines, short of ``--out``."""
    argv = ["--repertoires", str(repertoire), "--condition-set", "dead-robots=3", "--seeds", "1"]
    argv += ["--budget", str(budget), "--ceiling", str(ceiling), "--trials", str(trials)]
    argv += ["--keep-below", "10", "--filter-scenarios", "2", "--heldout", "2"]
    return [*argv, "--no-progress"]
