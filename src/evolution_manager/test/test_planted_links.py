"""Run folders are shared (tarballs, ``git clone`` of ``experiments/``, which stores symbolic links): a link
planted where a command writes is refused in one line, never written through, and what it points to is
left as it was (issue 41)."""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import pytest

from evolution_manager.evolution.run import Run
from evolution_manager.evolution.run_config import RunConfig
from evolution_manager.studies.evolve import evolve
from swarm_sim.evaluation import BatchEvaluator

QUIET = ["--no-progress", "--checkpoint-every", "0"]
NEVER_WRITTEN = {"config.json", "cells.json"}  # read through a link (a copy, outside), never written


@pytest.fixture(scope="module")
def unfinished(tmp_path_factory) -> Path:
    """A real run (the simulator, one trial per evaluation) stopped after its first batch."""
    out = tmp_path_factory.mktemp("links") / "run"
    config = RunConfig.make("qd", "food", 20, 5, trials=1)
    run = Run.start(config, out, BatchEvaluator(config.world(), threads=1))
    run.execute(checkpoint_interval=0, stop_after=1)
    assert not run.done
    assert run.lock is not None
    run.lock.release()
    return out


def _copy(run: Path, where: Path) -> Path:
    copy = where / "run"
    shutil.copytree(run, copy, symlinks=True)
    return copy


def test_a_planted_lock_link_is_refused_and_its_target_kept(unfinished, tmp_path, capsys):
    run = _copy(unfinished, tmp_path)
    precious = tmp_path / "precious"
    precious.write_text("keep me\n")
    (run / ".lock").unlink()
    (run / ".lock").symlink_to(precious)
    assert evolve(["--out", str(run), "--resume", *QUIET]) == 2
    error = capsys.readouterr().err.strip()
    assert "\n" not in error and ".lock is a symbolic link" in error, error
    assert precious.read_text() == "keep me\n"


@pytest.fixture(scope="module")
def written(unfinished, tmp_path_factory) -> list[str]:
    """Every path (file or folder) that ``evolve --resume`` writes in the run folder, figures included."""
    run = _copy(unfinished, tmp_path_factory.mktemp("finished"))
    assert evolve(["--out", str(run), "--resume", *QUIET]) == 0
    return sorted(str(p.relative_to(run)) for p in run.rglob("*"))


def _tree(folder: Path) -> dict[str, bytes | None]:
    return {str(p.relative_to(folder)): p.read_bytes() if p.is_file() else None for p in folder.rglob("*")}


def _plant_everywhere(unfinished: Path, written: list[str], where: Path, capsys) -> list[str]:
    """For each path of ``written``: a copy of ``unfinished`` with a link planted there (to a copy of the
    file outside, to text, to nothing, or to a folder), resumed with ``evolve --resume``; nothing outside
    may change, and the resume must be refused in one line naming the link. Returns each case's line."""
    shown = []
    for index, name in enumerate(written):
        case = where / str(index)
        run = _copy(unfinished, case)
        outside = case / "outside"
        outside.mkdir()
        planted = run / name
        original = planted.read_bytes() if planted.is_file() else None
        if planted.is_dir():
            shutil.rmtree(planted)
        planted.unlink(missing_ok=True)
        planted.parent.mkdir(parents=True, exist_ok=True)
        if "." not in name:  # a folder (best, figures)
            planted.symlink_to(outside, target_is_directory=True)
        elif original is not None:  # the file as it was, outside: what is read is fine, a write is refused
            (outside / "target").write_bytes(original)
            planted.symlink_to(outside / "target")
        elif index % 2:  # a dangling link: its target must not be created
            planted.symlink_to(outside / "target")
        else:
            (outside / "target").write_text("keep me\n")
            planted.symlink_to(outside / "target")
        before = _tree(outside)
        status = evolve(["--out", str(run), "--resume", *QUIET])
        error = capsys.readouterr().err.strip()
        shown.append(f"{name}: {status} {error}")
        assert _tree(outside) == before, (name, error)
        if name in NEVER_WRITTEN:
            assert status == 0, (name, error)
            continue
        assert status in (2, 74), (name, status, error)
        assert "\n" not in error and "symbolic link" in error, (name, error)
    return shown


def test_a_link_planted_at_any_path_evolve_writes_is_never_written_through(
    unfinished, written, tmp_path, capsys
):
    expected = {".lock", "evaluations.csv", "progress.csv", "checkpoint.json", "summary.json", "heldout.json"}
    expected |= {"sessions.json", "explorer.html", "best", "figures"}
    assert expected <= set(written), written
    assert any(p.startswith("best/") for p in written) and any(p.startswith("figures/") for p in written)
    shown = _plant_everywhere(unfinished, written, tmp_path, capsys)
    with capsys.disabled():  # shown with pytest -s: the refusal of each planted link
        print("\n" + "\n".join(shown))


def test_a_link_planted_at_any_path_of_a_composition_run_is_never_written_through(tmp_path, capsys):
    """The same for a run of compositions (``evolve --swarm-from``): its own files (cells.json, best/)."""
    from evolution_manager.evolution.compositions import CompositionConfig, CompositionRun, read_sources

    source = tmp_path / "source"
    args = ["--algorithm", "qd", "--objective", "food", "--evaluations", "10", "--trials", "1"]
    assert evolve([*args, "--out", str(source), "--no-figures", *QUIET]) == 0
    finished = tmp_path / "finished"
    compose = ["--task", "foraging", "--swarm-from", str(source), "--algorithm", "ga", "--trials", "1"]
    assert evolve([*compose, "--evaluations", "40", "--seed", "5", "--out", str(finished), *QUIET]) == 0
    written = sorted(str(p.relative_to(finished)) for p in finished.rglob("*"))
    assert {"cells.json", "best", "evaluations.csv", ".lock"} <= set(written), written
    config = CompositionConfig.from_json(json.loads((finished / "config.json").read_text()))
    unfinished = tmp_path / "unfinished" / "run"
    run = CompositionRun.start(config, read_sources([source])[0], unfinished, BatchEvaluator(config.world()))
    run.execute(checkpoint_interval=0, stop_after=1)
    assert run.lock is not None
    run.lock.release()
    shown = _plant_everywhere(unfinished, written, tmp_path / "cases", capsys)
    with capsys.disabled():
        print("\n" + "\n".join(shown))


EXPERIMENT = ["--runs", "1", "--evaluations", "2", "--trials", "1", "--processes", "2", "--no-progress"]
"""The smallest paper experiment: its seven groups, one run each, of two evaluations of one trial."""


@pytest.fixture(scope="module")
def experiment_folder(tmp_path_factory) -> Path:
    """A finished experiment folder: its plan, sessions, runs.csv, report, figures and seven run folders."""
    from evolution_manager.studies.experiment import experiment

    out = tmp_path_factory.mktemp("experiment") / "exp"
    assert experiment([*EXPERIMENT, "--out", str(out)]) == 0
    return out


def test_a_link_planted_at_any_path_of_an_experiment_folder_is_never_written_through(
    experiment_folder, tmp_path, capsys
):
    """``experiment`` continued on a folder with a link planted at any of its paths: the experiment's own
    files (experiment.json, sessions.json, runs.csv, report.md, figures/ and each figure), the folders its
    runs go in (runs/, runs/GROUP/, runs/GROUP/runNN, each planted as a link to an empty folder outside,
    so that the run is to be run again) and every file and folder of the runs. Each is refused in one line,
    status 2, before anything is run or written: nothing outside and nothing in the folder changes. A link
    at runs/ or runs/GROUP/ made the experiment run its runs outside the folder, exit status 0."""
    from evolution_manager.studies.experiment import experiment

    written = sorted(str(p.relative_to(experiment_folder)) for p in experiment_folder.rglob("*"))
    expected = {"experiment.json", "sessions.json", "runs.csv", "report.md", "figures", "runs"}
    expected |= {"runs/QD_food", "runs/QD_food/run00", "runs/QD_food/run00/evaluations.csv"}
    assert expected <= set(written), written
    shown = []
    for index, name in enumerate(written):
        case = tmp_path / str(index)
        folder = case / "exp"
        shutil.copytree(experiment_folder, folder, symlinks=True)
        outside = case / "outside"
        outside.mkdir()
        planted = folder / name
        if planted.is_dir():  # a folder: runs (or what they write) would go outside
            shutil.rmtree(planted)
            planted.symlink_to(outside, target_is_directory=True)
        else:  # the file as it was, outside: what is read is fine, a write is refused
            (outside / "target").write_bytes(planted.read_bytes())
            planted.unlink()
            planted.symlink_to(outside / "target")
        before, inside = _tree(outside), _tree(folder)
        status = experiment([*EXPERIMENT, "--out", str(folder)])
        error = capsys.readouterr().err.strip()
        shown.append(f"{name}: {status} {error}")
        assert _tree(outside) == before, (name, error)
        assert _tree(folder) == inside, (name, error)
        assert status == 2 and "\n" not in error, (name, status, error)
        assert f"{name} is a symbolic link" in error, (name, error)
    with capsys.disabled():
        print("\n" + "\n".join(shown))


@pytest.mark.parametrize("damage", ["{", "[]", '{"format": NaN}'])
def test_a_damaged_heldout_file_is_refused_before_any_evaluation(unfinished, tmp_path, capsys, damage):
    run = _copy(unfinished, tmp_path)
    (run / "heldout.json").write_text(damage)
    before = {name: data for name, data in _tree(run).items() if name != ".lock"}  # .lock: our PID
    assert evolve(["--out", str(run), "--resume", *QUIET]) == 2
    error = capsys.readouterr().err.strip()
    assert "\n" not in error and "heldout.json" in error and "remove it" in error, error
    assert {n: d for n, d in _tree(run).items() if n != ".lock"} == before  # nothing run, nothing lost


@pytest.mark.parametrize("planted", ["trial.bag.logs", "trial.bag.logs/simulator.log", "trial.bag.logs/ros"])
def test_a_planted_node_log_link_is_refused_before_a_node_starts(tmp_path, planted):
    """``trial --bag B`` writes the node logs in ``B.logs`` (``--logs``): a link there is refused."""
    from evolution_manager.errors import GraphError
    from evolution_manager.graph.startup import Graph

    outside = tmp_path / "outside"
    outside.mkdir()
    (outside / "target").write_text("keep me\n")
    logs = tmp_path / "trial.bag.logs"
    if planted != logs.name:
        logs.mkdir()
    (tmp_path / planted).symlink_to(
        outside if planted != "trial.bag.logs/simulator.log" else outside / "target"
    )
    with Graph(domain=0, log_dir=logs) as graph:
        with pytest.raises(GraphError, match="is a symbolic link") as refused:
            graph.start("simulator", "swarm_sim", "simulator")
        assert not graph.processes
    assert "\n" not in str(refused.value)
    assert _tree(outside) == {"target": b"keep me\n"}


def test_adapt_benchmark_never_writes_its_report_through_a_planted_link(tmp_path, capsys):
    from small_repertoires import adapt_benchmark_argv, food_repertoire

    from evolution_manager.adaptation.adapt_benchmark import main as adapt_benchmark

    repertoire = food_repertoire(tmp_path / "repertoire", 4)
    out, precious = tmp_path / "out", tmp_path / "precious.txt"
    out.mkdir()
    precious.write_text("keep me\n")
    (out / "report.md").symlink_to(precious)
    argv = adapt_benchmark_argv(repertoire, budget=2, ceiling=10, trials=1)
    with pytest.raises(SystemExit) as ended:
        adapt_benchmark([*argv, "--out", str(out)])
    error = capsys.readouterr().err
    assert ended.value.code == 74 and error.count("\n") == 1 and "report.md" in error, error
    assert precious.read_text() == "keep me\n" and (out / "report.md").is_symlink()


def test_adapt_refuses_a_link_planted_at_any_path_it_writes_before_its_trials(tmp_path, capsys):
    """``adapt --out DIR`` writes adaptation.json and adaptation.png in DIR: a link planted at either (a
    dangling one too) is refused in one line, status 2, before any trial, and nothing outside changes. It ran
    every trial, then ended in a WriteError traceback (status 1)."""
    from small_repertoires import food_repertoire

    from evolution_manager.adaptation.adapt import adapt

    repertoire = food_repertoire(tmp_path / "repertoire", 4)
    argv = ["--repertoire", str(repertoire), "--objective", "food", "--condition", "dead-robots=3"]
    argv += ["--budget", "2", "--trials", "1"]
    assert adapt([*argv, "--out", str(tmp_path / "done")]) == 0
    capsys.readouterr()
    written = sorted(str(p.relative_to(tmp_path / "done")) for p in (tmp_path / "done").rglob("*"))
    assert written == ["adaptation.json", "adaptation.png"], written
    for index, name in enumerate(written):
        for dangling in (False, True):
            case = tmp_path / f"{index}-{dangling}"
            out, outside = case / "out", case / "outside"
            out.mkdir(parents=True)
            outside.mkdir()
            if not dangling:
                (outside / "target").write_text("keep me\n")
            (out / name).symlink_to(outside / "target")
            before = _tree(outside)
            status = adapt([*argv, "--out", str(out)])
            error = capsys.readouterr().err.strip()
            assert status == 2 and "\n" not in error, (name, status, error)
            assert f"{name} is a symbolic link" in error, (name, error)
            assert _tree(outside) == before and [p.name for p in out.iterdir()] == [name], name
