"""What the hostile-files probe (``ws/probe-hostile``, ``docs/security.md``) found in this package, each as a
test: a key given twice in a run's JSON, links planted where a resume or a rebuild writes, refused only after
the work; a benchmark that wrote its results, then refused its report's link; the main job's usage block and
its ``--resume`` of a folder that is not there (it started a new job of 25,000 evaluations), its ``--out``
under a file or a dangling link; a run folder or a bag whose name is not UTF-8 (tracebacks writing the
explorer page and naming the bag's lock); ``--checkpoint-every inf``."""

from __future__ import annotations

import io
import shutil
import sys
from pathlib import Path

import pytest

from evolution_manager.errors import RunDirectoryError
from evolution_manager.evolution.run import Run
from evolution_manager.evolution.run_config import RunConfig
from evolution_manager.files import read_json
from swarm_sim.evaluation import BatchEvaluator

QUIET = ["--no-progress", "--no-figures", "--checkpoint-every", "0"]


def _tree(folder: Path) -> dict[str, bytes | None]:
    return {str(p.relative_to(folder)): p.read_bytes() if p.is_file() else None for p in folder.rglob("*")}


@pytest.fixture(scope="module")
def unfinished(tmp_path_factory) -> Path:
    """A real run stopped after its first batch."""
    out = tmp_path_factory.mktemp("hostile") / "run"
    config = RunConfig.make("qd", "food", 60, 5, trials=1)
    run = Run.start(config, out, BatchEvaluator(config.world(), threads=1))
    run.execute(checkpoint_interval=0, stop_after=1)
    assert run.lock is not None
    run.lock.release()
    return out


def test_a_key_given_twice_in_a_run_file_is_refused(tmp_path):
    """It was read silently (the last value won): a resume ran on with a configuration no one wrote."""
    path = tmp_path / "config.json"
    path.write_text('{"seed": 1, "seed": 2}')
    with pytest.raises(RunDirectoryError, match="the key 'seed' appears twice") as refused:
        read_json(path)
    assert "\n" not in str(refused.value)
    path.write_text('{"seed": NaN}')
    with pytest.raises(RunDirectoryError, match="NaN"):
        read_json(path)


PLANTED = ["best", "figures", "summary.json", "repertoire_nest.json", "best/food.txt"]


@pytest.mark.parametrize("planted", PLANTED)
def test_a_resume_refuses_a_planted_link_before_it_evaluates_anything(unfinished, tmp_path, capsys, planted):
    """``best/`` planted: the resume ran every evaluation and refused only when it wrote the results."""
    from evolution_manager.studies.evolve import evolve

    run = tmp_path / "run"
    shutil.copytree(unfinished, run, symlinks=True)
    outside = tmp_path / "outside"
    outside.mkdir()
    (run / planted).parent.mkdir(exist_ok=True)
    (run / planted).symlink_to(outside if "." not in planted else outside / "made")
    before = {name: data for name, data in _tree(run).items() if name != ".lock"}
    assert evolve(["--out", str(run), "--resume", *QUIET]) == 2
    error = capsys.readouterr().err.strip()
    assert "\n" not in error and f"{planted} is a symbolic link" in error, error
    assert {name: data for name, data in _tree(run).items() if name != ".lock"} == before
    assert not any(outside.iterdir())


def test_a_rebuild_of_a_runs_results_refuses_a_planted_link_before_it_writes(tmp_path, capsys):
    """``report RUN`` rewrote summary.json and timing.json, then refused the planted figures/ link."""
    from evolution_manager.studies.evolve import evolve
    from evolution_manager.studies.report_command import report

    run = tmp_path / "run"
    args = ["--algorithm", "qd", "--objective", "food", "--evaluations", "2", "--seed", "1"]
    assert evolve([*args, "--out", str(run), *QUIET]) == 0
    (tmp_path / "outside").mkdir()
    (run / "figures").symlink_to(tmp_path / "outside")
    before = _tree(run)
    assert report([str(run)]) == 2
    error = capsys.readouterr().err.strip()
    assert "\n" not in error and "figures is a symbolic link" in error, error
    assert _tree(run) == before


def test_adapt_benchmark_refuses_a_planted_report_link_before_it_benchmarks(tmp_path, capsys):
    """It ran every adaptation, wrote runs.csv, ceilings.csv, summary.json and curves.png, then refused."""
    from small_repertoires import adapt_benchmark_argv, food_repertoire

    from evolution_manager.adaptation.adapt_benchmark import main as adapt_benchmark

    out = tmp_path / "out"
    out.mkdir()
    (out / "report.md").symlink_to(tmp_path / "made")
    argv = adapt_benchmark_argv(food_repertoire(tmp_path / "repertoire", 4), budget=2, ceiling=10, trials=1)
    with pytest.raises(SystemExit) as ended:
        adapt_benchmark([*argv, "--out", str(out)])
    error = capsys.readouterr().err
    assert ended.value.code == 74 and error.count("\n") == 1 and "report.md is a symbolic link" in error
    assert sorted(p.name for p in out.iterdir()) == ["report.md"] and not (tmp_path / "made").exists()


@pytest.mark.parametrize(
    "argv,message",
    [
        (["--evaluations", "nan"], "main: argument --evaluations: expected a positive integer, got 'nan'"),
        (["--evaluators", "0"], "main: argument --evaluators: expected a positive integer, got 0"),
        (["--seed", "-1"], "main: argument --seed: expected an integer seed in [0, 9223372036854775807]"),
        (["--no-such-option"], "main: unrecognized arguments: --no-such-option"),
        (["--resume", "--out", "{tmp}/nothing"], "no job there to continue (no such folder)"),
        (["--out", "{tmp}/file/run"], "file is a file, not a folder"),
        (["--out", "{tmp}/dangling"], "dangling exists already"),
    ],
)
def test_the_main_job_refuses_in_one_line_before_it_starts(argv, message, tmp_path, capsys):
    """argparse's usage block came first; ``--resume`` of a folder that is not there started a new job."""
    from evolution_manager.graph.nodes import main_job

    (tmp_path / "file").write_text("mine\n")
    (tmp_path / "dangling").symlink_to(tmp_path / "made")
    assert main_job.main([a.format(tmp=tmp_path) for a in argv]) == 2
    error = capsys.readouterr().err
    assert error.count("\n") == 1 and message in error, error
    assert sorted(p.name for p in tmp_path.iterdir()) == ["dangling", "file"]


def test_evolve_refuses_an_infinite_checkpoint_period(tmp_path, capsys):
    from evolution_manager.studies.evolve import evolve

    args = ["--algorithm", "qd", "--objective", "food", "--evaluations", "2", "--out", str(tmp_path / "run")]
    assert evolve([*args, "--checkpoint-every", "inf"]) == 2
    error = capsys.readouterr().err
    assert error.count("\n") == 1 and "expected a finite number of seconds >= 0, got 'inf'" in error, error
    assert not (tmp_path / "run").exists()


def test_explorer_prints_a_run_folder_whose_name_is_not_utf8(tmp_path, monkeypatch):
    """Standard output is strict UTF-8: printing the name's surrogates was a UnicodeEncodeError traceback."""
    from evolution_manager.studies.evolve import evolve
    from evolution_manager.viewing.explorer import main as explorer

    run = tmp_path / "run-\udcff\udcfe"
    args = ["--algorithm", "qd", "--objective", "food", "--evaluations", "2", "--seed", "1"]
    assert evolve([*args, "--out", str(run), *QUIET]) == 0
    out = io.BytesIO()
    monkeypatch.setattr(sys, "stdout", io.TextIOWrapper(out, encoding="utf-8", errors="strict"))
    assert explorer([str(run), "--no-animations"]) == 0
    sys.stdout.flush()
    assert b"run-\\xff\\xfe/explorer.html: " in out.getvalue()
    assert (run / "explorer.html").is_file()


def test_a_bag_whose_name_is_not_utf8_gets_its_lock(tmp_path):
    """``recover BAG NEW`` with such a NEW: a UnicodeEncodeError traceback naming the bag's lock."""
    from evolution_manager.processes import lock_path_for

    lock = lock_path_for(tmp_path / "new-\udcff\udcfe", "bag")
    assert lock.name.startswith("bag-") and lock != lock_path_for(tmp_path / "new", "bag")
    assert lock_path_for(tmp_path / "new-é", "bag") == lock_path_for(tmp_path / "new-é", "bag")
