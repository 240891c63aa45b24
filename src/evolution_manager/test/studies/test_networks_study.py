"""``experiment --study bt-vs-nn``: the plan (arms, objectives, seeds), the whole study end to end on a tiny
budget (runs.csv, report, figures, each best network's action table), a second start that runs nothing
again, the report command rebuilding the same report, the readable form of a network (its action per input
pattern, grouped as conditions), and the committed report's tables against its runs.csv."""

from __future__ import annotations

import csv
import io
import json
import random
from pathlib import Path

import pytest

from bt_controller.interpreters import N_WEIGHTS, Network, load_network
from evolution_manager.studies import networks_study
from evolution_manager.studies.experiment import build_parser, experiment
from evolution_manager.studies.report_command import report as report_command
from evolution_manager.studies.significance import markdown_table


def _members(cube: str) -> set[int]:
    free = [k for k, c in enumerate(cube) if c == "-"]
    found = set()
    for s in range(2 ** len(free)):
        bits = list(cube)
        for j, k in enumerate(free):
            bits[k] = str((s >> j) & 1)
        found.add(int("".join(bits), 2))
    return found


def test_the_cover_matches_exactly_the_patterns_given():
    assert networks_study.cover(set(range(512))) == ["---------"]
    assert networks_study.cover({p for p in range(512) if p & 0b100000000}) == ["1--------"]
    rng = random.Random(3)
    for _ in range(5):
        patterns = {p for p in range(512) if rng.random() < 0.3}
        cubes = networks_study.cover(patterns)
        assert set().union(*(_members(c) for c in cubes)) == patterns
    assert networks_study.cube_text("1-0------") == "in_nest and not got_food"


def test_a_network_table_reads_its_action_for_every_input_pattern():
    stop = [0.0] * (N_WEIGHTS - 1) + [-50.0]  # the output bias alone: output near 0, stop everywhere
    assert networks_study.action_table(stop) == [0] * 512
    carrying = [0.0] * N_WEIGHTS
    carrying[2] = 40.0  # got_food drives hidden unit 0, which drives the output up
    carrying[45] = -20.0  # hidden unit 0's bias
    carrying[50] = 40.0
    carrying[55] = -20.0
    actions = networks_study.action_table(carrying)
    assert {actions[p] for p in range(512) if p & 0b001000000} == {6}  # reverse_right when carrying
    assert {actions[p] for p in range(512) if not p & 0b001000000} == {0}


def test_the_plan_gives_every_arm_and_objective_its_runs_with_distinct_seeds(tmp_path):
    args = build_parser().parse_args(["--study", "bt-vs-nn", "--runs", "2", "--out", str(tmp_path)])
    document, stages, budgets = networks_study.plan_study(args, "fixed", "shared")
    planned = stages[0]()
    assert len(planned) == 5 * 7 * 2 == len(budgets) and set(budgets.values()) == {25_000}
    assert len({made.seed for made, _ in planned}) == len(planned)
    assert len({made.scenario_seed for made, _ in planned}) == 1
    assert [e["arm"] for e in document["plan"][::14]] == ["gp", "qd", "nn-cmaes", "nn-ga", "nn-qd"]
    args.objectives = "foraging,food"
    fewer, _, _ = networks_study.plan_study(args, "fixed", "shared")
    kept = {e["dir"]: e["config"]["seed"] for e in document["plan"]}
    assert all(kept[e["dir"]] == e["config"]["seed"] for e in fewer["plan"])  # shrinking keeps seeds
    assert [e["objective"] for e in fewer["plan"][:4]] == ["food", "food", "foraging", "foraging"]
    with pytest.raises(Exception, match="--objectives takes some of"):
        networks_study.chosen_objectives("food,swim")


def test_the_study_runs_end_to_end_and_a_second_start_runs_nothing_again(tmp_path, capsys):
    out = tmp_path / "study"
    args = ["--study", "bt-vs-nn", "--runs", "1", "--evaluations", "60", "--trials", "1"]
    args += ["--objectives", "food", "--processes", "2", "--out", str(out), "--no-progress"]
    assert experiment(args) == 0
    rows = list(csv.DictReader(io.StringIO((out / "runs.csv").read_text())))
    assert list(rows[0]) == networks_study.CSV_HEADER
    assert [r["arm"] for r in rows] == ["gp", "qd", "nn-cmaes", "nn-ga", "nn-qd"]
    assert all(r["objective"] == "food" and r["best_fitness"] and r["heldout_best_fitness"] for r in rows)
    assert [bool(r["coverage"]) for r in rows] == [False, True, False, False, True]
    for row in rows:
        if row["arm"].startswith("nn-"):
            summary = json.loads((out / f"runs/{row['arm']}/food/run00/summary.json").read_text())
            assert summary["produced"] >= 60 and summary["finished"]
            assert float(row["best_fitness"]) == summary["best"]["fitness"]
    report = (out / "report.md").read_text()
    for heading in ("## Scores", "## Does readability cost performance?", "## Repertoires of trees"):
        assert heading in report
    assert "Holm" in report and "figures/best_fitness.png" in report and "figures/coverage.png" in report
    assert all((out / "figures" / f"{k}.png").stat().st_size > 0 for k in networks_study.CSV_HEADER[3:])
    table = list(csv.reader(io.StringIO((out / "networks" / "food.csv").read_text())))
    assert len(table) == 513 and table[0][-1] == "action"
    best = max(
        (r for r in rows if r["arm"].startswith("nn-")), key=lambda r: float(r["heldout_best_fitness"])
    )
    network = load_network(out / f"runs/{best['arm']}/food/run00/best/food.json")
    assert isinstance(network, Network)
    actions = networks_study.action_table(network.weights)
    assert [row[-1] for row in table[1:]] == [networks_study.ACTIONS[a] for a in actions]

    kept = {p: p.read_bytes() for p in out.glob("runs/*/*/run00/*.csv")}
    written = {name: (out / name).read_bytes() for name in ("runs.csv", "report.md")}
    assert experiment(args) == 0  # every run finished: nothing runs again, the report is the same
    assert {p: p.read_bytes() for p in out.glob("runs/*/*/run00/*.csv")} == kept
    assert {name: (out / name).read_bytes() for name in written} == written
    (out / "report.md").unlink()
    assert report_command([str(out)]) == 0  # the report command rebuilds the same report from the runs
    assert (out / "report.md").read_bytes() == written["report.md"]
    assert experiment([*args[:-3], "--runs", "1", "--evaluations", "70", "--out", str(out)]) == 2
    assert "other options" in capsys.readouterr().err


def test_the_committed_reports_tables_are_its_runs_csv():
    """docs/results/bt-vs-nn: the report's score table and both test tables recomputed from its runs.csv,
    over the objectives of the study's plan (experiments/bt-vs-nn)."""
    root = Path(__file__).resolve().parents[4]
    folder = root / "docs" / "results" / "bt-vs-nn"
    table = list(csv.DictReader(io.StringIO((folder / "runs.csv").read_text())))
    report = (folder / "report.md").read_text()
    objectives = json.loads((root / "experiments" / "bt-vs-nn" / "experiment.json").read_text())["objectives"]
    assert {row["objective"] for row in table} <= set(objectives)
    assert networks_study.scores_table(table, objectives) in report
    best, repertoires = networks_study.comparisons(table, objectives)
    for family in (best, repertoires):
        if family:
            assert markdown_table(family) in report
