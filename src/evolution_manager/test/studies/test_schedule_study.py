"""``experiment --study qd-schedule``: the foraging study's QD primitive runs again on the authors' 2024
MAP-Elites schedule, every other setting the same, paired run by run in the report."""

from __future__ import annotations

import csv
import dataclasses
import io
import json
from pathlib import Path

import numpy as np

from evolution_manager.evolution.run_config import RunConfig
from evolution_manager.studies import schedule_study
from evolution_manager.studies.experiment import build_parser, experiment, run_one
from evolution_manager.studies.foraging_study import PRIMITIVES

FORAGING = Path(__file__).resolve().parents[4] / "experiments" / "foraging"


def test_the_plan_runs_the_studys_qd_primitives_again_on_the_2024_schedule(tmp_path):
    args = build_parser().parse_args(
        ["--study", "qd-schedule", "--primitives-from", str(FORAGING), "--runs", "2", "--out", str(tmp_path)]
    )
    document, stages, budgets = schedule_study.plan_study(args, "fixed", "shared")
    planned = stages[0]()
    assert len(planned) == 2 * len(PRIMITIVES) == len(document["plan"]) == len(budgets)
    source = {
        e["dir"]: RunConfig.from_json(e["config"])
        for e in json.loads((FORAGING / "experiment.json").read_text())["primitives"]
    }
    for (made, folder), entry in zip(planned, document["plan"], strict=True):
        old = source[entry["from"]]
        assert folder == f"runs/{old.objective}/run{entry['run']:02d}" and entry["from"].endswith(folder[-5:])
        assert (made.qd.init_batch, made.qd.batch) == (25, 25) and (old.qd.init_batch, old.qd.batch) == (
            100,
            50,
        )
        assert made == dataclasses.replace(old, qd=dataclasses.replace(old.qd, init_batch=25, batch=25))


def test_the_study_runs_pairs_its_runs_with_the_sources_and_reports(tmp_path, capsys, monkeypatch):
    kept = ("nest", "food")  # two of the six objectives are enough, in a third of the time
    monkeypatch.setattr(schedule_study, "PRIMITIVES", kept)
    committed = json.loads((FORAGING / "experiment.json").read_text())
    source = tmp_path / "foraging"
    entries = []
    for entry in committed["primitives"]:
        made = RunConfig.from_json(entry["config"])
        if not entry["dir"].endswith("run00") or made.algorithm != "qd" or made.objective not in kept:
            continue
        tiny = dataclasses.replace(made, evaluations=60, trials=1)
        entries.append({"dir": entry["dir"], "config": tiny.to_json()})
        assert run_one(tiny.to_json(), str(source / entry["dir"]), checkpoint_interval=0)
    (source / "experiment.json").write_text(
        json.dumps({**committed, "evaluations": 60, "trials": 1, "primitives": entries})
    )
    out = tmp_path / "study"

    def command(runs: str, folder: Path) -> list[str]:
        args = ["--study", "qd-schedule", "--primitives-from", str(source), "--runs", runs, "--evaluations"]
        return [*args, "60", "--trials", "1", "--processes", "1", "--no-progress", "--out", str(folder)]

    assert experiment(command("1", out)) == 0
    rows = list(csv.DictReader(io.StringIO((out / "runs.csv").read_text())))
    assert len(rows) == 2 * len(kept) and list(rows[0]) == schedule_study.CSV_HEADER
    for objective in kept:
        old, new = (r for r in rows if r["objective"] == objective)
        assert (old["schedule"], new["schedule"]) == ("2023", "2024") and old["seed"] == new["seed"]
        summary = json.loads((out / f"runs/{objective}/run00/summary.json").read_text())
        assert float(new["coverage"]) == summary["objectives"][objective]["coverage"]
        assert summary["config"]["qd"]["init_batch"] == 25 and summary["config"]["qd"]["batch"] == 25
    # a row of the report's table recomputed from runs.csv
    report = (out / "report.md").read_text()
    food = {r["schedule"]: float(r["qd_score"]) for r in rows if r["objective"] == "food"}
    assert (
        f"| food | QD score | 1 | {np.median([food['2023']]):.4g} | {np.median([food['2024']]):.4g} |"
        in report
    )
    assert "Holm" in report
    # more runs than the source has: refused in one line, nothing run
    capsys.readouterr()
    assert experiment(command("2", tmp_path / "more")) == 2
    error = capsys.readouterr().err
    assert "has 2 QD primitive runs below index 2, not 4" in error and error.count("\n") == 1
    assert not (tmp_path / "more").exists()


def test_the_committed_reports_tables_are_its_runs_csv():
    """docs/results/foraging/schedule: the report's medians and tests recomputed from its runs.csv."""
    folder = Path(__file__).resolve().parents[4] / "docs" / "results" / "foraging" / "schedule"
    table = list(csv.DictReader(io.StringIO((folder / "runs.csv").read_text())))
    report = (folder / "report.md").read_text()
    assert len(table) == 2 * 5 * len(PRIMITIVES)
    assert schedule_study.medians_table(table) in report
    assert schedule_study.markdown_table(schedule_study.comparisons(table)) in report
