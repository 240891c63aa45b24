"""Small hand-made repertoires for the tests of the commands that read one (``adapt``,
``adapt-benchmark``)."""

from __future__ import annotations

import json
from pathlib import Path

from bt_controller.random_trees import random_trees
from evolution_manager.evolution.run_config import RunConfig


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


def adapt_benchmark_argv(repertoire: Path, budget: int, ceiling: int, trials: int) -> list[str]:
    """``adapt-benchmark``'s options for ``repertoire`` under one condition (``dead-robots=3``) and one seed,
    without progress lines, short of ``--out``."""
    argv = ["--repertoires", str(repertoire), "--condition-set", "dead-robots=3", "--seeds", "1"]
    argv += ["--budget", str(budget), "--ceiling", str(ceiling), "--trials", str(trials)]
    return [*argv, "--no-progress"]
