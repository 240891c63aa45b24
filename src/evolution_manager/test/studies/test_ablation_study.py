"""``experiment --study ablation``: the arms, seeds, folders and libraries of its plan (made from the
committed foraging study), a plan that grows with ``--runs``, one-line refusals, and its report recomputed
from ``runs.csv``."""

from __future__ import annotations

import csv
import json
import statistics
from pathlib import Path

import numpy as np
import pytest

from bt_controller.language import load_library, parse
from evolution_manager.errors import EvolutionError
from evolution_manager.studies import ablation_study, planning
from evolution_manager.studies.experiment import build_parser, experiment

FORAGING = Path(__file__).resolve().parents[4] / "experiments" / "foraging"


def _plan(out: Path, *more: str):
    args = build_parser().parse_args(
        ["--study", "ablation", "--primitives-from", str(FORAGING), "--out", str(out), *more]
    )
    return ablation_study.plan_study(args, "fixed", "shared")


@pytest.fixture(scope="module")
def planned(tmp_path_factory: pytest.TempPathFactory):
    """A plan of 2 runs per arm and its stage's runs, the libraries made in its folder."""
    out = tmp_path_factory.mktemp("ablation") / "a"
    document, stages, budgets = _plan(out, "--runs", "2", "--evaluations", "300")
    return out, document, stages[0](), budgets


def test_the_plan_has_five_arms_with_distinct_seeds_folders_and_the_study_settings(planned):
    out, document, runs, budgets = planned
    assert [arm.name for arm in ablation_study.ARMS] == ["elite8", "random8", "unevolved8", "padded1", "me8"]
    assert len(document["plan"]) == 10 and len({entry["seed"] for entry in document["plan"]}) == 10
    assert [entry["dir"] for entry in document["plan"][:2]] == ["arms/elite8/run00", "arms/elite8/run01"]
    assert set(budgets.values()) == {300} and set(budgets) == {entry["dir"] for entry in document["plan"]}
    source = json.loads((FORAGING / "experiment.json").read_text())
    assert document["scenario_seed"] == source["scenario_seed"] and document["trials"] == source["trials"]
    seeds = {name: entry.get("seed") for name, entry in document["libraries"].items()}
    assert seeds["elite8"] is None and seeds["padded1"] is None and seeds["random8"] != seeds["unevolved8"]
    configs = {directory: made for made, directory in runs}
    for entry in document["plan"]:
        made = configs[entry["dir"]]
        assert made.task.name == "foraging" and made.nodes == "hierarchical"
        assert made.library == str(out.absolute() / "libraries" / f"{entry['library']}.json")
        assert made.algorithm == ("qd" if entry["arm"] == "me8" else "gp")
        assert made.scenario_seed == source["scenario_seed"] and made.evaluations == 300
    assert configs["arms/me8/run00"].library == configs["arms/elite8/run00"].library


def test_the_libraries_are_the_arms_ablations_of_the_studys_qd8(planned):
    out, _, _, _ = planned
    qd8, qd1 = (load_library(FORAGING / "libraries" / f"{n}.json") for n in ("qd8", "qd1"))
    libraries = {name: load_library(out / "libraries" / f"{name}.json") for name in ablation_study.LIBRARIES}
    # elite8 is the study's qd8 itself, its source runs found from its new folder
    elite = libraries["elite8"]
    assert elite.digest == qd8.digest
    for p, e in zip(elite.primitives, qd8.primitives, strict=True):
        moved, there = out / "libraries" / str(p.source["run"]), FORAGING / "libraries" / str(e.source["run"])
        assert moved.resolve() == there.resolve() and (moved / "config.json").exists()
    # every library has elite8's 48 names, in order
    for library in libraries.values():
        assert library.names == qd8.names and len(library.names) == 48
    # unevolved: same node counts, other trees
    sizes = [parse(p.text).size for p in qd8.primitives]
    assert [parse(p.text).size for p in libraries["unevolved8"].primitives] == sizes
    assert all("got_food" not in p.text for p in libraries["unevolved8"].primitives)  # as the evolved
    assert all(
        a.tree != b.tree for a, b in zip(libraries["unevolved8"].primitives, qd8.primitives, strict=True)
    )
    # padded: each family's one qd1 primitive eight times
    for p in libraries["padded1"].primitives:
        family = p.name.rstrip("0123456789")
        assert p.tree == qd1.primitive(f"{family}1")
    # random: each a tree of its own block, drawn from a pool, mostly not the elite
    drawn = libraries["random8"]
    for p, e in zip(drawn.primitives, qd8.primitives, strict=True):
        assert p.source["block"] == e.source["block"] and p.source["objective"] == e.source["objective"]
        assert 0 <= p.source["ablation"]["drawn"] < p.source["ablation"]["pool"]
        assert (out / "libraries" / str(p.source["run"]) / "config.json").exists()
    assert sum(p.tree != e.tree for p, e in zip(drawn.primitives, qd8.primitives, strict=True)) >= 40


def test_the_libraries_are_drawn_from_the_seeded_generators_alone(planned, tmp_path):
    out, _, _, _ = planned
    _, stages, _ = _plan(tmp_path / "again", "--runs", "1")
    stages[0]()
    for name in ("random8", "unevolved8"):
        assert (tmp_path / "again" / "libraries" / f"{name}.json").read_text().replace(
            str(tmp_path / "again"), ""
        ) == (out / "libraries" / f"{name}.json").read_text().replace(str(out), "")
    _, stages, _ = _plan(tmp_path / "other", "--runs", "1", "--seed", "7")
    stages[0]()
    other = load_library(tmp_path / "other" / "libraries" / "unevolved8.json")
    assert other.digest != load_library(out / "libraries" / "unevolved8.json").digest


def test_more_runs_grow_the_plan_and_keep_its_runs_seeds_and_libraries(tmp_path):
    small, _, _ = _plan(tmp_path / "a", "--runs", "2")
    large, _, _ = _plan(tmp_path / "a", "--runs", "3")
    saved, given = json.loads(json.dumps(small)), json.loads(json.dumps(large))
    assert planning.more_runs(saved, given) and len(given["plan"]) == 15
    other, _, _ = _plan(tmp_path / "a", "--runs", "3", "--seed", "1")
    assert not planning.more_runs(saved, json.loads(json.dumps(other)))


def test_the_study_is_refused_in_one_line_without_a_foraging_study(tmp_path, capsys):
    out = str(tmp_path / "a")
    assert experiment(["--study", "ablation", "--out", out]) == 2
    assert "needs --primitives-from" in capsys.readouterr().err
    assert experiment(["--study", "ablation", "--primitives-from", str(tmp_path), "--out", out]) == 2
    assert "is not a foraging study" in capsys.readouterr().err
    (tmp_path / "p").mkdir()
    (tmp_path / "p" / "experiment.json").write_text('{"study": "replication"}')
    assert experiment(["--study", "ablation", "--primitives-from", str(tmp_path / "p"), "--out", out]) == 2
    more = ["--study", "ablation", "--primitives-from", str(FORAGING), "--trials", "3", "--out", out]
    assert experiment(more) == 2
    errors = capsys.readouterr().err
    assert errors.count("\n") == 2 and "--trials 3 differs" in errors and not (tmp_path / "a").exists()


def _rows(rng: np.random.Generator) -> list[dict[str, str]]:
    shifts = {"elite8": 0.0, "random8": -0.3, "unevolved8": -0.6, "padded1": -0.4, "me8": 0.05}
    rows = []
    for arm, shift in shifts.items():
        for r in range(10):
            value = 1.3 + shift + rng.normal(0.0, 0.08)
            rows.append(
                {
                    "arm": arm,
                    "run": str(r),
                    "seed": str(1000 + r),
                    "best_fitness": repr(value + 0.2),
                    "heldout_best_fitness": repr(value),
                }
            )
    return rows


def test_the_report_tables_recompute_from_runs_csv(tmp_path):
    rows = _rows(np.random.default_rng(3))
    path = ablation_study.write_runs_csv(tmp_path, rows)
    with path.open(newline="") as handle:
        again = list(csv.DictReader(handle))
    assert again == rows
    per_arm, compared = ablation_study.tables_from_rows(again)
    assert (per_arm, compared) == ablation_study.tables_from_rows(rows)
    assert per_arm.count("\n") == 2 + 5
    assert (
        "one family: the 4 rows of this table (4 comparisons on 1 metric: held-out best fitness)" in compared
    )
    lines = {line.split(" | ")[0]: line for line in compared.splitlines() if " vs elite8" in line}
    assert len(lines) == 4
    assert lines["| unevolved8 vs elite8"].endswith("| lower |")
    assert lines["| me8 vs elite8"].endswith("| no difference shown |")
    # the held-out median of an arm, recomputed by hand
    elite = sorted(float(row["heldout_best_fitness"]) for row in rows if row["arm"] == "elite8")
    assert f"{(elite[4] + elite[5]) / 2:.3f} [" in next(
        line for line in per_arm.splitlines() if "| elite8 |" in line
    )


def test_a_report_with_one_arm_says_no_comparison_yet():
    rows = [row for row in _rows(np.random.default_rng(4)) if row["arm"] == "elite8"]
    _, compared = ablation_study.tables_from_rows(rows)
    assert compared.startswith("No ablation arm")


def test_the_report_command_reads_a_study_folder_of_finished_runs(planned, tmp_path, capsys):
    from evolution_manager.studies.report_command import report

    _, document, _, _ = planned
    root = tmp_path / "study"
    root.mkdir()
    (root / "experiment.json").write_text(json.dumps(document))
    for k, entry in enumerate(document["plan"]):
        if entry["arm"] == "padded1":
            continue  # not finished yet
        run = root / entry["dir"]
        run.mkdir(parents=True)
        scores = {"best_fitness": 1.0 + k / 100, "heldout_best_fitness": 0.9 + k / 100}
        (run / "summary.json").write_text(json.dumps({"finished": True, "objectives": {"foraging": scores}}))
    assert report([str(root)]) == 0
    text = (root / "report.md").read_text()
    assert "8 of 10 runs finished" in text and "padded1" not in text.split("## Arms")[1].split("## Each")[0]
    with (root / "runs.csv").open(newline="") as handle:
        assert ablation_study.tables_from_rows(list(csv.DictReader(handle)))[1] in text


def test_a_library_file_there_is_kept_and_a_damaged_one_refused_in_one_line(planned, tmp_path):
    out, document, _, _ = planned
    folder = tmp_path / "libraries"
    folder.mkdir()
    kept = (out / "libraries" / "random8.json").read_text()
    (folder / "random8.json").write_text(kept)
    library = ablation_study.ablation_library("random8", folder, FORAGING, document["libraries"]["random8"])
    assert library.digest == load_library(out / "libraries" / "random8.json").digest
    assert (folder / "random8.json").read_text() == kept and not (folder / "elite8.json").exists()
    (folder / "random8.json").write_text('{"format": 1, "primitives": [{"name": "stop", "tree": "stop"}]}')
    with pytest.raises(EvolutionError, match="remove it to make it again") as caught:
        ablation_study.ablation_library("random8", folder, FORAGING, document["libraries"]["random8"])
    assert "\n" not in str(caught.value)


def test_the_committed_reports_tables_are_its_runs_csv():
    """docs/results/foraging/replication/ablation: the report's two tables recomputed from its runs.csv, and
    the README's run count and each arm's held-out median from the same rows."""
    folder = (
        Path(__file__).resolve().parents[4] / "docs" / "results" / "foraging" / "replication" / "ablation"
    )
    with (folder / "runs.csv").open(newline="") as handle:
        table = list(csv.DictReader(handle))
    report = (folder / "report.md").read_text()
    per_arm, compared = ablation_study.tables_from_rows(table)
    assert per_arm in report and compared in report
    assert report.count(f"{len(table)} of 50 runs finished") == 1
    readme = " ".join((folder / "README.md").read_text().split())
    assert f"{len(table)} of the 50 planned runs" in readme
    for arm in ablation_study.ARMS:
        heldout = [float(row["heldout_best_fitness"]) for row in table if row["arm"] == arm.name]
        assert f"`{arm.name}` {statistics.median(heldout):.3f} [" in readme, arm.name
