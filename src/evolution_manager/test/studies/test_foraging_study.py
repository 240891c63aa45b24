"""``experiment --study foraging`` end to end on a tiny budget: primitives, libraries, foragers, report."""

from __future__ import annotations

import csv
import json
import os
import shutil
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

from bt_controller.language import load_library, parse
from evolution_manager.evolution.libraries import FAMILIES
from evolution_manager.studies import foraging_tables, foraging_transfer
from evolution_manager.studies.experiment import experiment
from evolution_manager.studies.foraging_study import (
    ARMS,
    CSV_HEADER,
    LIBRARIES,
    PRIMITIVES,
    SWARM_ARMS,
    SWARM_SOURCE,
    flat_budget,
    load_arm_runs,
    scores,
    tables,
    write_runs_csv,
)
from evolution_manager.studies.report_command import report
from swarm_sim.validation import transfer

REPOSITORY = Path(__file__).resolve().parents[4]
COMMITTED = REPOSITORY / "docs/results/foraging"
"""The published report of the study committed in ``experiments/foraging``."""

TINY = ["--study", "foraging", "--runs", "1", "--evaluations", "10", "--trials", "1", "--processes", "1"]


@pytest.fixture(scope="module")
def study(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A whole study run without interruption."""
    out = tmp_path_factory.mktemp("foraging") / "study"
    assert experiment([*TINY, "--out", str(out), "--no-progress"]) == 0
    return out


def test_the_flat_baseline_gets_the_hierarchical_budget_plus_the_primitives_in_foraging_time():
    # the authors' 2200 generations against 1000: 6 primitives x 25,000 evaluations x 160 / 800 steps
    assert flat_budget(25_000) == 55_000
    assert flat_budget(10) == 22


def test_a_study_builds_libraries_from_its_primitive_runs_and_runs_every_arm_with_them(study: Path):
    document = json.loads((study / "experiment.json").read_text())
    assert document["study"] == "foraging"
    labels = sorted({Path(entry["dir"]).parent.name for entry in document["primitives"]})
    assert labels == sorted([f"QD_{o}" for o in PRIMITIVES] + ["GP_fnd"])
    seeds = [entry["config"]["seed"] for entry in document["primitives"]] + [
        a["seed"] for a in document["arms"]
    ]
    assert len(set(seeds)) == len(seeds)
    libraries = {name: load_library(study / "libraries" / f"{name}.json") for name in LIBRARIES}
    for name, library in libraries.items():
        source, blocks = LIBRARIES[name]
        assert library.primitives, f"{name} is empty"
        for primitive in library.primitives:
            family = primitive.name.rstrip("0123456789")
            assert family in FAMILIES.values()
            assert 1 <= int(primitive.name[len(family) :]) <= blocks
            assert primitive.source is not None
            # the source run, relative to the library's folder
            origin = (
                (study / "libraries" / str(primitive.source["run"]))
                .resolve()
                .relative_to((study / "primitives").resolve())
            )
            assert origin.parts[0] == (
                "GP_fnd" if source == "gp-fnd" else f"QD_{primitive.source['objective']}"
            )
            # the name expands to the primitive's tree
            assert parse(primitive.name, library=library).children[0] == primitive.tree
    for arm in ARMS:
        config = json.loads((study / "arms" / arm.name / "run00" / "config.json").read_text())
        assert config["task"] == "foraging" and config["objective"] == "foraging"
        assert config["algorithm"] == arm.algorithm
        if arm.library:
            assert config["library_digest"] == libraries[arm.library].digest
            copy = load_library(study / "arms" / arm.name / "run00" / "library.json")
            assert copy.digest == libraries[arm.library].digest
        else:
            assert config["library"] == "" and config["evaluations"] == flat_budget(10)
    source = load_library(study / "arms" / SWARM_SOURCE / "run00" / "library.json")
    for arm in SWARM_ARMS:  # compositions of the foragers of foragers-qd's run with the same index
        run = study / "arms" / arm.name / "run00"
        config = json.loads((run / "config.json").read_text())
        assert config["kind"] == "compositions" and config["algorithm"] == arm.algorithm
        assert [Path(p) for p in config["sources"]] == [(study / "arms" / SWARM_SOURCE / "run00").absolute()]
        assert config["library_digest"] == source.digest
        layout = json.loads((run / "best" / "foraging_swarm.json").read_text())
        assert len(layout["trees"]) == 9
        summary = json.loads((run / "summary.json").read_text())
        assert summary["finished"] and summary["heldout_best_fitness"] is not None


def test_the_report_has_a_row_per_run_every_arm_and_the_2024_paper_beside_ours(study: Path, capsys):
    with (study / "runs.csv").open() as handle:
        rows = list(csv.DictReader(handle))
    assert list(rows[0]) == CSV_HEADER
    assert [row["arm"] for row in rows] == [arm.name for arm in (*ARMS, *SWARM_ARMS)]
    for row in rows:
        summary = json.loads((study / "arms" / row["arm"] / "run00" / "summary.json").read_text())
        scores = summary["objectives"]["foraging"] if "objectives" in summary else summary
        assert float(row["best_fitness"]) == scores["best_fitness"]
        assert float(row["heldout_best_fitness"]) == scores["heldout_best_fitness"]
    text = (study / "report.md").read_text()
    for arm in (*ARMS, *SWARM_ARMS):
        assert f"| {arm.name} |" in text
    for arm in ARMS:
        assert (study / "figures" / f"best_{arm.name}.png").exists()
    assert "robot 8: " in text  # the best heterogeneous swarm, a tree per robot
    for arm in ARMS:  # an arm over a library shows its best forager as evolved, primitives by name
        summary = json.loads((study / "arms" / arm.name / "run00" / "summary.json").read_text())
        shown = summary["objectives"]["foraging"]["best_tree"]
        if not arm.library:
            shown = (study / "arms" / arm.name / "run00" / "best" / "foraging.txt").read_text().strip()
        assert f"```\n{shown}\n```" in text
    assert "## The 2024 paper beside ours" in text and "Hierarchical beats flat" in text
    compared, claims = tables(foraging_tables.read_scores(study / "runs.csv"))  # from runs.csv alone
    assert compared in text and claims in text
    assert "Holm's correction runs over one family: the 26 rows of this table (13 comparisons" in text
    for arm in SWARM_ARMS:  # paired with the runs they are made of; one run per arm here
        assert f"| {arm.name} vs {SWARM_SOURCE} | 1 pairs |" in text
        assert f"- {arm.name} against {SWARM_SOURCE}, run by run" in text
    assert "![progress](figures/progress.png)" in text
    assert "--study foraging" in text  # the reproduce command
    before = text
    assert report([str(study)]) == 0  # the report command rebuilds the same report
    assert (study / "report.md").read_text() == before
    capsys.readouterr()


def test_a_study_continued_with_other_options_is_refused(study: Path, capsys):
    other = [a if a != "10" else "11" for a in TINY]
    assert experiment([*other, "--out", str(study), "--no-progress"]) == 2
    assert "holds an experiment with other options" in capsys.readouterr().err


def test_a_killed_study_continues_to_the_same_libraries_and_results(study: Path, tmp_path: Path):
    killed = tmp_path / "killed"
    call = f"experiment({[*TINY, '--checkpoint-every', '0', '--out', str(killed)]!r})"
    code = f"from evolution_manager.studies.experiment import experiment; {call}"
    process = subprocess.Popen([sys.executable, "-c", code], start_new_session=True)
    try:  # killed in the foragers' stage: the libraries are built, some arms started
        deadline = time.monotonic() + 600
        while not list(killed.glob("arms/*/run00/config.json")) and process.poll() is None:
            assert time.monotonic() < deadline, "the study never reached its foragers"
            time.sleep(0.2)
    finally:
        os.killpg(process.pid, signal.SIGKILL)  # the command and its process pool
        process.wait()
    assert not (killed / "runs.csv").exists(), "the kill came too late to interrupt the study"
    assert experiment([*TINY, "--checkpoint-every", "0", "--out", str(killed), "--no-progress"]) == 0
    for name in LIBRARIES:  # the same primitives (their sources name each study's own folders)
        kept = load_library(killed / "libraries" / f"{name}.json").primitives
        straight = load_library(study / "libraries" / f"{name}.json").primitives
        assert [(p.name, p.tree) for p in kept] == [(p.name, p.tree) for p in straight]
    assert (killed / "runs.csv").read_bytes() == (study / "runs.csv").read_bytes()


def test_a_study_moved_to_another_folder_continues_its_unfinished_runs(study: Path, tmp_path: Path):
    """A forager run's configuration names its library's file and a composition run's its source runs by
    path; a study folder moved with such runs unfinished continues them to the same results."""
    moved = tmp_path / "elsewhere" / "study"
    shutil.copytree(study, moved)
    unfinished = [moved / "arms" / "hier-qd8" / "run00", moved / "arms" / "swarm-ga" / "run00"]
    for run in unfinished:  # as if stopped at their last checkpoint: the folder holds their old location
        assert str(study) in (run / "config.json").read_text()
        (run / "summary.json").unlink()
    (moved / "runs.csv").unlink()
    assert experiment([*TINY, "--out", str(moved), "--no-progress"]) == 0
    for run in unfinished:
        assert json.loads((run / "summary.json").read_text())["finished"]
    assert (moved / "runs.csv").read_bytes() == (study / "runs.csv").read_bytes()


def test_a_moved_composition_run_whose_sources_changed_is_refused(study: Path, tmp_path: Path, capsys):
    moved = tmp_path / "study"
    shutil.copytree(study, moved)
    run = moved / "arms" / "swarm-qd" / "run00"
    (run / "summary.json").unlink()
    source = moved / "arms" / SWARM_SOURCE / "run00" / "repertoire_foraging.json"
    document = json.loads(source.read_text())
    document["items"][0]["fitness"] += 1.0  # another repertoire than the run's cells were read from
    source.write_text(json.dumps(document))
    assert experiment([*TINY, "--out", str(moved), "--no-progress"]) != 0
    assert "holds a run of another configuration than the experiment's plan" in capsys.readouterr().err
    assert not (run / "summary.json").exists()


FORAGING_RAW = ["tree", "seed", "chromosome", "argos_wall_s", "foraging", "movement", "rotation",
                "conditionality", "foraging_trials", "build", "subs"]  # fmt: skip


def test_the_report_sets_each_arms_best_forager_beside_its_argos_score(study: Path, tmp_path: Path, capsys):
    """The driver's rows (written here in its format: ARGoS is not built where the tests run) give the
    transfer section; without them and without a build the command stops in one line."""
    copy = tmp_path / "study"
    shutil.copytree(study, copy)
    _, runs = load_arm_runs(copy)
    foragers = foraging_transfer.best_foragers(runs, {arm.name: arm.library for arm in ARMS})
    assert [f.arm for f in foragers] == [arm.name for arm in ARMS]  # the homogeneous arms only
    for f in foragers:
        top = max((r for r in runs if r.arm == f.arm), key=lambda r: r.best_fitness)
        assert (f.tree, f.best_fitness, f.heldout) == (
            top.best_tree,
            top.best_fitness,
            top.heldout_best_fitness,
        )
    # without a build: one line, the report as it was, no raw file
    before = (copy / "report.md").read_bytes()
    env_home = tmp_path / "home"
    code = (
        "import os, sys; from evolution_manager.studies.report_command import report; "
        f"sys.exit(report([{str(copy)!r}, '--argos-eval', {str(tmp_path / 'argos_eval.py')!r}]))"
    )
    env = {k: v for k, v in os.environ.items() if not k.startswith(("ARGOS_", "BT_ARGOS", "SRAND"))}
    done = subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, env={**env, "HOME": str(env_home)}
    )
    assert done.returncode == 2, done.stderr
    assert len(done.stderr.strip().splitlines()) == 1 and "ARGoS build not found" in done.stderr
    assert "rebuild_2024.sh" in done.stderr
    assert (copy / "report.md").read_bytes() == before and not list(copy.glob("argos_raw_*"))
    # the driver's rows: each forager's value per seed
    for library in dict.fromkeys(f.library for f in foragers):
        with (copy / f"argos_raw_{library or 'flat'}.tsv").open("w") as raw:
            raw.write("\t".join(FORAGING_RAW) + "\n")
            for k, f in enumerate(x for x in foragers if x.library == library):
                for seed in (1, 2, 3):
                    value = 0.1 * (k + 1) + 0.01 * seed
                    cells = [
                        f.tree,
                        str(seed),
                        "x",
                        "3.4",
                        str(value),
                        "0",
                        "0",
                        "0.5",
                        "",
                        "foraging",
                        library,
                    ]
                    raw.write("\t".join(cells) + "\n")
    assert report([str(copy), "--argos-seeds", "1-3"]) == 0
    capsys.readouterr()
    text = (copy / "report.md").read_text().split("## Transfer: each arm's best forager")[1]
    for f in foragers:
        k = [x for x in foragers if x.library == f.library].index(f)
        argos = 0.1 * (k + 1) + 0.02
        line = next(x for x in text.splitlines() if x.startswith(f"| {f.arm} |"))
        assert f"| {argos:.3f} ± {0.01 / 3**0.5:.3f} |" in line
        assert line.endswith(f"| {f.heldout - argos:+.3f} |")
    assert "Not transferred: swarm-ga, swarm-qd" in text
    assert "not yet scored" not in text
    assert report([str(copy), "--argos-seeds", "1-4"]) == 0  # a seed without rows: every forager missing
    capsys.readouterr()
    assert (
        f"**{len(foragers)} best foragers are not yet scored in ARGoS**" in (copy / "report.md").read_text()
    )


def test_a_library_becomes_the_drivers_sub_behaviours_file_without_draw_keys():
    text = transfer.subs_text(
        [("gotoNest1", "sel(prob@56(forward, stop), in_nest)"), ("gotoFood2", "forward")]
    )
    assert text == "gotoNest1 sel(prob(forward, stop), in_nest)\ngotoFood2 forward\n"


def test_the_committed_report_recomputes_from_its_runs_csv_and_its_runs(tmp_path: Path):
    """The published comparisons, the 2024 table and every arm's median with its interval recompute from
    the published ``runs.csv``, and that file from the committed runs of ``experiments/foraging``."""
    text = (COMMITTED / "report.md").read_text()
    scored = foraging_tables.read_scores(COMMITTED / "runs.csv")
    compared, claims = tables(scored)
    assert compared in text and claims in text
    assert "the 26 rows of this table (13 comparisons on 2 metrics" in text
    for metric, name in (("best fitness", "best"), ("held-out best fitness", "held-out")):
        for arm, by_run in scored[metric].items():
            values = [by_run[k] for k in sorted(by_run)]
            median = foraging_tables.with_interval(
                float(np.median(values)), foraging_tables.median_interval(values), sign=False
            )
            row = next(line for line in text.splitlines() if line.startswith(f"| {arm} | "))
            assert f"| {median} |" in row, f"{arm}'s {name} median"
    # one interval by hand: hier-qd8 against flat in-run, a Mann-Whitney row, so the difference of medians
    a = np.array(list(scored["best fitness"]["hier-qd8"].values()))
    b = np.array(list(scored["best fitness"]["flat"].values()))
    rng = np.random.default_rng(foraging_tables.BOOTSTRAP_SEED)
    draws = np.median(a[rng.integers(0, 10, (10_000, 10))], axis=1)
    draws = draws - np.median(b[rng.integers(0, 10, (10_000, 10))], axis=1)
    low, high = np.quantile(draws, [0.025, 0.975])
    by_hand = f"| Mann-Whitney U | Δ median | {np.median(a) - np.median(b):+.3f} [{low:+.3f}, {high:+.3f}] |"
    assert by_hand in next(
        line for line in text.splitlines() if line.startswith("| best fitness | **hier-qd8 vs flat")
    )
    # the published runs.csv is the committed runs' own
    _, runs = load_arm_runs(REPOSITORY / "experiments/foraging")
    assert scores(runs) == scored
    write_runs_csv(tmp_path, runs)
    assert (tmp_path / "runs.csv").read_bytes() == (COMMITTED / "runs.csv").read_bytes()
