"""``experiment --study replication``: a library per seed of the foraging study's primitive runs, its plan,
its libraries from the committed runs, and its report's mixed model and equivalence test."""

from __future__ import annotations

import csv
import io
import json
import os
import shutil
from pathlib import Path

import numpy as np
import pytest

from evolution_manager.studies import replication_study
from evolution_manager.studies.experiment import build_parser, experiment
from evolution_manager.studies.report_command import report

FORAGING = Path(__file__).resolve().parents[4] / "experiments" / "foraging"


def _plan(tmp_path, *more):
    args = build_parser().parse_args(
        ["--study", "replication", "--primitives-from", str(FORAGING), "--out", str(tmp_path / "r"), *more]
    )
    return replication_study.plan_study(args, "fixed", "shared")


def test_the_plan_has_a_library_per_primitive_seed_and_kind_with_distinct_run_seeds(tmp_path):
    document, stages, budgets = _plan(tmp_path, "--runs", "3", "--evaluations", "500")
    libraries = document["libraries"]
    assert len(libraries) == 20 and libraries["qd8-s4"]["from"] == [
        f"primitives/{label}/run04"
        for label in ("QD_density", "QD_nest", "QD_food", "QD_idensity", "QD_inest", "QD_ifood")
    ]
    assert libraries["gpfnd8-s4"]["from"] == ["primitives/GP_fnd/run04"]
    assert len(document["arms"]) == 60 and len({arm["seed"] for arm in document["arms"]}) == 60
    assert set(budgets.values()) == {500} and document["scenario_seed"] is not None
    # the one stage builds each library from its own seed's runs, and its runs evolve over that library
    planned = stages[0]()
    assert len(planned) == 60
    first, directory = planned[0]
    assert directory == "arms/qd8-s0/run00" and first.library.endswith("libraries/qd8-s0.json")
    built = (tmp_path / "r" / "libraries" / "qd8-s0.json").read_text()
    assert "primitives/QD_density/run00" in built and "run01" not in built


def test_the_study_is_refused_without_a_foraging_study_to_draw_from(tmp_path, capsys):
    out = str(tmp_path / "r")
    assert experiment(["--study", "replication", "--out", out]) == 2
    assert "needs --primitives-from" in capsys.readouterr().err
    assert experiment(["--study", "replication", "--primitives-from", str(tmp_path), "--out", out]) == 2
    assert experiment(["--primitives-from", str(FORAGING), "--out", out]) == 2  # the paper's study: no
    assert capsys.readouterr().err.count("\n") == 2 and not (tmp_path / "r").exists()


def _rows(rng, gap):
    rows = []
    for kind, shift in (("qd8", 0.0), ("gpfnd8", gap)):
        for k in range(6):
            library_effect = rng.normal(0.0, 0.05)
            for r in range(3):
                value = 1.5 + shift + library_effect + rng.normal(0.0, 0.03)
                rows.append(
                    {
                        "arm": f"hier-{kind}-s{k}",
                        "library": f"{kind}-s{k}",
                        "seed": str(100 * k + r),
                        "best_fitness": repr(value + 0.1),
                        "heldout_best_fitness": repr(value),
                        replication_study.ARGOS: repr(value - 0.05),
                    }
                )
    return rows


def test_the_mixed_model_finds_a_difference_and_equivalence_where_they_are():
    different = replication_study.mixed_comparison(
        _rows(np.random.default_rng(1), 0.3), "heldout_best_fitness"
    )
    estimate, low, high, p, p_tost = different
    assert abs(estimate - 0.3) < 0.1
    assert low < 0.3 < high and p < 0.001 and p_tost > 0.5
    same = replication_study.mixed_comparison(_rows(np.random.default_rng(2), 0.0), "heldout_best_fitness")
    assert same[4] < 0.05  # within the margin: equivalent
    assert (
        replication_study.mixed_comparison(_rows(np.random.default_rng(3), 0.0)[:12], "best_fitness") is None
    )


def _pooled(rows, value):
    """``rows`` with ten best-of-seeds rows of each kind at ``value``."""
    extra = [
        {
            **rows[0],
            "arm": f"hier-{kind}",
            "library": kind,
            "seed": str(r),
            "heldout_best_fitness": repr(value),
        }
        for kind in ("qd8", "gpfnd8")
        for r in range(10)
    ]
    return rows + extra


def test_the_mixed_model_leaves_the_best_of_seeds_rows_out():
    rows = _rows(np.random.default_rng(4), 0.2)
    assert replication_study.mixed_comparison(_pooled(rows, 9.0), "heldout_best_fitness") == (
        replication_study.mixed_comparison(rows, "heldout_best_fitness")
    )
    text = replication_study.pooled_from_rows(_pooled(rows, 9.0))
    assert "- qd8 from every seed: held-out median 9.000" in text and "6 of them below it" in text
    assert replication_study.pooled_from_rows(rows).startswith("No best-of-seeds runs")


def test_the_best_of_seeds_rows_are_the_foraging_studys_runs_on_its_whole_libraries(tmp_path):
    """The foraging study's hier-qd8 and hier-gpfnd8 runs, as the replication's plan names that study; an
    ARGoS score only where its raw rows hold every seed; None when the study is not there."""
    study = tmp_path / "foraging"
    document = json.loads((FORAGING / "experiment.json").read_text())
    study.mkdir()
    (study / "experiment.json").write_text(json.dumps(document))
    runs = [entry for entry in document["arms"] if entry["arm"] in ("hier-qd8", "hier-gpfnd8")]
    for entry in runs:
        (study / entry["dir"]).mkdir(parents=True)
        shutil.copy(FORAGING / entry["dir"] / "summary.json", study / entry["dir"] / "summary.json")
    first = json.loads((study / runs[0]["dir"] / "summary.json").read_text())
    tree = first["objectives"]["foraging"]["best_tree"]
    with (study / "argos_raw_qd8.tsv").open("w") as raw:
        raw.write("\t".join(FORAGING_RAW) + "\n")
        for seed in (1, 2):
            fields = [tree, str(seed), "x", "2.0", str(1.0 + seed), "0", "0", "0.5", "", "foraging", "qd8"]
            raw.write("\t".join(fields) + "\n")
    pooled = replication_study.pooled_rows({"primitives_from": str(study)}, (1, 2))
    assert [row["arm"] for row in pooled] == [entry["arm"] for entry in runs]
    assert all(replication_study.is_pooled(row) for row in pooled)
    assert [row["seed"] for row in pooled] == [str(entry["seed"]) for entry in runs]
    assert pooled[0][replication_study.ARGOS] == repr(2.5) and not any(
        row[replication_study.ARGOS] for row in pooled[1:]
    )
    assert replication_study.pooled_rows({"primitives_from": str(tmp_path / "gone")}) is None


def test_the_report_tables_recompute_from_runs_csv(tmp_path):
    rows = _rows(np.random.default_rng(5), 0.05)
    buffer = io.StringIO()
    writer = csv.DictWriter(buffer, replication_study.CSV_HEADER, lineterminator="\n")
    writer.writeheader()
    writer.writerows(rows)
    again = list(csv.DictReader(io.StringIO(buffer.getvalue())))
    assert replication_study.tables_from_rows(again) == replication_study.tables_from_rows(rows)
    per_library, verdicts = replication_study.tables_from_rows(rows)
    assert per_library.count("\n") == 2 + 12 and verdicts.count("TOST") == 3


def test_the_argos_agreement_line_names_the_runs_beyond_its_width():
    def row(arm: str, library: str, held: str, argos: str) -> dict[str, str]:
        return {"arm": arm, "library": library, "seed": str(len(arm) + len(held)), "best_fitness": "1.0",
                "heldout_best_fitness": held, replication_study.ARGOS: argos}  # fmt: skip

    table = [
        row("hier-qd8-s0", "qd8-s0", "1.0", "1.05"),
        row("hier-qd8-s0", "qd8-s0", "0.5", "0.7"),
        row("hier-gpfnd8-s0", "gpfnd8-s0", "1.2", ""),  # not scored in ARGoS: left out
        row("hier-qd8", "qd8", "1.0", "2.0"),  # best-of-seeds: left out
    ]
    line = replication_study.agreement_from_rows(table)
    assert "over the 2 runs that have both: mean absolute difference 0.125, largest 0.200" in line
    assert "1 of 2 within 0.1 (beyond it: hier-qd8-s0, seed 14 (+0.200))." in line
    assert "No run" in replication_study.agreement_from_rows(table[2:])
    assert "beyond" not in replication_study.agreement_from_rows(table[:1])


REPLICATION = Path(__file__).resolve().parents[4] / "experiments" / "foraging-replication"
FORAGING_RAW = ["tree", "seed", "chromosome", "argos_wall_s", "foraging", "movement", "rotation",
                "conditionality", "foraging_trials", "build", "subs"]  # fmt: skip


def test_every_runs_best_forager_takes_its_argos_score_from_the_drivers_rows(tmp_path, monkeypatch, capsys):
    """The committed runs' best foragers; the driver's rows (written here in its format) give a run its ARGoS
    score only where every seed is there; the report's table and count follow; without a build the command
    stops in one line and writes nothing."""
    copy = tmp_path / "r"
    # the study's runs without the driver's committed rows, which this test writes itself
    ignored = shutil.ignore_patterns("checkpoint.json", "evaluations.csv", "argos_raw_*", "argos_subs_*")
    shutil.copytree(REPLICATION, copy, ignore=ignored)
    found = replication_study.foragers(copy)
    assert len(found) >= 2
    for entry, forager in found:
        summary = json.loads((copy / entry["dir"] / "summary.json").read_text())
        assert forager.tree == summary["objectives"]["foraging"]["best_tree"]
        assert (forager.library, f"run{forager.run:02d}") == (entry["library"], entry["dir"].rsplit("/")[-1])
    # without a build: one line, nothing written
    monkeypatch.setenv("HOME", str(tmp_path / "home"))
    for name in [k for k in os.environ if k.startswith(("ARGOS_", "BT_ARGOS", "SRAND"))]:
        monkeypatch.delenv(name)
    assert report([str(copy), "--argos-eval", str(tmp_path / "argos_eval.py"), "--argos-seeds", "1-2"]) == 2
    error = capsys.readouterr().err
    assert len(error.strip().splitlines()) == 1 and "ARGoS" in error and not list(copy.glob("argos_raw_*"))
    assert report([str(copy), "--beside", str(copy / "x.csv")]) == 2
    capsys.readouterr()
    # the driver's rows for the first library's runs: seeds 1 and 2 for its first run, seed 1 for the others
    first = found[0][1].library
    mine = [f for _, f in found if f.library == first]
    with (copy / f"argos_raw_{first}.tsv").open("w") as raw:
        raw.write("\t".join(FORAGING_RAW) + "\n")
        for k, forager in enumerate(mine):
            for seed in (1, 2) if k == 0 else (1,):
                value = 0.5 + 0.1 * k + 0.01 * seed
                raw.write("\t".join([forager.tree, str(seed), "x", "2.0", str(value), "0", "0", "0.5", "",
                                     "foraging", first]) + "\n")  # fmt: skip
    table = replication_study.rows(copy, (1, 2))
    scored = [row[replication_study.ARGOS] for row in table]
    assert scored[0] and float(scored[0]) == pytest.approx(0.515) and not any(scored[1:])
    assert report([str(copy), "--argos-seeds", "1-2"]) == 0
    capsys.readouterr()
    text = (copy / "report.md").read_text()
    assert f"| {first} | {len(mine)} |" in text and "| 0.515 (1) |" in text
    assert f"the runs not yet scored: {len(found) - 1} of {len(found)} here" in text
    assert (copy / "runs.csv").read_text().splitlines()[0].endswith(",argos_best_fitness")


def test_the_committed_reports_tables_are_its_runs_csv():
    """docs/results/foraging/replication: the report's per-library table, best-of-seeds lines, verdicts and
    ARGoS agreement recomputed from its runs.csv, and the README's range of the per-seed libraries' held-out
    medians and its mean ARGoS difference from the same table."""
    folder = Path(__file__).resolve().parents[4] / "docs" / "results" / "foraging" / "replication"
    table = list(csv.DictReader(io.StringIO((folder / "runs.csv").read_text())))
    report = (folder / "report.md").read_text()
    per_library, verdicts = replication_study.tables_from_rows(table)
    assert per_library in report and verdicts in report
    assert replication_study.pooled_from_rows(table) in report
    per_seed = [row for row in table if not replication_study.is_pooled(row)]
    assert f"{len(per_seed)} finished forager runs" in report
    medians = [
        float(line.split(" | ")[3]) for line in per_library.splitlines()[2:] if "(every seed)" not in line
    ]
    readme = " ".join((folder / "README.md").read_text().split())
    assert f"range from {min(medians):.2f} to {max(medians):.2f} deliveries" in readme
    assert replication_study.agreement_from_rows(table) in report
    both = [row for row in per_seed if row[replication_study.ARGOS] and row["heldout_best_fitness"]]
    sizes = [abs(float(row[replication_study.ARGOS]) - float(row["heldout_best_fitness"])) for row in both]
    assert f"mean absolute difference {sum(sizes) / len(sizes):.3f} over {len(both)} runs" in readme
