"""The report's transfer section: each run's best tree beside its ARGoS score, read from the driver's rows.

ARGoS is not built where the tests run, so the driver's raw rows are written here in its format (the same
columns ``swarm_sim.validation.transfer.read_argos_raw`` reads from real runs); that the missing build stops
the command in one line, with the report and runs.csv as they were, is tested against the real harness path.
"""

from __future__ import annotations

import csv
import math
import statistics as stats

import pytest

from evolution_manager.studies import argos_transfer
from evolution_manager.studies.experiment import experiment
from evolution_manager.studies.report import load_runs
from evolution_manager.studies.report_command import report
from swarm_sim.evaluation import BatchEvaluator, EvaluationRequest
from swarm_sim.model import OBJECTIVES, default_config

RAW_COLUMNS = ["tree", "seed", "chromosome", "argos_wall_s", "density", "nest", "food", "movement",
               "rotation", "conditionality"]  # fmt: skip
SEEDS = (1, 2, 3)


@pytest.fixture(scope="module")
def small_experiment(tmp_path_factory):
    out = tmp_path_factory.mktemp("transfer") / "experiment"
    args = ["--runs", "2", "--evaluations", "50", "--out", str(out), "--processes", "1", "--no-progress"]
    assert experiment(args) == 0
    return out


def _offset(tree: str) -> float:
    """A made-up ARGoS value per tree: a loss that differs between trees, so the tests can recompute it."""
    return 0.01 * (len(tree) % 7) - 0.02


def write_raw(root, trees, seeds=SEEDS, skip=()):
    """The driver's rows for ``trees`` (best tree -> our held-out score on its objective), every seed,
    ARGoS's fitness spread around held-out minus ``_offset`` (0 +- 0.003 over the seeds)."""
    with (root / argos_transfer.RAW_FILE).open("w", newline="") as f:
        writer = csv.writer(f, delimiter="\t", lineterminator="\n")
        writer.writerow(RAW_COLUMNS)
        for tree, value in trees.items():
            if tree in skip:
                continue
            for k, seed in enumerate(seeds):
                spread = 0.003 * (k - (len(seeds) - 1) / 2)
                row = {"density": 0.5, "nest": 0.5, "food": 0.5}
                objective, held = value
                row[objective] = held - _offset(tree) + spread
                writer.writerow([tree, seed, tree, 0.4, row["density"], row["nest"], row["food"], 0, 0, 0.5])


def best_of(root):
    return argos_transfer.best_trees(load_runs(root))


def test_every_runs_best_tree_is_picked_on_each_objective_it_is_compared_on(small_experiment):
    runs = load_runs(small_experiment)
    best = argos_transfer.best_trees(runs)
    assert len(runs) == 14
    assert len(best) == 2 * 6 + 2 * 3  # GP_o and QD_o once each, GP_fnd on the three objectives
    assert {(b.label, b.objective) for b in best if b.label == "GP_fnd"} == {
        ("GP_fnd", o) for o in ("density", "nest", "food")
    }
    for b in best:
        (run,) = [
            r for r in runs
            if r.objective in (None, b.objective) and r.label(b.objective) == b.label and r.index == b.run
        ]  # fmt: skip
        m = run.summary["objectives"][b.objective]
        assert (b.tree, b.best_fitness) == (m["best_tree"], m["best_fitness"])
        assert b.heldout == m["heldout_best_fitness"] is not None


def test_the_report_sets_each_best_tree_here_beside_its_argos_score(small_experiment, capsys):
    best = best_of(small_experiment)
    trees = {}
    for b in best:  # a tree best on two objectives (it can happen) keeps the first
        trees.setdefault(b.tree, (b.objective, b.heldout))
    write_raw(small_experiment, trees)
    assert report([str(small_experiment), "--argos-seeds", "1-3"]) == 0
    capsys.readouterr()
    rows = list(csv.DictReader((small_experiment / argos_transfer.CSV_FILE).open()))
    assert [r["algorithm"] for r in rows] == [b.label for b in best]
    # ours: the model on fresh seeds 1-3 (as many as ARGoS's), the experiment's 10 trials each
    evaluator = BatchEvaluator(default_config("paper"))
    for row, b in zip(rows, best, strict=True):
        assert row["tree"] == b.tree and int(row["argos_n"]) == 3 == int(row["ours_n"])
        results = evaluator.evaluate([EvaluationRequest(b.tree, seed, 10) for seed in SEEDS])
        values = [r.fitness[OBJECTIVES.index(b.objective)] for r in results]
        assert float(row["ours_fitness"]) == pytest.approx(stats.fmean(values), abs=1e-12)
        objective, held = trees[b.tree]
        if objective == b.objective:
            assert float(row["argos_fitness"]) == pytest.approx(held - _offset(b.tree), abs=1e-9)
            assert float(row["argos_sem"]) == pytest.approx(0.003 / math.sqrt(3), rel=1e-6)
        z = (float(row["ours_fitness"]) - float(row["argos_fitness"])) / math.hypot(
            float(row["ours_sem"]), float(row["argos_sem"])
        )
        assert float(row["z"]) == pytest.approx(z, abs=1e-3)
        assert row["verdict"] in ("indistinguishable", "agrees", "OUTSIDE")
    text = (small_experiment / "report.md").read_text()
    assert "## Transfer: each run's best tree in the authors' ARGoS" in text
    assert "not yet scored in ARGoS" not in text
    assert (small_experiment / "figures" / "transfer_argos.png").stat().st_size > 10_000
    # the QD_nest row: its loss is the mean of ours minus ARGoS over its two runs
    qd = [r for r in rows if r["algorithm"] == "QD_nest"]
    losses = [float(r["ours_fitness"]) - float(r["argos_fitness"]) for r in qd]
    se = stats.stdev(losses) / math.sqrt(2)
    section = text.split("## Transfer:")[1]
    line = next(x for x in section.splitlines() if x.startswith("| nest | QD_nest | 2 |"))
    assert f"{stats.mean(losses):.4f} ± {se:.4f}" in line
    same = sum(r["verdict"] == "indistinguishable" for r in qd)
    assert f"| {same} of 2 |" in line
    assert "loss in ARGoS" in text  # the algorithms' losses compared


def test_trees_without_every_seed_are_left_out_and_counted(small_experiment, capsys):
    best = best_of(small_experiment)
    trees = {}
    for b in best:
        trees.setdefault(b.tree, (b.objective, b.heldout))
    dropped = best[0].tree
    write_raw(small_experiment, trees, skip={dropped})
    assert report([str(small_experiment), "--argos-seeds", "1-3"]) == 0
    capsys.readouterr()
    rows = list(csv.DictReader((small_experiment / argos_transfer.CSV_FILE).open()))
    missing = sum(b.tree == dropped for b in best)
    assert len(rows) == len(best) - missing and dropped not in {r["tree"] for r in rows}
    text = (small_experiment / "report.md").read_text()
    assert f"**{missing} best trees are not yet scored in ARGoS**" in text
    # seeds the raw rows do not have: no tree is complete
    assert report([str(small_experiment), "--argos-seeds", "1-4"]) == 0
    capsys.readouterr()
    assert (small_experiment / argos_transfer.CSV_FILE).read_text().count("\n") == 1  # the header only


def test_without_an_argos_build_it_stops_in_one_line_and_keeps_the_report(small_experiment, tmp_path,
                                                                         monkeypatch, capsys):  # fmt: skip
    (small_experiment / argos_transfer.RAW_FILE).unlink(missing_ok=True)
    assert report([str(small_experiment)]) == 0
    capsys.readouterr()
    before = {name: (small_experiment / name).read_bytes() for name in ("report.md", "runs.csv")}
    for name in ("ARGOS_PREFIX", "BT_ARGOS_DIR", "SRAND_SHIM"):
        monkeypatch.delenv(name, raising=False)
    monkeypatch.setenv("HOME", str(tmp_path))
    assert report([str(small_experiment), "--argos-eval", str(tmp_path / "argos_eval.py")]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "ARGoS build not found" in err[0] and "argos_eval.py" in err[0]
    assert {name: (small_experiment / name).read_bytes() for name in before} == before
    assert not (small_experiment / argos_transfer.RAW_FILE).exists()
    assert not (small_experiment / "transfer_trees.txt").exists()


def test_bad_options_are_refused_in_one_line(small_experiment, capsys):
    assert report([str(small_experiment), "--argos-seeds", "0-2"]) == 2
    assert (
        capsys.readouterr().err == "report: error: --argos-seeds: expected distinct seeds >= 1, got '0-2'\n"
    )
    run = small_experiment / "runs" / "QD_nest" / "run00"
    assert report([str(run), "--argos-eval", "x.py"]) == 2
    assert "apply to an experiment folder, not to a run" in capsys.readouterr().err


def test_the_wilcoxon_p_needs_two_values_not_all_zero():
    assert argos_transfer.signed_rank_p([0.1]) is None
    assert argos_transfer.signed_rank_p([0.0, 0.0, 0.0]) is None
    assert argos_transfer.signed_rank_p([0.1, 0.2, 0.3, 0.4, 0.5, 0.6]) == pytest.approx(0.03125)


def test_a_persons_notes_are_kept_at_the_end_when_the_report_is_rebuilt(small_experiment, capsys):
    notes = small_experiment / "notes.md"
    notes.write_text("## What the numbers mean\n\nMeasured by hand.\n")
    try:
        assert report([str(small_experiment)]) == 0
        capsys.readouterr()
        assert (
            (small_experiment / "report.md")
            .read_text()
            .endswith("## What the numbers mean\n\nMeasured by hand.\n")
        )
    finally:
        notes.unlink()
    assert report([str(small_experiment)]) == 0
    assert "What the numbers mean" not in (small_experiment / "report.md").read_text()
