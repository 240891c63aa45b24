"""A small experiment end to end (real swarm_sim evaluator, parallel processes) and its report."""

from __future__ import annotations

import dataclasses
import json
import os
import re
import shutil
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from evolution_manager.cluster.settings import ClusterSettings
from evolution_manager.studies.experiment import (
    CODE_DIRECTORY,
    build_parser,
    current_commit,
    experiment,
    record_session,
    start_order,
)
from evolution_manager.studies.planning import paper_study, plan, shared_scenario_seed
from evolution_manager.studies.report_command import report
from evolution_manager.studies.significance import compare, holm

RUNS_HEADER = (
    "algorithm,objective,seed,best_fitness,heldout_best_fitness,coverage,qd_score,heldout_qd_score,"
    "repertoire_size"
)

FIGURES = [
    "fig4_best_fitness.png",
    "fig5_coverage.png",
    "fig6_qd_score.png",
    "fig8_histograms.png",
    "heldout_best_fitness.png",
    "heldout_qd_score.png",
    *(f"fig7_grid_{o}.png" for o in ("density", "nest", "food")),
    *(f"progress_{o}.png" for o in ("density", "nest", "food")),
]


ONE_RUN_ARGS = ["--runs", "1", "--evaluations", "50", "--processes", "2", "--checkpoint-every", "0"]
"""A small experiment, one run per group: several tests start from it run straight through, and the kill and
signal tests stop it and continue it (each runs most of it twice, before the stop and after it; its seven runs
still outlast the moment of the stop by several seconds)."""


@pytest.fixture(scope="module")
def one_run_experiment(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """That experiment run straight through, once for the module: tests that change it take a copy."""
    straight = tmp_path_factory.mktemp("one-run") / "experiment"
    assert experiment([*ONE_RUN_ARGS, "--out", str(straight), "--no-progress"]) == 0
    return straight


@pytest.fixture
def never_stopped_runs_csv(one_run_experiment: Path) -> bytes:
    """runs.csv of the experiment never stopped: what every way of stopping it must continue to."""
    return (one_run_experiment / "runs.csv").read_bytes()


def test_the_plan_covers_every_algorithm_objective_and_run_with_distinct_seeds():
    planned = plan(runs=3, evaluations=100, seed=4)
    labels = sorted({config.label for config, _ in planned})
    assert labels == sorted(
        ["GP_density", "GP_nest", "GP_food", "GP_fnd", "QD_density", "QD_nest", "QD_food"]
    )
    assert len(planned) == 7 * 3
    assert len({config.seed for config, _ in planned}) == len(planned)
    assert all(config.evaluations == (300 if config.label == "GP_fnd" else 100) for config, _ in planned)
    assert plan(runs=3, evaluations=100, seed=4) == planned


def test_the_authors_design_is_the_default_one_scenario_for_every_run_and_per_run_an_option():
    shared = plan(runs=3, evaluations=100, seed=4)
    assert len({config.scenario_seed for config, _ in shared}) == 1
    assert shared[0][0].scenario_seed == shared_scenario_seed(4)
    given = plan(runs=3, evaluations=100, seed=4, scenario_seed=77)
    assert {config.scenario_seed for config, _ in given} == {77}
    per_run = plan(runs=3, evaluations=100, seed=4, design="per-run")
    assert len({config.scenario_seed for config, _ in per_run}) == len(per_run)
    assert [c.seed for c, _ in per_run] == [c.seed for c, _ in shared]  # only the scenarios differ


def test_the_design_is_recorded_and_a_per_run_table_shown_beside(tmp_path, capsys, one_run_experiment):
    out = tmp_path / "experiment"
    shutil.copytree(one_run_experiment, out)
    args = ["--runs", "1", "--evaluations", "50", "--out", str(out), "--processes", "2", "--no-progress"]
    document = json.loads((out / "experiment.json").read_text())
    assert document["design"] == "shared" and document["scenario_seed"] == shared_scenario_seed(0)
    configs = [json.loads(p.read_text()) for p in out.glob("runs/*/run*/config.json")]
    assert {c["scenario_seed"] for c in configs} == {document["scenario_seed"]}
    assert "every run on one shared scenario" in (out / "report.md").read_text()
    assert experiment([*args, "--design", "per-run"]) == 2  # another design is another experiment
    assert 'other options (design "shared" there, "per-run" given' in capsys.readouterr().err
    committed = Path(__file__).resolve().parents[4] / "docs/results/paper/per-run-design/runs.csv"
    beside = out / "per-run" / "runs.csv"
    beside.parent.mkdir()
    beside.write_text(committed.read_text())
    assert report([str(out), "--beside", str(beside), "--beside-title", "the per-run design"]) == 0
    text = (out / "report.md").read_text()
    assert "### Table 6 again: the per-run design" in text
    assert "[per-run/runs.csv](per-run/runs.csv)" in text  # linked from the report's folder
    assert "16 of 18 rows reach the paper's conclusion" in text  # the committed per-run experiment's verdict


def test_a_small_experiment_writes_the_report_with_every_figure_and_the_table(tmp_path, capsys):
    out = tmp_path / "experiment"
    args = ["--runs", "2", "--evaluations", "150", "--out", str(out), "--processes", "2", "--no-progress"]
    assert experiment(args) == 0
    summaries = sorted(out.glob("runs/*/run*/summary.json"))
    assert len(summaries) == 14
    assert all(json.loads(p.read_text())["finished"] for p in summaries)
    text = (out / "report.md").read_text()
    for name in FIGURES:
        assert (out / "figures" / name).stat().st_size > 1000
        assert f"(figures/{name})" in text
    table = [line for line in text.splitlines() if re.match(r"\| (best fitness|coverage|QD score) \|", line)]
    assert len(table) == 3 * 3 * 3  # metrics x objectives x pairs: the paper's 18, then GP_fnd vs QD
    assert all(line.endswith(("| same conclusion |", ")")) or "different:" in line for line in table[:18])
    assert "| 0.0004 | T-test |" in text and "| 0.4406 | Mann-Whitney |" in text  # the paper's, beside ours
    assert "Mann-Whitney U" in text  # two runs cannot be shown normal
    for size in ("| 290 |", "| 148 |", "| 305 |"):  # fig. 8's sizes beside ours
        assert size in text
    rows = (out / "runs.csv").read_text().splitlines()
    assert rows[0] == RUNS_HEADER and len(rows) == 1 + 2 * (3 + 3 + 3)  # GP_fnd: a row per objective
    assert "Reproduce: `ws/run evolution_manager experiment --runs 2 --evaluations 150" in text
    # the same command continues (nothing to do) and report rebuilds the same report
    before = text
    assert experiment(args) == 0
    assert report([str(out)]) == 0
    assert (out / "report.md").read_text() == before
    # another experiment's options are refused, nothing is lost (fewer runs too: they would drop some)
    assert experiment(["--runs", "1", "--evaluations", "150", "--out", str(out), "--no-progress"]) == 2
    assert "other options" in capsys.readouterr().err
    assert (out / "report.md").read_text() == before


def test_more_runs_continue_an_experiment_and_leave_its_finished_runs_as_they_are(
    tmp_path, capsys, one_run_experiment
):
    """``--runs`` raised on an experiment folder: the runs it planned keep their seeds, folders and files,
    and only the new ones run (issue 38's scenarios grow from 10 to 20 runs per group this way), in any
    ``--order``."""
    out = tmp_path / "experiment"
    shutil.copytree(one_run_experiment, out)
    args = ["--evaluations", "50", "--out", str(out), "--processes", "2", "--no-progress"]
    first = {p: p.read_bytes() for p in sorted(out.glob("runs/*/run00/*.json"))}
    plan = json.loads((out / "experiment.json").read_text())["plan"]
    assert experiment(["--runs", "2", "--order", "seed", *args]) == 0  # the order is not an option it keeps
    assert "grows to 2 runs per group" in capsys.readouterr().err
    assert {p: p.read_bytes() for p in first} == first
    grown = json.loads((out / "experiment.json").read_text())
    assert grown["runs"] == 2 and all(entry in grown["plan"] for entry in plan)
    assert len(list(out.glob("runs/*/run01/summary.json"))) == 7


@dataclasses.dataclass(frozen=True)
class _Budget:
    evaluations: int


def test_the_start_order_is_the_largest_budget_first_or_run_0_of_every_arm_first():
    runs = [(_Budget(50), "arms/a/run01"), (_Budget(50), "arms/a/run00"), (_Budget(90), "arms/b/run01")]
    runs += [(_Budget(50), "arms/b/run00"), (_Budget(10), "libraries/x")]  # no run index: index 0
    longest = [folder for _, folder in start_order(runs, "longest")]
    assert longest == ["arms/b/run01", "arms/a/run01", "arms/a/run00", "arms/b/run00", "libraries/x"]
    by_seed = [folder for _, folder in start_order(runs, "seed")]
    assert by_seed == ["arms/a/run00", "arms/b/run00", "libraries/x", "arms/b/run01", "arms/a/run01"]
    assert experiment(["--order", "random", "--out", "unused"]) == 2


def test_other_options_are_named_in_the_refusal(tmp_path, capsys):
    """An experiment folder continued with other options: the one line says which options differ."""
    out = tmp_path / "experiment"
    out.mkdir()
    saved = ["--runs", "2", "--evaluations", "150", "--out", str(out)]
    document = paper_study(build_parser().parse_args(saved), "fixed", "shared")[0]
    (out / "experiment.json").write_text(json.dumps(document))
    before = (out / "experiment.json").read_bytes()
    assert experiment(["--runs", "3", "--evaluations", "300", "--out", str(out), "--no-progress"]) == 2
    error = capsys.readouterr().err
    assert error.count("\n") == 1, error
    assert (
        "holds an experiment with other options (runs 2 there, 3 given; evaluations 150 there, 300 given"
        in error
    )
    assert (out / "experiment.json").read_bytes() == before and [p.name for p in out.iterdir()] == [
        "experiment.json"
    ]


def test_a_second_experiment_on_a_folder_in_use_is_refused_up_front(tmp_path):
    """Two experiment commands on one folder collided (both exit 1, the second breaking the first); the
    second is now refused in one line, status 2, as evolve refuses a run directory in use, and the first
    goes on."""
    out = tmp_path / "experiment"
    args = ["--runs", "1", "--evaluations", "5000", "--processes", "1", "--no-progress", "--out", str(out)]
    code = "import sys; from evolution_manager.studies.experiment import experiment; "
    code += f"sys.exit(experiment({args!r}))"
    first = subprocess.Popen([sys.executable, "-c", code], start_new_session=True, stderr=subprocess.DEVNULL)
    try:
        deadline = time.monotonic() + 120
        while not (out / "experiment.json").exists():
            assert first.poll() is None and time.monotonic() < deadline, "the first experiment did not start"
            time.sleep(0.1)
        plan_before = (out / "experiment.json").read_bytes()
        second = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120)
        assert second.returncode == 2, second.stderr
        assert second.stderr.startswith("experiment: error: the experiment folder ")
        assert f"is in use by process {first.pid}" in second.stderr and second.stderr.count("\n") == 1
        assert first.poll() is None, "the second command stopped the first"
        assert (out / "experiment.json").read_bytes() == plan_before
    finally:
        os.killpg(first.pid, signal.SIGKILL)
        first.wait()


def test_tests_follow_the_papers_rule_and_holm_corrects():
    normal_a = [0.50, 0.52, 0.49, 0.51, 0.505, 0.515, 0.495, 0.50, 0.51, 0.49]
    normal_b = [x + 0.05 for x in normal_a]
    row = compare("best fitness", "food", "GP_food", normal_a, "QD_food", normal_b)
    assert row.test.startswith("t-test") and row.p_value < 0.001 and row.cohens_d < -2
    skewed = [0.1] * 8 + [0.9, 0.95]
    row = compare("coverage", "food", "GP_food", skewed, "QD_food", normal_b)
    assert row.test == "Mann-Whitney U" and row.shapiro_first < 0.05
    assert compare("x", "food", "a", [1.0, 1.0], "b", [1.0, 1.0]).p_value == 1.0
    rows = holm([row, row, row])
    assert [r.p_holm for r in rows] == [min(1.0, 3 * row.p_value)] * 3
    assert 0.0 <= row.vargha_delaney_a <= 1.0


def test_report_on_a_folder_without_runs_says_so(tmp_path, capsys):
    assert report([str(tmp_path)]) == 2
    assert "neither an experiment folder, a run directory nor a folder of scenario" in capsys.readouterr().err
    assert report([]) == 2


def _finished_runs(out):
    return sum(1 for p in out.glob("runs/*/run*/summary.json") if json.loads(p.read_text()).get("heldout"))


def test_an_experiment_killed_and_continued_writes_the_same_runs_csv(tmp_path, never_stopped_runs_csv):
    args = ONE_RUN_ARGS
    killed = tmp_path / "killed"
    call = f"experiment({[*args, '--out', str(killed)]!r})"
    code = f"from evolution_manager.studies.experiment import experiment; {call}"
    process = subprocess.Popen([sys.executable, "-c", code], start_new_session=True)
    try:
        deadline = time.monotonic() + 600
        while _finished_runs(killed) < 2 and process.poll() is None and time.monotonic() < deadline:
            time.sleep(0.2)
    finally:
        os.killpg(process.pid, signal.SIGKILL)  # the command, its process pool and its manager
        process.wait()
    assert 2 <= _finished_runs(killed) < 7, "the kill came too late to interrupt the experiment"
    assert not (killed / "runs.csv").exists()
    assert experiment([*args, "--out", str(killed), "--no-progress"]) == 0
    assert (killed / "runs.csv").read_bytes() == never_stopped_runs_csv


def _children(pid: int) -> set[int]:
    """The live processes whose parent is ``pid``."""
    found = set()
    for entry in Path("/proc").iterdir():
        if entry.name.isdigit():
            try:
                fields = (entry / "stat").read_text().rsplit(")", 1)[1].split()
            except OSError:
                continue
            if int(fields[1]) == pid and fields[0] != "Z":
                found.add(int(entry.name))
    return found


def _alive(pids: set[int]) -> set[int]:
    alive = set()
    for pid in pids:
        try:
            state = (Path("/proc") / str(pid) / "stat").read_text().rsplit(")", 1)[1].split()[0]
        except OSError:
            continue
        if state != "Z":
            alive.add(pid)
    return alive


@pytest.mark.parametrize(
    ("signum", "group"), [(signal.SIGTERM, False), (signal.SIGKILL, False), (signal.SIGTERM, True)]
)
def test_a_signal_to_the_command_or_its_group_stops_its_runs_too(
    tmp_path, signum, group, never_stopped_runs_csv
):
    """SIGTERM to the experiment's process (not its group, as a scheduler or `kill PID` sends it) stops it as
    Ctrl-C does, exit 143, and its runs stop at once; SIGKILL takes its workers with it. SIGTERM to its whole
    process group (as `timeout` sends it, and a terminal its Ctrl-C), which stops its manager too, ends in
    the same one line, no traceback. The experiment then continues to the same runs.csv as one never
    stopped."""
    args = ONE_RUN_ARGS
    out = tmp_path / "stopped"
    call = f"experiment({[*args, '--out', str(out), '--no-progress']!r})"
    code = f"import sys; from evolution_manager.studies.experiment import experiment; sys.exit({call})"
    process = subprocess.Popen(
        [sys.executable, "-c", code], stderr=subprocess.PIPE, text=True, start_new_session=group
    )
    try:
        deadline = time.monotonic() + 300
        while not list(out.glob("runs/*/run00/checkpoint.json")) and process.poll() is None:
            assert time.monotonic() < deadline, "no run started"
            time.sleep(0.1)
        children = _children(process.pid)
        assert len(children) >= 3  # the manager and two workers (and spawn's resource tracker)
        if group:
            os.killpg(process.pid, signum)
        else:
            os.kill(process.pid, signum)
        _, err = process.communicate(timeout=60)
    finally:
        if process.poll() is None:
            process.kill()
    if signum == signal.SIGTERM:
        assert process.returncode == 143 and "experiment: interrupted; run the same command again" in err
        assert "Traceback" not in err, err
    deadline = time.monotonic() + 20
    while _alive(children) and time.monotonic() < deadline:
        time.sleep(0.1)
    assert not _alive(children), "a worker outlived the experiment"
    assert not (out / "runs.csv").exists(), "the signal came too late to interrupt the experiment"
    assert experiment([*args, "--out", str(out), "--no-progress"]) == 0
    assert (out / "runs.csv").read_bytes() == never_stopped_runs_csv


def test_a_session_keeps_the_commit_it_started_with(tmp_path, monkeypatch):
    """HEAD may move while a long session runs (its finished runs committed as they finish); the session's
    record keeps the commit of the code it started with, and a new session records the new one."""
    monkeypatch.chdir(tmp_path)

    def commit(message: str) -> str:
        (tmp_path / "file").write_text(message)
        git = ["git", "-c", "user.name=t", "-c", "user.email=t@t"]
        subprocess.run([*git, "add", "file"], check=True)
        subprocess.run([*git, "commit", "-q", "-m", message], check=True)
        return subprocess.run(["git", "rev-parse", "HEAD"], capture_output=True, text=True).stdout.strip()

    subprocess.run(["git", "init", "-q"], check=True)
    first = commit("first")
    out = tmp_path / "experiment"
    out.mkdir()
    record_session(out, 1000.0, "experiment", ClusterSettings(), tmp_path, runs_finished=0)
    second = commit("second")
    record_session(out, 1000.0, "experiment", ClusterSettings(), tmp_path, runs_finished=1)
    record_session(out, 2000.0, "experiment", ClusterSettings(), tmp_path, runs_finished=0)
    sessions = json.loads((out / "sessions.json").read_text())
    assert [(s["commit"], s["runs_finished"]) for s in sessions] == [(first, 1), (second, 0)]
    # By default the commit is the one of the checkout holding the code that runs, not the working
    # directory's (a frozen install running a study whose folder lies in another checkout).
    record_session(out, 3000.0, "experiment", ClusterSettings(), runs_finished=0)
    recorded = json.loads((out / "sessions.json").read_text())[-1]["commit"]
    assert recorded == current_commit(CODE_DIRECTORY) and recorded.rstrip("+") not in (first, second)
