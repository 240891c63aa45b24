"""The command lines, run as users run them (subprocesses, the real swarm_sim batch evaluator)."""

from __future__ import annotations

import random
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

import evolution_manager.studies.evolve as evolve_command
from evolution_manager.studies.evolve import evolve
from swarm_ros.isolation import Workspace
from swarm_sim.model import VALUE_NAMES

COMPARED = [
    "config.json",
    "evaluations.csv",
    "progress.csv",
    "summary.json",
    "archive.json",
    "repertoire_density.json",
    "repertoire_nest.json",
    "repertoire_food.json",
    "best/food.txt",
]


MODULES = {"report": "report_command"}
"""The studies module of a command, where its name differs."""


def command(tool: str, *args: str) -> list[str]:
    module = MODULES.get(tool, tool)
    return [sys.executable, "-c", f"from evolution_manager.studies.{module} import main; main()", *args]


def run(workspace: Workspace, tool: str, *args: str, **env: str) -> subprocess.CompletedProcess:
    return subprocess.run(
        command(tool, *args), env=workspace.with_env(**env), capture_output=True, text=True, timeout=300
    )


def files(root: Path) -> dict[str, bytes]:
    return {name: (root / name).read_bytes() for name in COMPARED if (root / name).exists()}


@pytest.mark.parametrize(
    "args,message",
    [
        (["--algorithm", "qd", "--out", "X"], "needs --objective"),
        (["--algorithm", "gp-fnd", "--objective", "food", "--out", "X"], "leave out --objective"),
        (["--algorithm", "qd", "--objective", "speed", "--out", "X"], "invalid choice"),
        (
            ["--algorithm", "gp", "--objective", "food", "--evaluations", "0", "--out", "X"],
            "positive integer",
        ),
        (["--algorithm", "gp", "--objective", "food", "--seed", "-3", "--out", "X"], "seed must be"),
        (
            ["--algorithm", "gp", "--objective", "food", "--scenario-seed", "-1", "--out", "X"],
            "--scenario-seed must be in [0, ",
        ),
        (["--algorithm", "gp", "--objective", "food", "--workers", "999", "--out", "X"], "threads must be"),
        (["--out", "X", "--resume"], "no run to continue"),
        (["--algorithm", "qd", "--objective", "food"], "--out"),
    ],
)
def test_bad_options_say_why_and_exit_2(tmp_path, capsys, args, message):
    args = [str(tmp_path / "X") if a == "X" else a for a in args]
    assert evolve(args) == 2
    assert message in capsys.readouterr().err
    assert not (tmp_path / "X" / "config.json").exists()


def test_an_out_that_is_a_file_or_cannot_be_made_is_refused(tmp_path, capsys):
    (tmp_path / "file").write_text("keep me\n")
    assert evolve(["--algorithm", "gp", "--objective", "food", "--out", str(tmp_path / "file")]) == 2
    assert "is a file" in capsys.readouterr().err
    assert evolve(["--algorithm", "gp", "--objective", "food", "--out", str(tmp_path / "file" / "run")]) == 2
    assert "evolve: error:" in capsys.readouterr().err
    assert (tmp_path / "file").read_text() == "keep me\n"


def test_a_bad_option_exits_2_without_a_traceback_from_the_command_line(tmp_path, workspace):
    result = run(
        workspace,
        "evolve",
        "--algorithm",
        "qd",
        "--objective",
        "food",
        "--evaluations",
        "many",
        "--out",
        str(tmp_path),
    )
    assert result.returncode == 2
    assert "expected a positive integer, got 'many'" in result.stderr and "Traceback" not in result.stderr


def test_nothing_saved_is_overwritten_and_resume_refuses_other_options(tmp_path, workspace):
    out = tmp_path / "run"
    assert (
        run(
            workspace,
            "evolve",
            "--algorithm",
            "qd",
            "--objective",
            "food",
            "--evaluations",
            "150",
            "--out",
            str(out),
        ).returncode
        == 0
    )
    before = files(out)
    again = run(
        workspace,
        "evolve",
        "--algorithm",
        "gp",
        "--objective",
        "nest",
        "--evaluations",
        "150",
        "--out",
        str(out),
    )
    assert again.returncode == 2 and "already holds a run" in again.stderr
    other = run(workspace, "evolve", "--out", str(out), "--resume", "--seed", "5")
    assert other.returncode == 2 and "differs from the run being resumed" in other.stderr
    assert files(out) == before
    # a finished run: results rewritten, unchanged
    finished = run(workspace, "evolve", "--out", str(out), "--resume")
    assert finished.returncode == 0 and files(out) == before
    assert run(workspace, "report", str(out)).returncode == 0 and files(out) == before
    assert (out / "figures" / "heatmap_food.png").exists() and (out / "best" / "food.txt").exists()


def test_the_profile_is_the_runs_recorded_and_reproduced_by_evaluate(tmp_path, capsys):
    import csv
    import json

    from swarm_sim.evaluation.cli import run as evaluate_command

    out = tmp_path / "clean"
    common = ["--algorithm", "qd", "--objective", "food", "--evaluations", "20", "--seed", "4"]
    assert evolve([*common, "--profile", "clean", "--out", str(out), "--no-progress", "--no-figures"]) == 0
    config = json.loads((out / "config.json").read_text())
    assert config["profile"] == "clean"
    assert json.loads((out / "summary.json").read_text())["config"]["profile"] == "clean"
    with (out / "evaluations.csv").open() as f:
        rows = list(csv.DictReader(f))
    differs = 0
    for row in rows[:6]:
        seed = str(config["scenario_seed"])
        clean = json.loads(evaluate_command(["--tree", row["tree"], "--seed", seed, "--profile", "clean"]))
        values = {**clean["fitness"], **clean["descriptors"]}
        assert list(values) == list(VALUE_NAMES) and all(
            float(row[k]) == v for k, v in values.items()
        )  # all, exactly
        paper = json.loads(evaluate_command(["--tree", row["tree"], "--seed", seed]))
        differs += any(float(row[k]) != v for k, v in {**paper["fitness"], **paper["descriptors"]}.items())
    assert differs > 0  # the run did not run the default profile
    capsys.readouterr()
    assert evolve(["--out", str(out), "--resume", "--profile", "paper"]) == 2
    assert "--profile paper differs from the run being resumed (clean)" in capsys.readouterr().err
    assert evolve(["--out", str(tmp_path / "x"), *common, "--profile", "noisy"]) == 2
    assert "invalid choice: 'noisy'" in capsys.readouterr().err


def test_same_seed_same_files_under_another_pythonhashseed(tmp_path, workspace):
    common = [
        "--algorithm",
        "gp",
        "--objective",
        "food",
        "--evaluations",
        "260",
        "--seed",
        "21",
        "--no-figures",
    ]
    a = run(workspace, "evolve", *common, "--out", str(tmp_path / "a"), PYTHONHASHSEED="1")
    b = run(workspace, "evolve", *common, "--out", str(tmp_path / "b"), PYTHONHASHSEED="2")
    assert a.returncode == b.returncode == 0, a.stderr + b.stderr
    assert files(tmp_path / "a") == files(tmp_path / "b")
    assert len(files(tmp_path / "a")) == len(COMPARED) - 1  # all but archive.json (GP has none)


def test_sigkill_at_random_points_then_resume_equals_the_uninterrupted_run(tmp_path, workspace):
    common = ["--evaluations", "700", "--seed", "8", "--checkpoint-every", "0", "--no-figures"]
    straight = tmp_path / "straight"
    assert evolve(["--algorithm", "qd", "--objective", "food", *common, "--out", str(straight)]) == 0
    killed = tmp_path / "killed"
    rng = random.Random(99)
    kills = 0
    args = ["--algorithm", "qd", "--objective", "food", *common, "--out", str(killed)]
    while True:
        process = subprocess.Popen(
            command("evolve", *args), env=workspace.env, stderr=subprocess.PIPE, text=True
        )
        args = ["--out", str(killed), "--resume"]
        if kills == 3:
            break
        # wait until the run has evaluated something, then kill it at a random moment
        deadline = time.monotonic() + 120
        while time.monotonic() < deadline and process.poll() is None:
            progress = killed / "progress.csv"
            if progress.exists() and progress.stat().st_size > 200 * (kills + 1):
                break
            time.sleep(0.05)
        time.sleep(rng.uniform(0.0, 0.6))
        if process.poll() is not None:
            break  # finished before the kill: nothing more to interrupt
        process.send_signal(signal.SIGKILL)
        process.wait()
        kills += 1
    assert process.wait(timeout=300) == 0, process.stderr.read()
    assert kills >= 2
    assert files(killed) == files(straight)


LIBRARY = {
    "format": 1,
    "primitives": [
        {
            "name": "toNest",
            "tree": "sel(in_nest, seq(nest_left, forward_left), seq(nest_right, forward_right))",
        },
        {
            "name": "toFood",
            "tree": "sel(on_food, seq(food_left, forward_left), seq(food_right, forward_right))",
        },
    ],
}


def test_a_foraging_run_with_a_library_as_a_user_runs_it(tmp_path, capsys):
    # GP_foraging in 100 s trials over a primitive library: the run keeps the library, its results (held-out
    # scores, figures, best trees with the names, the explorer's animations of 800-step trials with the
    # carrying flags) are the run's task's; --resume reads the library from the run, never from the options.
    import json

    from evolution_manager.evolution.run_config import RunConfig
    from evolution_manager.viewing.explorer import explorer_data
    from swarm_sim.evaluation.cli import run as evaluate_command

    library = tmp_path / "primitives.json"
    library.write_text(json.dumps(LIBRARY))
    out = tmp_path / "forager"
    common = ["--algorithm", "gp", "--objective", "foraging", "--task", "foraging", "--evaluations", "25"]
    assert (
        evolve([*common, "--library", str(library), "--seed", "6", "--out", str(out), "--no-progress"]) == 0
    )
    config = RunConfig.from_json(json.loads((out / "config.json").read_text()))
    assert (config.task.name, config.library, config.grids) == ("foraging", str(library), ("foraging",))
    assert json.loads((out / "library.json").read_text()) == LIBRARY
    assert {p.name for p in (out / "figures").iterdir()} == {
        "heatmap_foraging.png",
        "histogram.png",
        "progress.png",
    }
    summary = json.loads((out / "summary.json").read_text())
    assert list(summary["objectives"]) == ["foraging"]
    foraging = summary["objectives"]["foraging"]
    assert foraging["heldout_best_fitness"] is not None and foraging["heldout_qd_score"] is not None
    # the best tree as evolved (names kept) scores as the run says on the run's scenario
    best = (out / "best/foraging.original.txt").read_text().strip()
    assert best == foraging["best_tree"]
    scored = json.loads(
        evaluate_command(
            [
                "--tree",
                best,
                "--seed",
                str(config.scenario_seed),
                "--task",
                "foraging",
                "--library",
                str(library),
            ]
        )
    )
    assert scored["fitness"]["foraging"] == foraging["best_fitness"]
    names = [r["tree"] for r in csv_rows(out / "evaluations.csv")]
    assert any("toNest" in t or "toFood" in t for t in names)
    data = explorer_data(out)
    assert list(data["objectives"]) == ["foraging"]
    animation = next(iter(data["animations"].values()))
    assert animation["steps"][-1] == 800 and len(animation["steps"]) == 401  # every 2nd step, and the last
    capsys.readouterr()
    assert evolve(["--out", str(out), "--resume", "--library", str(library)]) == 2
    assert "leave them out with --resume" in capsys.readouterr().err
    assert evolve(["--out", str(out), "--resume", "--task", "primitives"]) == 2
    assert evolve([*common, "--library", str(tmp_path / "none.json"), "--out", str(tmp_path / "x")]) == 2
    assert "--library" in capsys.readouterr().err and not (tmp_path / "x").exists()


def test_gp_fnd_evolves_any_set_of_objectives(tmp_path, capsys):
    import json

    out = tmp_path / "inverse"
    args = [
        "--algorithm",
        "gp-fnd",
        "--objectives",
        "ifood,idensity,inest",
        "--evaluations",
        "75",
        "--seed",
        "7",
    ]
    assert evolve([*args, "--out", str(out), "--no-progress", "--no-figures"]) == 0
    summary = json.loads((out / "summary.json").read_text())
    evolved = [o for o, m in summary["objectives"].items() if m["evolved"]]
    assert evolved == ["idensity", "inest", "ifood"]  # OBJECTIVES order
    assert set(summary["objectives"]) == {"density", "nest", "food", "idensity", "inest", "ifood"}
    assert all(summary["objectives"][o]["heldout_best_fitness"] is not None for o in evolved)
    assert "ifood: best" in capsys.readouterr().out
    assert evolve([*args[:2], "--objectives", "ifood,speed", "--out", str(tmp_path / "bad")]) == 2
    assert "speed" in capsys.readouterr().err


def csv_rows(path: Path) -> list[dict[str, str]]:
    import csv

    with path.open(newline="") as handle:
        return list(csv.DictReader(handle))


def test_an_interrupt_after_the_run_is_made_and_before_it_executes_says_how_to_continue(
    tmp_path, capsys, monkeypatch
):
    # a SIGTERM that lands between Run.start and the protected execution (here: while the progress bar is
    # made) used to kill the process with no word; it is now the one line of any other interrupt
    def interrupted(*_args, **_kwargs):
        raise KeyboardInterrupt

    monkeypatch.setattr(evolve_command, "progress_bar", interrupted)
    out = tmp_path / "run"
    status = evolve(["--algorithm", "gp", "--objective", "nest", "--evaluations", "40", "--out", str(out)])
    assert status == 130
    assert (out / "config.json").exists()
    said = capsys.readouterr().err.strip()
    assert said == f"evolve: interrupted; continue with: evolve --out {out} --resume"
