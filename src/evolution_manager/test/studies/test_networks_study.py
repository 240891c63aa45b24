"""``experiment --study bt-vs-nn``: the plan (arms, objectives, seeds), the whole study end to end on a tiny
budget (runs.csv, report, figures, each best network's action table), a second start that runs nothing
again, the report command rebuilding the same report, the readable form of a network (its action per input
pattern, grouped as conditions), and the committed report's tables against its runs.csv."""

from __future__ import annotations

import csv
import io
import json
import os
import random
import shutil
from pathlib import Path

import pytest

from bt_controller.interpreters import N_WEIGHTS, Network, load_network
from evolution_manager.studies import networks_study, networks_transfer
from evolution_manager.studies.experiment import build_parser, experiment
from evolution_manager.studies.report_command import report as report_command
from evolution_manager.studies.significance import markdown_table
from swarm_sim.validation import reference as validation
from swarm_sim.validation import transfer


def _members(cube: str) -> set[int]:
    free = [k for k, c in enumerate(cube) if c == "-"]
    found = set()
    for s in range(2 ** len(free)):
        bits = list(cube)
        for j, k in enumerate(free):
            bits[k] = str((s >> j) & 1)
        found.add(int("".join(bits), 2))
    return found


def test_the_cover_matches_exactly_the_patterns_given():
    assert networks_study.cover(set(range(512))) == ["---------"]
    assert networks_study.cover({p for p in range(512) if p & 0b100000000}) == ["1--------"]
    rng = random.Random(3)
    for _ in range(5):
        patterns = {p for p in range(512) if rng.random() < 0.3}
        cubes = networks_study.cover(patterns)
        assert set().union(*(_members(c) for c in cubes)) == patterns
    assert networks_study.cube_text("1-0------") == "in_nest and not got_food"


def test_a_network_table_reads_its_action_for_every_input_pattern():
    stop = [0.0] * (N_WEIGHTS - 1) + [-50.0]  # the output bias alone: output near 0, stop everywhere
    assert networks_study.action_table(stop) == [0] * 512
    carrying = [0.0] * N_WEIGHTS
    carrying[2] = 40.0  # got_food drives hidden unit 0, which drives the output up
    carrying[45] = -20.0  # hidden unit 0's bias
    carrying[50] = 40.0
    carrying[55] = -20.0
    actions = networks_study.action_table(carrying)
    assert {actions[p] for p in range(512) if p & 0b001000000} == {6}  # reverse_right when carrying
    assert {actions[p] for p in range(512) if not p & 0b001000000} == {0}


def test_the_plan_gives_every_arm_and_objective_its_runs_with_distinct_seeds(tmp_path):
    args = build_parser().parse_args(["--study", "bt-vs-nn", "--runs", "2", "--out", str(tmp_path)])
    document, stages, budgets = networks_study.plan_study(args, "fixed", "shared")
    planned = stages[0]()
    assert len(planned) == 5 * 7 * 2 == len(budgets) and set(budgets.values()) == {25_000}
    assert len({made.seed for made, _ in planned}) == len(planned)
    assert len({made.scenario_seed for made, _ in planned}) == 1
    assert [e["arm"] for e in document["plan"][::14]] == ["gp", "qd", "nn-cmaes", "nn-ga", "nn-qd"]
    args.objectives = "foraging,food"
    fewer, _, _ = networks_study.plan_study(args, "fixed", "shared")
    kept = {e["dir"]: e["config"]["seed"] for e in document["plan"]}
    assert all(kept[e["dir"]] == e["config"]["seed"] for e in fewer["plan"])  # shrinking keeps seeds
    assert [e["objective"] for e in fewer["plan"][:4]] == ["food", "food", "foraging", "foraging"]
    with pytest.raises(Exception, match="--objectives takes some of"):
        networks_study.chosen_objectives("food,swim")


def test_the_study_runs_end_to_end_and_a_second_start_runs_nothing_again(tmp_path, capsys):
    out = tmp_path / "study"
    args = ["--study", "bt-vs-nn", "--runs", "1", "--evaluations", "60", "--trials", "1"]
    args += ["--objectives", "food", "--processes", "2", "--out", str(out), "--no-progress"]
    assert experiment(args) == 0
    rows = list(csv.DictReader(io.StringIO((out / "runs.csv").read_text())))
    assert list(rows[0]) == networks_study.CSV_HEADER
    assert [r["arm"] for r in rows] == ["gp", "qd", "nn-cmaes", "nn-ga", "nn-qd"]
    assert all(r["objective"] == "food" and r["best_fitness"] and r["heldout_best_fitness"] for r in rows)
    assert [bool(r["coverage"]) for r in rows] == [False, True, False, False, True]
    for row in rows:
        if row["arm"].startswith("nn-"):
            summary = json.loads((out / f"runs/{row['arm']}/food/run00/summary.json").read_text())
            assert summary["produced"] >= 60 and summary["finished"]
            assert float(row["best_fitness"]) == summary["best"]["fitness"]
    report = (out / "report.md").read_text()
    for heading in ("## Scores", "## Does readability cost performance?", "## Repertoires of trees"):
        assert heading in report
    assert "Holm" in report and "figures/best_fitness.png" in report and "figures/coverage.png" in report
    assert all((out / "figures" / f"{k}.png").stat().st_size > 0 for k in networks_study.CSV_HEADER[3:])
    table = list(csv.reader(io.StringIO((out / "networks" / "food.csv").read_text())))
    assert len(table) == 513 and table[0][-1] == "action"
    best = max(
        (r for r in rows if r["arm"].startswith("nn-")), key=lambda r: float(r["heldout_best_fitness"])
    )
    network = load_network(out / f"runs/{best['arm']}/food/run00/best/food.json")
    assert isinstance(network, Network)
    actions = networks_study.action_table(network.weights)
    assert [row[-1] for row in table[1:]] == [networks_study.ACTIONS[a] for a in actions]

    kept = {p: p.read_bytes() for p in out.glob("runs/*/*/run00/*.csv")}
    written = {name: (out / name).read_bytes() for name in ("runs.csv", "report.md")}
    assert experiment(args) == 0  # every run finished: nothing runs again, the report is the same
    assert {p: p.read_bytes() for p in out.glob("runs/*/*/run00/*.csv")} == kept
    assert {name: (out / name).read_bytes() for name in written} == written
    (out / "report.md").unlink()
    assert report_command([str(out)]) == 0  # the report command rebuilds the same report from the runs
    assert (out / "report.md").read_bytes() == written["report.md"]
    assert experiment([*args[:-3], "--runs", "1", "--evaluations", "70", "--out", str(out)]) == 2
    assert "other options" in capsys.readouterr().err


def test_the_committed_reports_tables_are_its_runs_csv():
    """docs/results/bt-vs-nn: the report's score table and both test tables recomputed from its runs.csv,
    over the objectives of the study's plan (experiments/bt-vs-nn)."""
    root = Path(__file__).resolve().parents[4]
    folder = root / "docs" / "results" / "bt-vs-nn"
    table = list(csv.DictReader(io.StringIO((folder / "runs.csv").read_text())))
    report = (folder / "report.md").read_text()
    objectives = json.loads((root / "experiments" / "bt-vs-nn" / "experiment.json").read_text())["objectives"]
    assert {row["objective"] for row in table} <= set(objectives)
    assert networks_study.scores_table(table, objectives) in report
    best, repertoires = networks_study.comparisons(table, objectives)
    for family in (best, repertoires):
        if family:
            assert markdown_table(family) in report


STUDY = Path(__file__).resolve().parents[4] / "experiments" / "bt-vs-nn"
TREE_RAW = ["tree", "seed", "chromosome", "argos_wall_s", "density", "nest", "food", "idensity", "inest",
            "ifood", "movement", "rotation", "conditionality", "build", "subs"]  # fmt: skip


def test_each_objectives_best_tree_and_network_take_their_argos_rows(tmp_path, monkeypatch, capsys):
    """The committed study's best controllers (the runs of the highest held-out best fitness); the driver's
    rows (written here in its formats) for density's tree and network make the report's ARGoS section, ours
    beside them on the same seeds; the other controllers are counted as missing; without a build the
    command stops in one line and writes no row."""
    copy = tmp_path / "study"
    # the summaries and best controllers only: no checkpoints, evaluation logs or repertoires
    shutil.copytree(
        STUDY, copy, ignore=shutil.ignore_patterns("checkpoint.json", "evaluations.csv", "repertoire_*")
    )
    for name in copy.glob("argos_raw_*"):
        name.unlink()
    document, found = networks_study.finished_runs(copy)
    bests = networks_study.best_controllers(copy, found, document["objectives"])
    kinds = {(b.objective, b.kind) for b in bests}
    assert ("density", "tree") in kinds and ("density", "network") in kinds
    for best in bests:
        mine = next(row for entry, row in found if entry["dir"] == best.folder)
        others = [
            float(row["heldout_best_fitness"])
            for _, row in found
            if row["objective"] == best.objective
            and (row["arm"] in networks_study.TREE_ARMS) == (best.kind == "tree")
        ]
        assert float(mine["heldout_best_fitness"]) == max(others) == best.heldout
    tree = next(b for b in bests if b.objective == "density" and b.kind == "tree")
    network = next(b for b in bests if b.objective == "density" and b.kind == "network")
    assert network.subject.startswith("nn: ") and len(network.subject.split()) == 1 + N_WEIGHTS
    # without a build: one line, no rows
    monkeypatch.setenv("HOME", str(tmp_path / "home"))
    for name in [k for k in os.environ if k.startswith(("ARGOS_", "BT_ARGOS", "SRAND"))]:
        monkeypatch.delenv(name)
    assert (
        report_command([str(copy), "--argos-eval", str(tmp_path / "argos_eval.py"), "--argos-seeds", "1-2"])
        == 2
    )
    error = capsys.readouterr().err
    assert len(error.strip().splitlines()) == 1 and "ARGoS" in error and not list(copy.glob("argos_raw_*"))
    assert report_command([str(copy), "--beside", str(copy / "x.csv")]) == 2
    capsys.readouterr()
    # density's tree and network on seeds 1 and 2
    with (networks_transfer.trees_raw(copy, "primitives")).open("w") as raw:
        raw.write("\t".join(TREE_RAW) + "\n")
        for seed, value in ((1, 0.5), (2, 0.6)):
            cells = [tree.subject, str(seed), "x", "0.3", str(value), *["0.5"] * 8, "primitives", ""]
            raw.write("\t".join(cells) + "\n")
    with (copy / networks_transfer.NETWORKS_RAW).open("w") as raw:
        raw.write("\t".join(transfer.NETWORK_RAW_COLUMNS) + "\n")
        for seed, value in ((1, 0.7), (2, 0.7)):
            cells = [network.subject, str(seed), "20", str(value), *["0.5"] * 29, "0.3"]
            raw.write("\t".join(cells) + "\n")
    text = networks_transfer.section(copy, bests, (1, 2), document["profile"])
    rows = [line for line in text.splitlines() if line.startswith("| density")]
    assert len(rows) == 2 and rows[0].startswith(f"| density | tree, {tree.arm} seed {tree.seed} |")
    assert "| 0.5500 ± 0.0500 |" in rows[0] and "| 0.7000 ± 0.0000 |" in rows[1]
    assert f"{len(bests) - 2} of {len(bests)} controllers lack ARGoS rows" in text
    ours = float(rows[0].split(" | ")[3].split(" ± ")[0])
    assert abs(ours - tree.heldout) < 0.1  # ours on seeds 1-2 near the run's held-out score
    assert report_command([str(copy), "--argos-seeds", "1-2"]) == 0
    capsys.readouterr()
    assert text in (copy / "report.md").read_text()


def test_the_committed_reports_argos_column_is_its_raw_rows():
    """docs/results/bt-vs-nn: each row of the ARGoS section names a run (arm and seed) of the study; that
    run's best controller's rows in experiments/bt-vs-nn give the ARGoS cell, mean and standard error."""
    folder = Path(__file__).resolve().parents[4] / "docs" / "results" / "bt-vs-nn"
    report = (folder / "report.md").read_text()
    section = report.split("## In the authors' ARGoS")[1]
    rows = [line for line in section.splitlines() if line.startswith("| ")][2:]
    _, found = networks_study.finished_runs(STUDY)
    assert rows
    for line in rows:
        cells = [c.strip() for c in line.strip("|").split("|")]
        objective = cells[0].removesuffix(" †")
        kind, rest = cells[1].split(", ")
        arm, seed = rest.split(" seed ")
        entry, row = next(
            (e, r) for e, r in found if (r["arm"], r["objective"], r["seed"]) == (arm, objective, seed)
        )
        best = networks_study.best_controllers(STUDY, [(entry, row)], [objective])[0]
        assert best.kind == kind
        values = networks_transfer.argos_values(STUDY, best, range(1, 21))
        assert values is not None
        estimate = validation.estimate(values)
        assert cells[4] == f"{estimate.mean:.4f} ± {estimate.sem:.4f}"
