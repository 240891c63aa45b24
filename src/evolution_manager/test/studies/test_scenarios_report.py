"""Table 6 across training scenarios (``studies.scenarios``): the report from scenario experiments, its
tables recomputed from its ``runs.csv``, and the pooled mixed model on data of known effect."""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import numpy as np
import pytest

from evolution_manager.studies import scenarios
from evolution_manager.studies.report_command import report

PAPER = Path(__file__).resolve().parents[4] / "experiments" / "paper"
COMMITTED = Path(__file__).resolve().parents[4] / "docs" / "results" / "paper" / "scenarios"


def _scenario(root: Path, name: str, scenario_seed: int, runs: range) -> None:
    """A scenario experiment folder from runs of the committed paper experiment (its files only)."""
    folder = root / name
    folder.mkdir(parents=True)
    document = json.loads((PAPER / "experiment.json").read_text())
    (folder / "experiment.json").write_text(json.dumps({**document, "scenario_seed": scenario_seed}))
    for group in (PAPER / "runs").iterdir():
        for r in runs:
            shutil.copytree(group / f"run{r:02d}", folder / "runs" / group.name / f"run{r:02d}")


def test_the_report_of_two_scenarios_has_both_tables_and_recomputes_from_its_csv(tmp_path, capsys):
    _scenario(tmp_path, "seed-0", 11, range(0, 4))
    _scenario(tmp_path, "seed-1", 22, range(4, 8))
    assert scenarios.is_scenarios_folder(tmp_path) and not scenarios.is_scenarios_folder(PAPER)
    assert report([str(tmp_path)]) == 0
    rows = scenarios.read_scenarios_csv(tmp_path / "runs.csv")
    assert len(rows) == 2 * 4 * (3 + 3 + 3)  # scenarios x runs x (GP_o, GP_fnd on three, QD_o)
    assert {row["scenario_seed"] for row in rows} == {"11", "22"}
    text = (tmp_path / "report.md").read_text()
    per_scenario, pooled = scenarios.tables_from_rows(rows)
    assert per_scenario in text and pooled in text
    assert "1. scenario seed 11: 28 finished runs" in text
    assert pooled.count("\n") == 2 + 18  # header, rule, table 6's 18 rows
    # --beside is the paper experiment's option: refused in one line, nothing written
    before = (tmp_path / "report.md").read_bytes()
    assert report([str(tmp_path), "--beside", str(tmp_path / "runs.csv")]) == 2
    assert capsys.readouterr().err.count("\n") == 1 and (tmp_path / "report.md").read_bytes() == before


def test_the_mixed_model_recovers_a_known_difference_with_scenario_offsets():
    rng = np.random.default_rng(4)
    first, second = {}, {}
    for s, offset in enumerate((0.0, 0.3, -0.2, 0.1, 0.5)):
        first[str(s)] = list(offset + rng.normal(0.0, 0.05, 20))
        second[str(s)] = list(offset + 0.08 + rng.normal(0.0, 0.05, 20))
    estimate, low, high, p = scenarios._mixed(first, second)
    assert low < 0.08 < high and estimate == pytest.approx(0.08, abs=0.02) and p < 1e-6
    same = {s: list(v) for s, v in first.items()}
    shifted = {s: list(np.array(v)[::-1]) for s, v in same.items()}  # the same values: no difference
    assert scenarios._mixed(same, shifted)[3] > 0.5


def test_a_p_value_that_underflows_is_shown_as_below_the_smallest_not_zero():
    assert scenarios.shown_p(0.0) == "< 1e-300" and scenarios.shown_p(1e-301) == "< 1e-300"
    assert scenarios.shown_p(0.04287) == "0.0429" and scenarios.shown_p(2.5e-12) == "2.5e-12"
    row = scenarios.Pooled("QD score", "food", "GP_food", "QD_food", 3, 60, 0.172, 0.163, 0.181, 0.0, 0.0)
    assert "| < 1e-300 | < 1e-300 |" in scenarios._pooled_table([row])


def test_the_committed_scenarios_report_recomputes_from_its_runs_csv():
    rows = scenarios.read_scenarios_csv(COMMITTED / "runs.csv")
    per_scenario, pooled = scenarios.tables_from_rows(rows)
    text = (COMMITTED / "report.md").read_text()
    assert per_scenario in text and pooled in text


def test_the_committed_paper_report_has_table_6_with_intervals_recomputed_from_its_runs_csv():
    from evolution_manager.studies.report import _table6, runs_from_csv

    paper = COMMITTED.parent
    table = _table6(runs_from_csv(paper / "runs.csv"))
    assert table in (paper / "report.md").read_text()
    assert "difference (95 % CI)" in table and table.count(" [") >= 18
