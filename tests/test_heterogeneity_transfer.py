"""The heterogeneity study's swarms in the authors' ARGoS (``docs/results/heterogeneity/transfer``): our side
recomputed from the model, the README's table from the two committed tables, and the agreement it claims."""

from __future__ import annotations

import csv
import statistics
from pathlib import Path

from swarm_sim.evaluation import BatchEvaluator, SwarmRequest
from swarm_sim.model import OBJECTIVES, SwarmLayout
from swarm_sim.tasks import task_named

FOLDER = Path(__file__).resolve().parent.parent / "docs" / "results" / "heterogeneity" / "transfer"


def _table(name: str) -> list[dict[str, str]]:
    with open(FOLDER / name, newline="") as handle:
        return list(csv.DictReader(handle, delimiter="\t"))


def _trees(line: str) -> tuple[str, ...]:
    return tuple(tree.strip() for tree in line.removeprefix("swarm: ").split(" ; "))


def test_our_side_is_the_models_and_the_readme_shows_both_tables():
    ours = _table("ours_stats.tsv")
    argos = {row["tree"]: row for row in _table("argos_stats.tsv")}
    lines = (FOLDER / "swarms.txt").read_text().splitlines()
    swarms = [line for line in lines if line.startswith("swarm: ")]
    assert [row["tree"] for row in ours] == swarms and set(argos) == set(swarms)
    # the baseline (nine copies of one tree, the cheapest) recomputed: seeds 1-20 of 10 trials each
    baseline = next(row for row in ours if row["label"].startswith("homogeneous"))
    evaluator = BatchEvaluator(task_named("multifood-arena9-kind2").config("paper"))
    results = evaluator.evaluate(
        [SwarmRequest(SwarmLayout(_trees(baseline["tree"])), s, 10) for s in range(1, 21)]
    )
    values = [r.fitness[OBJECTIVES.index("foraging_biased")] for r in results]
    assert float(baseline["fitness_mean"]) == statistics.mean(values)
    assert float(baseline["fitness_sem"]) == statistics.stdev(values) / len(values) ** 0.5
    readme = (FOLDER / "README.md").read_text()
    largest = 0.0
    for row in ours:
        theirs = argos[row["tree"]]
        mine, mine_sem = float(row["fitness_mean"]), float(row["fitness_sem"])
        other, other_sem = float(theirs["fitness_mean"]), float(theirs["fitness_sem"])
        z = (mine - other) / (mine_sem**2 + other_sem**2) ** 0.5
        cells = f"| {mine:.3f} ± {mine_sem:.3f} | {other:.3f} ± {other_sem:.3f} | {mine - other:+.3f} "
        cells += f"| {z:+.2f} |"
        assert cells in readme, cells
        largest = max(largest, abs(z))
    assert f"the largest |z| is {largest:.2f}" in readme


def test_the_teams_second_look_on_seeds_21_to_40():
    """The README's second look at team2's best team: ours recomputed on seeds 21-40, ARGoS's from its
    rows."""
    lines = (FOLDER / "swarms.txt").read_text().splitlines()
    team = next(lines[k + 1] for k, line in enumerate(lines) if line.startswith("# team2 "))
    argos = _table("argos_raw_team2_seeds21-40.tsv")
    assert {row["tree"] for row in argos} == {team} and sorted(int(r["seed"]) for r in argos) == list(
        range(21, 41)
    )
    evaluator = BatchEvaluator(task_named("multifood-arena9-kind2").config("paper"))
    results = evaluator.evaluate([SwarmRequest(SwarmLayout(_trees(team)), s, 10) for s in range(21, 41)])
    ours = [r.fitness[OBJECTIVES.index("foraging_biased")] for r in results]
    theirs = [float(row["fitness"]) for row in argos]

    def sem(values: list[float]) -> float:
        return statistics.stdev(values) / len(values) ** 0.5

    z = (statistics.mean(ours) - statistics.mean(theirs)) / (sem(ours) ** 2 + sem(theirs) ** 2) ** 0.5
    mine, other = statistics.mean(ours), statistics.mean(theirs)
    text = f"{mine:.3f} ±\n  {sem(ours):.3f} here against {other:.3f} ± {sem(theirs):.3f} there, z {z:+.2f}"
    assert text in (FOLDER / "README.md").read_text(), text


def test_the_shuttles_on_arena_6_recomputed_and_shown_beside_argos():
    """The carriers study's three shuttle trees, nine copies each on ``multifood-arena6``: our side
    recomputed for the first, and every README row from the two committed tables."""
    trees = [line for line in (FOLDER / "shuttles.txt").read_text().splitlines() if line and line[0] != "#"]
    ours = _table("ours_stats_shuttles.tsv")
    argos = {row["tree"]: row for row in _table("argos_stats_shuttles.tsv")}
    assert [row["tree"] for row in ours] == trees and set(argos) == set(trees)
    evaluator = BatchEvaluator(task_named("multifood-arena6").config("paper"))
    results = evaluator.evaluate([SwarmRequest(SwarmLayout((trees[0],) * 9), s, 10) for s in range(1, 21)])
    for objective, column in (("foraging", "foraging"), ("foraging3", "food3")):
        values = [r.fitness[OBJECTIVES.index(objective)] for r in results]
        assert float(ours[0][f"{column}_mean"]) == statistics.mean(values)
        assert float(ours[0][f"{column}_sem"]) == statistics.stdev(values) / len(values) ** 0.5
    readme = (FOLDER / "README.md").read_text()
    for row in ours:
        for column in ("foraging", "food3"):
            mine, mine_sem = float(row[f"{column}_mean"]), float(row[f"{column}_sem"])
            theirs = argos[row["tree"]]
            other, other_sem = float(theirs[f"{column}_mean"]), float(theirs[f"{column}_sem"])
            z = (mine - other) / (mine_sem**2 + other_sem**2) ** 0.5
            cells = f"| {mine:.3f} ± {mine_sem:.3f} | {other:.3f} ± {other_sem:.3f} "
            cells += f"| {mine - other:+.3f} | {z:+.2f} |"
            assert cells in readme, cells
