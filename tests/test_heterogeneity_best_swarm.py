"""The best heterogeneous swarm's page (``docs/results/heterogeneity/best-swarm``): its swarm is the study
run's best swarm, and the trial its animation shows scores on the batch road what the README says."""

from __future__ import annotations

import csv
import json
from pathlib import Path

from swarm_sim.evaluation import BatchEvaluator, SwarmRequest
from swarm_sim.model import OBJECTIVES, load_layout
from swarm_sim.tasks import task_named

ROOT = Path(__file__).resolve().parent.parent
FOLDER = ROOT / "docs" / "results" / "heterogeneity" / "best-swarm"
RUN = ROOT / "experiments" / "heterogeneity" / "arms" / "multifood-arena9-kind2" / "team2" / "run06"


def test_the_swarm_is_the_best_held_out_swarm_of_the_study():
    swarm = json.loads((FOLDER / "swarm.json").read_text())
    assert swarm == json.loads((RUN / "best" / "foraging_biased_swarm.json").read_text())
    rows = list(csv.DictReader((ROOT / "docs/results/heterogeneity/study/runs.csv").open()))
    best = max(rows, key=lambda row: float(row["heldout_best_fitness"] or "-inf"))
    seed = json.loads((RUN / "config.json").read_text())["seed"]
    assert (best["arm"], int(best["seed"])) == ("team2", seed)
    assert f"{float(best['heldout_best_fitness']):.3f}" in (FOLDER / "README.md").read_text()


def test_the_animated_trial_scores_what_the_readme_says():
    config = task_named("multifood-arena9-kind2").config()
    layout = load_layout(FOLDER / "swarm.json", config.n_robots)
    assert len(set(layout.trees)) == 2
    result = BatchEvaluator(config).evaluate([SwarmRequest(layout, 1, 1)])[0]
    values = dict(zip(OBJECTIVES, result.fitness, strict=True))
    assert values["foraging2"] * 9 == 6 and values["foraging1"] == values["foraging3"] == 0
    assert f"`foraging_biased` {values['foraging_biased']:.3f}" in (FOLDER / "README.md").read_text()
