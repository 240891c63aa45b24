"""``experiment --study heterogeneity``: the plan (a repertoire per task and index, then the arms composing
from it, all of one index on one seed), the whole study end to end on a tiny budget (runs.csv with the
homogeneous baseline paired by seed, report with the tests and the QD scores, a figure), and a second start
that runs nothing again and writes the same report."""

from __future__ import annotations

import csv
import io
import json
from pathlib import Path

import numpy as np
import pytest

from evolution_manager.studies import handwritten_swarms, planning
from evolution_manager.studies import heterogeneity_study as study
from evolution_manager.studies.experiment import build_parser, experiment
from evolution_manager.studies.report_command import report as report_command
from swarm_sim.bench import division
from swarm_sim.evaluation import BatchEvaluator, SwarmRequest
from swarm_sim.model import OBJECTIVES, SwarmLayout
from swarm_sim.tasks import task_named, unseen_twin


def test_the_plan_pairs_every_arm_with_its_repertoire_by_seed(tmp_path):
    args = build_parser().parse_args(
        ["--study", "heterogeneity", "--runs", "2", "--swarm-evaluations", "300", "--out", str(tmp_path)]
    )
    document, stages, budgets = study.plan_study(args, "fixed", "shared")
    assert len(study.DEFAULT_TASKS) == 3  # without --tasks, the first three tasks
    assert len(stages) == 3 * 3  # each task: its repertoires, its compositions, its teams
    first = stages[0]()
    assert [folder for _, folder in first] == [
        "repertoires/multifood-arena9-kind2/run00",
        "repertoires/multifood-arena9-kind2/run01",
    ]
    third = stages[2]()  # the teams need no repertoire
    assert [folder for _, folder in third] == [
        f"arms/multifood-arena9-kind2/team{k}{fresh}/run0{r}"
        for fresh in ("", "-fresh")
        for k in (2, 3, 9)
        for r in (0, 1)
    ]
    made, _ = first[0]
    assert (made.algorithm, made.descriptors, made.objective) == ("qd", "deliveries", "foraging_biased")
    teams = [e for e in document["plan"] if e["kind"] == "team"]
    assert len(teams) == 3 * 6 * 2
    assert all(budgets[e["dir"]] == 25_000 + 300 for e in teams)  # a repertoire's and a composition's budget
    assert [made.team for made, _ in third] == [2, 2, 3, 3, 9, 9] * 2
    assert [made.scenarios for made, _ in third] == ["fixed"] * 6 + ["fresh"] * 6
    arms = [e for e in document["plan"] if e["kind"] == "composition"]
    planned = [a for a in study.ARMS if a.name in study.DEFAULT_ARMS]  # without --arms, the first twelve
    assert len(arms) == 3 * sum(1 for a in planned if not a.team) * 2
    for entry in arms:
        repertoire = next(e for e in document["plan"] if e["dir"] == entry["from"])
        assert entry["seed"] == repertoire["config"]["seed"] and entry["task"] == repertoire["task"]
        assert budgets[entry["dir"]] == 300
    seeds = {(e["task"], e["seed"]) for e in arms}
    assert len(seeds) == 3 * 2  # one seed per task and index, shared by its arms
    assert document["swarm_evaluations"] == 300 and document["arms"] == list(study.DEFAULT_ARMS)
    for entry in teams:  # the teams share the seeds of the repertoires and compositions they are set beside
        assert (entry["task"], entry["seed"]) in seeds


def test_new_arms_grow_the_plan_and_keep_the_runs_planned_before(tmp_path, monkeypatch):
    """The fresh-scenario arms came after the study began: a plan made without them grows by them (as by more
    runs), every run planned before planned again alike (the fixed-scenario entries, of compositions and
    teams, without a scenarios key); a plan with other options does not grow."""
    args = build_parser().parse_args(
        ["--study", "heterogeneity", "--runs", "2", "--swarm-evaluations", "300", "--out", str(tmp_path)]
    )
    full, _, _ = study.plan_study(args, "fixed", "shared")
    every_arm = study.ARMS
    earlier = tuple(arm for arm in every_arm if arm.scenarios == "fixed")
    monkeypatch.setattr(study, "ARMS", earlier)
    before, _, _ = study.plan_study(args, "fixed", "shared")
    saved, given = json.loads(json.dumps(before)), json.loads(json.dumps(full))
    assert planning.more_runs(saved, given) and not planning.more_runs(given, saved)
    added = "ga-fresh, qd-fresh, team2-fresh, team3-fresh, team9-fresh"
    assert planning.growth(saved, given) == f"by the arms {added}"
    fresh = [e for e in given["plan"] if e.get("scenarios", e.get("config", {}).get("scenarios")) == "fresh"]
    assert len(fresh) == 3 * 5 * 2 and {e["arm"] for e in fresh} == set(added.split(", "))
    assert all("scenarios" not in e for e in saved["plan"])
    assert all("scenarios" not in e["config"] for e in saved["plan"] if e["kind"] == "team")
    more = build_parser().parse_args(
        ["--study", "heterogeneity", "--runs", "3", "--swarm-evaluations", "300", "--out", str(tmp_path)]
    )
    monkeypatch.setattr(study, "ARMS", every_arm)
    both, _, _ = study.plan_study(more, "fixed", "shared")
    assert (
        planning.growth(saved, json.loads(json.dumps(both))) == f"to 3 runs per group and by the arms {added}"
    )
    other = build_parser().parse_args(
        ["--study", "heterogeneity", "--runs", "2", "--swarm-evaluations", "400", "--out", str(tmp_path)]
    )
    changed, _, _ = study.plan_study(other, "fixed", "shared")
    assert not planning.more_runs(saved, json.loads(json.dumps(changed)))


def test_arms_and_descriptors_plan_a_part_of_the_study_on_the_same_seeds(tmp_path, capsys):
    """``--arms`` plans only the arms named and ``--descriptors`` bins every repertoire and composition by
    another behaviour space; each run keeps the seed and folder it has in the whole plan, so the two folders'
    runs pair by seed, and the part grows into the whole as new arms do."""
    base = ["--study", "heterogeneity", "--runs", "2", "--swarm-evaluations", "300", "--out", str(tmp_path)]
    base += ["--tasks", "multifood-arena6-carriers"]
    whole, _, _ = study.plan_study(build_parser().parse_args(base), "fixed", "shared")
    part_args = build_parser().parse_args([*base, "--arms", "qd, ga", "--descriptors", "deliveries-0.25"])
    part, _, budgets = study.plan_study(part_args, "fixed", "shared")
    assert part["arms"] == ["ga", "qd"] and part["tasks"][0]["descriptors"] == "deliveries-0.25"
    assert {e.get("arm", "repertoire") for e in part["plan"]} == {"repertoire", "ga", "qd"}
    assert len(part["plan"]) == 6 and set(budgets) == {e["dir"] for e in part["plan"]}
    seeds = {e["dir"]: e.get("seed", e["config"]["seed"] if "config" in e else None) for e in whole["plan"]}
    for entry in part["plan"]:
        where = entry["config"] if entry["kind"] == "repertoire" else entry
        assert where["descriptors"] == "deliveries-0.25"
        assert entry.get("seed", entry.get("config", {}).get("seed")) == seeds[entry["dir"]]
    only_args = build_parser().parse_args([*base, "--arms", "ga,qd"])
    only_arms, _, _ = study.plan_study(only_args, "fixed", "shared")
    assert planning.growth(json.loads(json.dumps(only_arms)), json.loads(json.dumps(whole))).startswith(
        "by the arms ga-seeded, qd-mix"
    )
    # the group compositions: planned only when named, on the seeds and repertoires of the whole plan
    grouped_args = build_parser().parse_args([*base, "--arms", "ga-groups3,qd-groups3"])
    grouped, _, _ = study.plan_study(grouped_args, "fixed", "shared")
    entries = [e for e in grouped["plan"] if e["kind"] == "composition"]
    assert {e["arm"] for e in entries} == {"ga-groups3", "qd-groups3"} and len(entries) == 4
    assert not any(e.get("arm", "").endswith("groups3") for e in whole["plan"])
    ga = {e["from"]: e["seed"] for e in whole["plan"] if e.get("arm") == "ga"}
    assert all(ga[e["from"]] == e["seed"] for e in entries)
    assert [a.parameters.groups for a in study.ARMS if a.name.endswith("groups3")] == [3, 3, 3]
    ascent_args = build_parser().parse_args([*base, "--arms", "ascent-groups3"])
    ascent, _, _ = study.plan_study(ascent_args, "fixed", "shared")
    climbs = [e for e in ascent["plan"] if e["kind"] == "composition"]
    assert {e["arm"] for e in climbs} == {"ascent-groups3"} and len(climbs) == 2
    assert all(ga[e["from"]] == e["seed"] for e in climbs)
    # the teams from a start tree and their homogeneous twin: planned only when named, on the same seeds
    started_args = build_parser().parse_args([*base, "--arms", "ga,team3-any-fresh,homogeneous-any-fresh"])
    started, _, _ = study.plan_study(started_args, "fixed", "shared")
    teams = [e for e in started["plan"] if e["kind"] == "team"]
    assert sorted((e["arm"], e["config"]["team"]) for e in teams) == [
        ("homogeneous-any-fresh", 1), ("homogeneous-any-fresh", 1),
        ("team3-any-fresh", 3), ("team3-any-fresh", 3),
    ]  # fmt: skip
    assert all(e["config"]["start_tree"] == division.any_forager() for e in teams)
    specialists_args = build_parser().parse_args([*base, "--arms", "ga,team3-specialists-fresh"])
    specialists, _, _ = study.plan_study(specialists_args, "fixed", "shared")
    started_from = [e["config"]["start_tree"] for e in specialists["plan"] if e["kind"] == "team"]
    assert started_from == [[division.kind_forager(k) for k in (1, 2, 3)]] * 2
    assert all(e["config"]["scenarios"] == "fresh" and ga[_from(e)] == e["seed"] for e in teams)
    assert not any(e.get("arm", "").endswith("any-fresh") for e in whole["plan"])
    for more, expected in (
        (["--arms", "ga,gx"], "--arms: unknown arm 'gx'; expected some of ga,ga-seeded,qd,"),
        (["--arms", "team3"], "--arms: a plan needs a composition arm"),
    ):
        assert experiment([*base, *more, "--out", str(tmp_path / "x")]) == 2
        error = capsys.readouterr().err
        assert error.count("\n") == 1 and expected in error
    for option in (["--arms", "ga"], ["--descriptors", "deliveries"]):
        assert experiment(["--study", "paper", *option, "--out", str(tmp_path / "x")]) == 2
        assert f"{option[0]} applies to --study heterogeneity only" in capsys.readouterr().err
    assert not (tmp_path / "x").exists()


def _from(entry: dict) -> str:
    """The repertoire folder of a plan entry's index (a team plans none: its index's, by its folder)."""
    task, index = entry["task"], entry["dir"].rsplit("/", 1)[1]
    return f"repertoires/{task}/{index}"


def test_an_arm_is_paired_with_its_homogeneous_twin_seed_by_seed():
    """twin_comparisons: team3-any-fresh against homogeneous-any-fresh, on the held-out scores of the best and
    of the validated choice, paired by seed (a seed only one of them has is left out), one Holm family; the
    report's section names the pair."""

    def row(arm, seed, held, validated):
        return {
            "arm": arm,
            "task": "t",
            "seed": str(seed),
            study.HELDOUT: str(held),
            study.VALIDATED: validated,
        }

    rows = [row("team3-any-fresh", s, 0.30 + 0.01 * s, str(0.31 + 0.01 * s)) for s in range(6)]
    rows += [row("homogeneous-any-fresh", s, 0.20 + 0.013 * s, "") for s in range(1, 8)]
    (held,) = study.twin_comparisons(rows, ["t"])  # no validated scores on the twin's side: one row
    assert (held.first, held.second, held.n_first, held.metric) == (
        "team3-any-fresh", "homogeneous-any-fresh", 5, study.METRICS[study.HELDOUT]
    )  # fmt: skip
    assert held.significant and held.p_holm == held.p_value
    rows += [row("homogeneous-any-fresh", 0, 0.2, "0.2")]
    rows = [{**r, study.VALIDATED: r[study.VALIDATED] or "0.25"} for r in rows]
    both = study.twin_comparisons(rows, ["t"])
    assert [c.metric for c in both] == [study.METRICS[study.HELDOUT], study.METRICS[study.VALIDATED]]
    assert all(c.n_first == 6 for c in both) and all(c.p_holm >= c.p_value for c in both)
    rows += [row(study.BASELINE, s, 0.1, "0.1") for s in range(8)]
    goal = study.goal_text(rows, study.comparisons(rows, ["t"]), ["t"])
    twin = np.median([0.2] + [0.20 + 0.013 * s for s in range(1, 8)])  # 0.2455
    assert (
        f"- t, homogeneous-any-fresh: a homogeneous arm, no candidate; its median is {twin / 0.1:.3g} times"
        in goal
    )
    assert f"best heterogeneous median {0.325 / twin:.3g} times its own" in goal  # team3-any-fresh's 0.325
    # the twin's median is above the baseline's: the goal is measured against the twin, in a family of its own
    assert study.best_homogeneous(rows, "t", study.HELDOUT) == "homogeneous-any-fresh"
    assert goal.startswith("The best homogeneous swarm is not the baseline here (t: homogeneous-any-fresh")
    assert goal.count("goal reached") == 1
    assert f"- t, team3-any-fresh: {0.325 / twin:.3g} times homogeneous-any-fresh's median" in goal
    assert "(6 runs, 6 paired with it): goal reached" in goal
    # where the baseline is the best homogeneous swarm (a tie included), the goal stays against it
    lower = [{**r, study.HELDOUT: "0.1"} if r["arm"] == "homogeneous-any-fresh" else r for r in rows]
    assert study.best_homogeneous(lower, "t", study.HELDOUT) == study.BASELINE
    kept = study.goal_text(lower, study.comparisons(lower, ["t"]), ["t"])
    assert (
        kept.startswith("- t, homogeneous-any-fresh")
        and "- t, team3-any-fresh: 3.25 times the homogeneous" in kept
    )
    section = study._twins_section(rows, ["t"])
    assert (
        section.startswith("## Against the homogeneous twin") and "team3-any-fresh vs homogeneous" in section
    )
    assert study._twins_section(rows[:1], ["t"]) == ""


def test_map_elites_is_paired_with_the_ga_and_mix_me_on_every_qd_score():
    """qd_comparisons: qd against ga and against qd-mix at 1, 2, 4 and 8 bins, paired by seed (a seed only
    one side has is left out), one Holm family; the section shows the table only once a pair has two runs."""

    def row(arm, seed, score):
        return {
            "arm": arm,
            "task": "t",
            "seed": str(seed),
            **{f"qd_score_{k}": str(score / k) for k in (1, 2, 4, 8)},
        }

    rows = [row("qd", s, 0.5 + 0.01 * s) for s in range(7)]
    rows += [row("ga", s, 0.4 + 0.011 * s) for s in range(1, 8)] + [
        row("qd-mix", s, 0.5 + 0.01 * s) for s in range(7)
    ]
    tested = study.qd_comparisons(rows, ["t"])
    assert [(c.metric, c.first, c.second) for c in tested] == [
        (f"QD score, {k} per axis", "qd", rival) for k in (1, 2, 4, 8) for rival in ("ga", "qd-mix")
    ]
    against_ga = [c for c in tested if c.second == "ga"]
    assert all(c.n_first == 6 and c.significant and c.p_holm >= c.p_value for c in against_ga)
    assert all(
        c.p_value == 1.0 and c.n_first == 7 for c in tested if c.second == "qd-mix"
    )  # identical scores
    section = study._qd_section(rows, ["t"], "space")
    assert section.startswith("## The authors' QD score") and study.markdown_table(tested) in section
    assert "paired by seed" not in study._qd_section(rows[:1] + rows[7:8], ["t"], "space")


def test_swarm_evaluations_belongs_to_the_heterogeneity_study(tmp_path, capsys):
    args = ["--study", "paper", "--swarm-evaluations", "10", "--out", str(tmp_path / "x")]
    assert experiment(args) == 2
    assert "--swarm-evaluations applies to --study heterogeneity only" in capsys.readouterr().err


def _plan(tmp_path, *more):
    args = ["--study", "heterogeneity", "--runs", "2", "--swarm-evaluations", "300", "--out", str(tmp_path)]
    document, _, _ = study.plan_study(build_parser().parse_args([*args, *more]), "fixed", "shared")
    return document


def test_tasks_plans_the_tasks_named_each_on_the_seeds_of_its_row(tmp_path):
    """--tasks names the rows of TASKS to plan; a task's runs are the same whichever others are planned
    (their seeds derive from its row), and without --tasks the plan is the first three tasks'."""
    every = ",".join(task for task, _, _ in study.TASKS)
    whole = _plan(tmp_path, "--tasks", every)
    assert [t["task"] for t in whole["tasks"]] == [task for task, _, _ in study.TASKS]
    balanced = _plan(tmp_path, "--tasks", "multifood-arena6-balanced")
    assert balanced["tasks"] == [
        {"task": "multifood-arena6-balanced", "objective": "foraging_balanced", "descriptors": "deliveries"}
    ]
    assert balanced["plan"] == [e for e in whole["plan"] if e["task"] == "multifood-arena6-balanced"]
    repertoire = balanced["plan"][0]
    assert repertoire["dir"] == "repertoires/multifood-arena6-balanced/run00"
    assert repertoire["config"]["objective"] == "foraging_balanced"
    carriers = _plan(tmp_path, "--tasks", "multifood-arena6-carriers")
    assert carriers["tasks"] == [
        {"task": "multifood-arena6-carriers", "objective": "foraging", "descriptors": "deliveries"}
    ]
    assert carriers["plan"] == [e for e in whole["plan"] if e["task"] == "multifood-arena6-carriers"]
    default = _plan(tmp_path)
    assert [t["task"] for t in default["tasks"]] == list(study.DEFAULT_TASKS)
    assert default == _plan(tmp_path, "--tasks", ",".join(reversed(study.DEFAULT_TASKS)))  # in TASKS order
    assert default["plan"] == [e for e in whole["plan"] if e["task"] in study.DEFAULT_TASKS]


@pytest.mark.parametrize("name", ["heterogeneity", "heterogeneity-carriers", "heterogeneity-carriers-fine"])
def test_the_running_studys_plan_is_still_planned_alike(name):
    """experiments/heterogeneity (cut to its first task), experiments/heterogeneity-carriers and its twin on
    the finer delivery grid (two arms): the plan the study's own options give today."""
    folder = Path(__file__).resolve().parents[4] / "experiments" / name
    saved = json.loads((folder / planning.PLAN_FILE).read_text())
    args = [
        "--study",
        "heterogeneity",
        "--runs",
        str(saved["runs"]),
        "--evaluations",
        str(saved["evaluations"]),
    ]
    args += ["--seed", str(saved["seed"]), "--trials", str(saved["trials"]), "--out", str(folder)]
    args += ["--swarm-evaluations", str(saved["swarm_evaluations"]), "--profile", saved["profile"]]
    args += ["--tasks", ",".join(t["task"] for t in saved["tasks"])]
    if saved["arms"] != list(study.DEFAULT_ARMS):
        args += ["--arms", ",".join(saved["arms"])]
    if name.endswith("-fine"):
        args += ["--descriptors", saved["tasks"][0]["descriptors"]]
    document, _, _ = study.plan_study(build_parser().parse_args(args), saved["scenarios"], saved["design"])
    assert json.loads(json.dumps(document)) == saved


def test_tasks_refuses_an_unknown_task_and_other_studies(tmp_path, capsys):
    out = str(tmp_path / "x")
    assert experiment(["--study", "heterogeneity", "--tasks", "multifood-arena6,arena6", "--out", out]) == 2
    error = capsys.readouterr().err
    assert error.count("\n") == 1 and "--tasks: unknown task 'arena6'; expected some of " in error
    assert ",".join(task for task, _, _ in study.TASKS) in error
    assert experiment(["--study", "heterogeneity", "--tasks", " , ", "--out", out]) == 2
    assert "--tasks: no task in ' , '" in capsys.readouterr().err
    assert experiment(["--study", "paper", "--tasks", "multifood-arena6", "--out", out]) == 2
    error = capsys.readouterr().err
    assert error.count("\n") == 1 and "--tasks applies to --study heterogeneity only" in error
    assert not (tmp_path / "x").exists()


def test_the_study_runs_end_to_end_and_a_second_start_runs_nothing_again(tmp_path, capsys):
    out = tmp_path / "study"
    args = ["--study", "heterogeneity", "--runs", "2", "--evaluations", "20", "--swarm-evaluations", "10"]
    args += ["--tasks", "multifood-arena6"]  # one task is enough, in a third of the time
    args += ["--trials", "1", "--processes", "1", "--out", str(out), "--no-progress"]
    assert experiment(args) == 0
    rows = list(csv.DictReader(io.StringIO((out / "runs.csv").read_text())))
    assert list(rows[0]) == study.HEADER
    for task in ("multifood-arena6",):
        mine = [r for r in rows if r["task"] == task]
        baselines = [r for r in mine if r["arm"] == study.BASELINE]
        assert len(baselines) == 2 and all(r["qd_score_1"] == "" for r in baselines)
        for arm in (a for a in study.ARMS if a.name in study.DEFAULT_ARMS):
            runs = [r for r in mine if r["arm"] == arm.name]
            assert {r["seed"] for r in runs} == {r["seed"] for r in baselines}
            # the evaluated QD score at one bin is the run's best fitness
            if not arm.team:
                assert all(float(r["qd_score_1"]) == float(r["best_fitness"]) for r in runs)
            assert all(r["heldout_foraging1"] != "" for r in runs)
            assert all(r[study.VALIDATED] != "" for r in runs)  # every arm, teams too, ends validated
        assert all(r[study.VALIDATED] != "" for r in baselines)
    # the baseline is each composition run's own measure: the same for every arm of a seed
    first = json.loads((out / "arms/multifood-arena6/ga/run00/summary.json").read_text())["homogeneous"]
    other = json.loads((out / "arms/multifood-arena6/qd-mix/run00/summary.json").read_text())["homogeneous"]
    assert first == other
    # who delivers what: the robots' deliveries, averaged over robots, are the held-out deliveries per kind
    summary = json.loads((out / "arms/multifood-arena6/ga/run00/summary.json").read_text())
    config = task_named("multifood-arena6").config("paper")
    per_robot = study.robot_deliveries(summary["best"]["trees"], config, summary["heldout"]["seeds"], 1)
    assert per_robot.shape == (9, 3)
    assert per_robot.mean(axis=0).tolist() == pytest.approx(summary["heldout_descriptors"], abs=1e-12)
    assert (out / "figures" / "robots_multifood-arena6.png").stat().st_size > 0
    report = (out / "report.md").read_text()
    assert "picks up only" not in report  # every robot of multifood-arena6 carries every kind
    assert report.count("deliveries of food kinds 1-3 per robot per trial over [0, 0.5]") == 2  # its space
    # what the repertoires hold: the bins each filled, from its archives
    sizes = [
        json.loads((out / f"repertoires/multifood-arena6/run0{r}/repertoire_foraging.json").read_text())[
            "repertoire_size"
        ]
        for r in (0, 1)
    ]
    held = report[report.index("## What the repertoires hold") :]
    assert f"| multifood-arena6 | 2 | {np.median(sizes):g} [{min(sizes)}, {max(sizes)}] of 512 |" in held
    assert (
        "## Does heterogeneity pay?" in report
        and "Holm" in report
        and "| multifood-arena6 | qd-mix |" in report
    )
    assert "Against the goal" in report and (out / "figures" / "heldout_best_fitness.png").stat().st_size > 0
    # the validated choices: their own table and family, the baseline's from the run's summary
    validated = report[report.index("## The validated choice") :]
    assert "| multifood-arena6 | qd-mix |" in validated and "validated held-out fitness" in validated
    baseline = next(r for r in rows if r["arm"] == study.BASELINE and r["seed"] == rows[0]["seed"])
    assert float(baseline[study.VALIDATED]) == first["validated"]["heldout_best_fitness"]
    # the validated choices on the arenas no run evolved on: every row scored, each score that choice's mean
    # on the task's unseen twin over the run's held-out seeds; a section of its own
    assert all(r[study.UNSEEN] != "" for r in rows)
    recorded = list(csv.DictReader(io.StringIO((out / study.UNSEEN_FILE).read_text())))
    assert len(recorded) == len(rows) and list(recorded[0]) == study.UNSEEN_HEADER
    evaluator = BatchEvaluator(unseen_twin("multifood-arena6").config("paper"))
    summary = json.loads((out / "arms/multifood-arena6/ga/run00/summary.json").read_text())
    for swarm, chosen in (
        (study.BASELINE, summary["homogeneous"]["validated"]["trees"]),
        ("validated", summary["validated"]["trees"]),
    ):
        results = evaluator.evaluate(
            [SwarmRequest(SwarmLayout(tuple(chosen)), s, 1) for s in summary["heldout"]["seeds"]]
        )
        mean = sum(r.fitness[OBJECTIVES.index("foraging")] for r in results) / len(results)
        row = next(
            r for r in recorded if r["dir"] == "arms/multifood-arena6/ga/run00" and r["swarm"] == swarm
        )
        assert float(row["fitness"]) == pytest.approx(mean, abs=1e-12)
    assert "## Unseen arenas" in report and "unseen-arena held-out fitness" in report
    # a team's own trees run by every robot on its held-out scenarios: every tree of its best and its
    # validated swarm, each score that homogeneous swarm's mean; the team arms paired with their best tree
    members = list(csv.DictReader(io.StringIO((out / study.MEMBERS_FILE).read_text())))
    assert list(members[0]) == study.MEMBERS_HEADER
    team = json.loads((out / "arms/multifood-arena6/team3/run01/summary.json").read_text())
    mine = [r for r in members if r["dir"] == "arms/multifood-arena6/team3/run01"]
    assert [(r["swarm"], r["group"]) for r in mine] == [
        (w, str(g)) for w in ("best", "validated") for g in range(3)
    ]
    assert len(members) == 2 * 2 * (2 + 3 + 9) * 2  # 2 runs of team2, 3 and 9, fixed and fresh; 2 swarms
    tree = team["validated"]["trees"][2]
    results = BatchEvaluator(config).evaluate(
        [SwarmRequest(SwarmLayout((tree,) * 9), s, 1) for s in team["heldout"]["seeds"]]
    )
    mean = sum(r.fitness[OBJECTIVES.index("foraging")] for r in results) / len(results)
    assert float(mine[5]["fitness"]) == pytest.approx(mean, abs=1e-12)
    tested = study.member_comparisons(list(study.finished_arm_runs(out, study.study_plan(out))),
                                      {(r["dir"], r["swarm"], int(r["group"])): float(r["fitness"])
                                       for r in members}, ["multifood-arena6"])  # fmt: skip
    assert [(c.first, c.second, c.n_first) for c in tested[:3]] == [
        (f"team{k}", study.BEST_MEMBER, 2) for k in (2, 3, 9)
    ]
    assert len(tested) == 12 and all(c.p_holm >= c.p_value for c in tested)  # 6 arms, 2 scores
    assert tested[1].mean_second == pytest.approx(np.mean([
        max(float(r["fitness"]) for r in members if r["dir"] == f"arms/multifood-arena6/team3/run0{k}"
            and r["swarm"] == "best") for k in (0, 1)
    ]))  # fmt: skip
    assert "## Is a team more than its best tree?" in report
    # the hand-written swarms on the baseline's held-out scenarios: every one measured once (the scenarios
    # are the study's, shared by both indices), the specialists' score that swarm's mean over the scenarios
    written = list(csv.DictReader(io.StringIO((out / handwritten_swarms.HANDWRITTEN_FILE).read_text())))
    # and on the scenario the runs evolved on (where their in-run scores come from)
    assert [r["swarm"] for r in written] == list(division.swarms(9)) * 2
    held_seeds = " ".join(map(str, summary["heldout"]["seeds"]))
    assert [r["seeds"] for r in written[::11]] == [held_seeds, str(summary["config"]["scenario_seed"])]
    specialists = division.swarms(9)[division.SPECIALISTS][1]
    results = BatchEvaluator(config).evaluate(
        [SwarmRequest(SwarmLayout(specialists), s, 1) for s in summary["heldout"]["seeds"]]
    )
    row = next(r for r in written if r["swarm"] == division.SPECIALISTS)
    for column in ("foraging", "foraging1", "foraging2", "foraging3"):
        mean = sum(r.fitness[OBJECTIVES.index(column)] for r in results) / len(results)
        assert float(row["fitness" if column == "foraging" else column]) == pytest.approx(mean, abs=1e-12)
    # the same road scores the baseline's nine copies as its run did: the pairing is like for like
    copies = (summary["homogeneous"]["tree"],) * 9
    results = BatchEvaluator(config).evaluate(
        [SwarmRequest(SwarmLayout(copies), s, 1) for s in summary["heldout"]["seeds"]]
    )
    mean = sum(r.fitness[OBJECTIVES.index("foraging")] for r in results) / len(results)
    assert mean == pytest.approx(summary["homogeneous"]["heldout_best_fitness"], abs=1e-12)
    trained = next(r for r in written[11:] if r["swarm"] == division.SPECIALISTS)
    [again] = BatchEvaluator(config).evaluate(
        [SwarmRequest(SwarmLayout(specialists), summary["config"]["scenario_seed"], 1)]
    )
    assert float(trained["fitness"]) == pytest.approx(again.fitness[OBJECTIVES.index("foraging")], abs=1e-12)
    hand = report[report.index("## Hand-written swarms") : report.index("## The authors' QD score")]
    assert f"| multifood-arena6 | {study.HANDWRITTEN}{division.SPECIALISTS} | 2 |" in hand
    in_run = hand[hand.index("### On the scenario the runs evolved on") :]
    above = sum(1 for r in rows if r["arm"] == study.BASELINE and float(r["best_fitness"]) > float(
        trained["fitness"]))  # fmt: skip
    assert f"| {division.SPECIALISTS} | {float(trained['fitness']):.3f} | {above} of 2 |" in in_run
    assert f"- multifood-arena6, {study.HANDWRITTEN}{division.SPECIALISTS}: " in hand
    assert f"- multifood-arena6, {study.HANDWRITTEN}any kind: " not in hand  # the goal is heterogeneity's
    before = {p: p.read_bytes() for p in out.rglob("*") if p.is_file() and p.name != "sessions.json"}
    capsys.readouterr()
    assert experiment(args) == 0
    after = {p: p.read_bytes() for p in out.rglob("*") if p.is_file() and p.name != "sessions.json"}
    assert after.keys() == before.keys()
    assert after[out / "report.md"] == before[out / "report.md"]
    assert after[out / "runs.csv"] == before[out / "runs.csv"]
    assert report_command([str(out)]) == 0
    assert (out / "report.md").read_bytes() == before[out / "report.md"]


def test_the_goals_power_is_the_paired_t_tests_from_the_noncentral_t():
    """paired_power: the power of a two-sided paired t-test to detect the goal's gain, as the noncentral t
    distribution gives it, and the smallest number of pairs reaching 80 %."""
    from scipy import stats

    rng = np.random.default_rng(5)
    differences = list(rng.normal(0.01, 0.05, 10))
    gain = 0.04
    power, needed = study.paired_power(differences, gain)
    effect = gain / np.std(differences, ddof=1)

    def exact(n: int) -> float:
        critical = stats.t.ppf(0.975, n - 1)
        shifted = stats.nct(n - 1, effect * np.sqrt(n))
        return float(shifted.sf(critical) + shifted.cdf(-critical))

    assert power == pytest.approx(exact(10), abs=1e-6)
    assert exact(needed) >= 0.8 > exact(needed - 1)
    # effects so large that statsmodels' root finder gives up: the fewest pairs still counted, from 2
    for large, fewest in ((0.2, 3), (1.0, 2)):
        effect = large / np.std(differences, ddof=1)
        power, needed = study.paired_power(differences, large)
        assert needed == fewest and exact(needed) >= 0.8 and (needed == 2 or exact(needed - 1) < 0.8)
        assert power > 0.999  # (scipy's noncentral t gives NaN this far out)
    assert study.paired_power(differences[:2], gain) is None and study.paired_power([0.1] * 5, gain) is None
    assert "power to detect the goal's gain" in study.goal_power(differences, gain)


def test_the_carries_note_names_each_group_and_what_the_colours_follow():
    carries = task_named("multifood-arena6-carriers").config("paper").carries
    note = study.carries_note("multifood-arena6-carriers", carries)
    assert "group i mod 3" in note and "group 0: food; group 1: food2; group 2: food3" in note
    assert "heights of the bars, not in their colours" in note


CARRIERS = ("multifood-arena6-carriers",)
"""The carriers study's one task (``experiments/heterogeneity-carriers``)."""


@pytest.mark.parametrize(
    ("name", "tasks"),
    [
        ("study", study.DEFAULT_TASKS),
        *(
            (name, CARRIERS)
            for name in (
                "carriers-study",
                "carriers-fine",
                "carriers-groups",
                "carriers-fine-groups",
                "carriers-ascent",
            )
        ),
    ],
)
def test_the_committed_reports_tables_are_its_runs_csv(name, tasks):
    """docs/results/heterogeneity/study, carriers-study and its twins: each report's score tables and QD table
    recomputed from its runs.csv, and the hand-written swarms' table from handwritten.csv."""
    folder = Path(__file__).resolve().parents[4] / "docs" / "results" / "heterogeneity" / name
    rows = list(csv.DictReader(io.StringIO((folder / "runs.csv").read_text())))
    report = (folder / "report.md").read_text()
    tasks = list(tasks)
    assert {row["task"] for row in rows} <= set(tasks)
    for key in (study.HELDOUT, study.VALIDATED, study.UNSEEN):
        assert study.scores_table(rows, tasks, key) in report
    assert study.qd_table(rows, tasks) in report
    # MAP-Elites against the GA and Mix-ME where the report has them, and no such table where it has not
    qd_tested = study.qd_comparisons(rows, tasks)
    assert ("| QD score, " in report) == bool(qd_tested)
    assert not qd_tested or study.markdown_table(qd_tested) in report
    # the hand-written swarms, paired with every index's baseline on the study's one set of scenarios
    measured = list(csv.DictReader(io.StringIO((folder / handwritten_swarms.HANDWRITTEN_FILE).read_text())))
    begun = {row["task"] for row in rows if row["arm"] == study.BASELINE}
    assert {r["task"] for r in measured} == begun
    # the five held-out scenarios; since the in-run section, the study's one training scenario too
    held = [r for r in measured if len(r["seeds"].split()) == 5]
    trained = {(r["task"], r["swarm"]): r["fitness"] for r in measured if len(r["seeds"].split()) == 1}
    assert len({(r["task"], r["seeds"], r["trials"]) for r in held}) == len(begun)
    assert len(held) + len(trained) == len(measured)
    paired = [
        {
            **dict.fromkeys(study.HEADER, ""),
            "arm": study.HANDWRITTEN + r["swarm"],
            "task": r["task"],
            "seed": base["seed"],
            "best_fitness": trained.get((r["task"], r["swarm"]), ""),
            study.HELDOUT: r["fitness"],
            **{f"heldout_foraging{k}": r[f"foraging{k}"] for k in (1, 2, 3)},
        }
        for base in rows
        if base["arm"] == study.BASELINE
        for r in held
        if r["task"] == base["task"]
    ]
    names = list(dict.fromkeys(r["arm"] for r in paired))
    both = [r for r in rows if r["arm"] == study.BASELINE] + paired
    assert study.scores_table(both, tasks, study.HELDOUT, names) in report
    if trained:
        for task in begun:
            assert study.in_run_table(rows, paired, task) in report
