"""The run loop and its directory (with the toy evaluator): resume, logs, passive grids, refusals."""

from __future__ import annotations

import csv
import itertools
import json

import pytest
from recompute import check_repertoires
from toy import ToyEvaluator

from evolution_manager.config import RunConfig, evaluation_seed
from evolution_manager.errors import RunDirectoryError
from evolution_manager.outputs import write_results
from evolution_manager.primitives import OBJECTIVES
from evolution_manager.run import Run

RESULT_FILES = [
    "evaluations.csv",
    "progress.csv",
    "summary.json",
    *(f"repertoire_{o}.json" for o in OBJECTIVES),
]


def _files(root, names=RESULT_FILES):
    return {name: (root / name).read_bytes() for name in names if (root / name).exists()}


def _finish(run):
    run.execute(checkpoint_interval=0)
    write_results(run, with_figures=False)
    return run


@pytest.mark.parametrize("algorithm,objective", [("gp", "food"), ("gp-fnd", None), ("qd", "nest")])
def test_a_resumed_run_ends_identical_to_an_uninterrupted_one(tmp_path, algorithm, objective):
    config = RunConfig.make(algorithm, objective, 700, 11)
    straight = _finish(Run.start(config, tmp_path / "straight", ToyEvaluator()))
    stopped = Run.start(config, tmp_path / "stopped", ToyEvaluator())
    for stop in (90, 260, 430):
        stopped.execute(checkpoint_interval=0, stop_after=stop)
        # a crash after the last checkpoint leaves rows the checkpoint does not know about
        with open(tmp_path / "stopped" / "evaluations.csv", "a") as log:
            log.write("999,1,garbage\n")
        stopped = Run.resume(tmp_path / "stopped", ToyEvaluator())
    _finish(stopped)
    assert _files(tmp_path / "stopped") == _files(tmp_path / "straight")
    if algorithm == "qd":
        assert (tmp_path / "stopped" / "archive.json").read_bytes() == (
            tmp_path / "straight" / "archive.json"
        ).read_bytes()
    assert stopped.evaluations == straight.evaluations == 700


def test_passive_grids_agree_with_a_recomputation_from_the_evaluation_log(tmp_path):
    run = _finish(
        Run.start(RunConfig.make("qd", "food", 900, 12), tmp_path / "r", ToyEvaluator(fail_on="stop, stop"))
    )
    with open(tmp_path / "r" / "evaluations.csv", newline="") as handle:
        rows = list(csv.DictReader(handle))
    assert [int(r["evaluation"]) for r in rows] == list(range(900))
    assert all(int(r["seed"]) == evaluation_seed(12, i) for i, r in enumerate(rows))
    assert any(r["error"] for r in rows)
    check_repertoires(tmp_path / "r")
    for objective in OBJECTIVES:
        document = json.loads((tmp_path / "r" / f"repertoire_{objective}.json").read_text())
        grid = run.passive[objective]
        assert grid.qd_score == document["qd_score"] and grid.coverage == document["coverage"]
    archive = json.loads((tmp_path / "r" / "archive.json").read_text())
    assert archive["items"] == json.loads((tmp_path / "r" / "repertoire_food.json").read_text())["items"]


def test_progress_is_one_row_per_batch_and_never_loses_quality(tmp_path):
    _finish(Run.start(RunConfig.make("qd", "density", 400, 13), tmp_path / "r", ToyEvaluator()))
    with open(tmp_path / "r" / "progress.csv", newline="") as handle:
        rows = list(csv.DictReader(handle))
    counts = [int(r["evaluations"]) for r in rows]
    # the initial batch, then batches of 50 varied parents of which the untouched ones are not evaluated
    assert counts[0] == 100 and counts[-1] == 400
    assert all(0 < b - a <= 50 for a, b in itertools.pairwise(counts))
    for objective in OBJECTIVES:
        for metric in ("best", "coverage", "qd_score"):
            values = [float(r[f"{metric}_{objective}"]) for r in rows]
            assert values == sorted(values)


def test_a_run_never_overwrites_another_and_resume_needs_a_run(tmp_path):
    config = RunConfig.make("gp", "nest", 60, 1)
    Run.start(config, tmp_path / "r", ToyEvaluator())
    before = _files(tmp_path / "r", ["config.json", "checkpoint.json"])
    with pytest.raises(RunDirectoryError, match="already holds a run"):
        Run.start(config, tmp_path / "r", ToyEvaluator())
    assert _files(tmp_path / "r", ["config.json", "checkpoint.json"]) == before
    with pytest.raises(RunDirectoryError, match="no run to resume"):
        Run.resume(tmp_path / "empty", ToyEvaluator())
    (tmp_path / "other").mkdir()
    (tmp_path / "other" / "progress.csv").write_text("someone else's file\n")
    with pytest.raises(RunDirectoryError, match="not empty"):
        Run.start(config, tmp_path / "other", ToyEvaluator())
    assert (tmp_path / "other" / "progress.csv").read_text() == "someone else's file\n"


def test_a_damaged_checkpoint_is_refused_with_its_name(tmp_path):
    Run.start(RunConfig.make("gp", "nest", 60, 1), tmp_path / "r", ToyEvaluator())
    (tmp_path / "r" / "checkpoint.json").write_text('{"format": 1, "config": ')
    with pytest.raises(RunDirectoryError, match=r"checkpoint\.json"):
        Run.resume(tmp_path / "r", ToyEvaluator())
