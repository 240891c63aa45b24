"""Teams (``evolution.teams``, ``evolve --team K``): K trees evolved together, robot i runs tree i mod K."""

from __future__ import annotations

import csv
import json
import random

import pytest
from killed_runs import straight_and_killed

from evolution_manager.errors import ConfigError, EvolutionError
from evolution_manager.evolution.deap_trees import make_primitive_set, tree_from_text, tree_to_text
from evolution_manager.evolution.operators import full_tree, vary
from evolution_manager.evolution.parameters import GPParameters
from evolution_manager.evolution.run_config import evaluation_seed
from evolution_manager.evolution.run_folder import TEAMS, run_kind
from evolution_manager.evolution.teams import (
    TeamConfig,
    TeamRun,
    check_team_size,
    evaluate_teams,
    robot_groups,
    team_layout,
    vary_teams,
)
from evolution_manager.studies.evolve import evolve
from swarm_sim.evaluation import BatchEvaluator, EvaluationRequest
from swarm_sim.evaluation.cli import evaluate_main
from swarm_sim.model import OBJECTIVES, load_layout
from swarm_sim.tasks import task_named

MULTIFOOD = "multifood-arena9-kind2"


def _compared(objective: str, team: int) -> list[str]:
    """Every file of a team run but sessions.json (wall times)."""
    return [
        "config.json",
        "evaluations.csv",
        "progress.csv",
        "checkpoint.json",
        "summary.json",
        f"best/{objective}_swarm.json",
        *(f"best/{objective}_group{g}.txt" for g in range(team)),
    ]


def _files(root, objective="food", team=3):
    return {name: (root / name).read_bytes() for name in _compared(objective, team) if (root / name).exists()}


def _team(out, *extra):
    args = ["--algorithm", "gp", "--objective", "food", "--trials", "1", "--out", str(out)]
    return evolve([*args, "--no-progress", "--checkpoint-every", "0", *extra])


# Sub-groups -------------------------------------------------------------------------------------------------
def test_robot_i_runs_tree_i_mod_k():
    assert robot_groups(9, 1) == (0,) * 9
    assert robot_groups(9, 2) == (0, 1, 0, 1, 0, 1, 0, 1, 0)  # even and odd robots: the authors' two types
    assert robot_groups(9, 3) == (0, 1, 2) * 3
    assert robot_groups(9, 4) == (0, 1, 2, 3, 0, 1, 2, 3, 0)  # K need not divide the robots
    assert robot_groups(9, 9) == tuple(range(9))
    assert team_layout(("a", "b"), 5).trees == ("a", "b", "a", "b", "a")
    assert team_layout(("x",), 3).trees == ("x", "x", "x")
    for bad in (0, -1, 10, True, 2.0):
        with pytest.raises(ConfigError, match="give K from 1 to 9"):
            check_team_size(bad, 9)


def test_a_team_of_one_is_the_homogeneous_evaluation_of_its_tree():
    task = task_named(MULTIFOOD)
    evaluator = BatchEvaluator(task.config("paper"))
    trees = [
        "sel(seq(got_food2, sel(seq(nest_left, forward_left), seq(nest_right, forward_right), forward)), "
        "sel(seq(food_left2, forward_left), seq(food_right2, forward_right), forward))",
        "prob(forward, forward_left, forward_right)",
    ]
    n = task.config().n_robots
    alone = evaluator.evaluate([EvaluationRequest(t, 17, 1) for t in trees])
    as_teams = evaluate_teams(evaluator, [(t,) for t in trees], n, [17, 17], 1)
    copies = evaluate_teams(evaluator, [(t, t, t) for t in trees], n, [17, 17], 1)  # K = 3, one tree
    for result, team, three in zip(alone, as_teams, copies, strict=True):
        assert result.ok and team[2] == ""
        assert team[0] == result.fitness and team[1] == result.descriptors
        assert three[:2] == team[:2]
    k = OBJECTIVES.index("foraging2")
    assert alone[0].fitness[k] > 0  # the forager of kind 2 delivers: the comparison is not of zeros
    # a mixed team is a swarm of both trees, not one of them
    [mixed] = evaluate_teams(evaluator, [tuple(trees)], n, [17], 1)
    assert mixed[1] not in [r.descriptors for r in alone]


# Variation --------------------------------------------------------------------------------------------------
def _random_teams(pset, rng, count, k):
    return [tuple(tree_to_text(full_tree(pset, rng, 1, 4)) for _ in range(k)) for _ in range(count)]


@pytest.mark.parametrize("k", [1, 2, 3, 9])
def test_each_variation_changes_only_the_sub_group_it_names(k):
    pset = make_primitive_set()
    rng = random.Random(11)
    parameters = GPParameters()
    seen, touched = set(), 0
    for _ in range(20):
        parents = _random_teams(pset, rng, 7, k)  # odd: the last parent is varied alone
        children = vary_teams(parents, pset, rng, parameters)
        assert len(children) == len(parents)
        for start in range(0, len(parents), 2):
            pair = children[start : start + 2]
            assert len({c.group for c in pair}) == 1  # a pair varies one sub-group, the same in both
        for parent, child in zip(parents, children, strict=True):
            assert 0 <= child.group < k
            seen.add(child.group)
            assert len(child.texts) == k
            for g in range(k):
                if g != child.group:
                    assert child.texts[g] == parent[g]
            if not child.touched:
                assert child.texts == parent
            touched += child.touched
    assert seen == set(range(k))  # every sub-group is drawn
    assert touched > 0


def test_a_sub_groups_trees_are_varied_by_the_tree_gps_operators():
    """The varied sub-group's trees are what ``operators.vary`` makes of the pair's trees, from the same
    generator state after the sub-group's draw."""
    pset = make_primitive_set()
    parameters = GPParameters()
    parents = _random_teams(pset, random.Random(3), 6, 3)
    rng = random.Random(5)
    children = vary_teams(parents, pset, rng, parameters)
    again = random.Random(5)
    p = parameters
    for start in range(0, 6, 2):
        group = again.randrange(3)
        trees = [tree_from_text(parents[i][group], pset) for i in (start, start + 1)]
        for tree in trees:
            tree.fitness.values = (0.0,) * len(OBJECTIVES)
        varied = vary(trees, pset, again, p.crossover, p.mutations, p.max_height, p.max_nodes)
        for i, tree in zip((start, start + 1), varied, strict=True):
            assert children[i].group == group
            assert children[i].texts[group] == tree_to_text(tree)
    assert rng.getstate() == again.getstate()


def test_teams_of_different_sizes_are_refused():
    pset = make_primitive_set()
    with pytest.raises(ValueError, match="teams of one size"):
        vary_teams([("forward",), ("forward", "stop")], pset, random.Random(0), GPParameters())


# Runs -------------------------------------------------------------------------------------------------------
def test_same_seed_same_files_and_the_best_swarm_loads(tmp_path, capsys):
    assert _team(tmp_path / "a", "--team", "3", "--evaluations", "50", "--seed", "3") == 0
    assert _team(tmp_path / "b", "--team", "3", "--evaluations", "50", "--seed", "3") == 0
    assert _team(tmp_path / "c", "--team", "3", "--evaluations", "50", "--seed", "4") == 0
    a, b, c = (_files(tmp_path / n) for n in "abc")
    assert a == b and len(a) == 9
    assert a["evaluations.csv"] != c["evaluations.csv"]
    assert run_kind(tmp_path / "a") == TEAMS
    summary = json.loads(a["summary.json"])
    config = summary["config"]
    assert config["kind"] == TEAMS and config["team"] == 3 and config["gp"]["population"] == 25
    assert summary["individuals_produced"] == 50 and summary["generations"] == 3
    assert summary["robot_groups"] == [0, 1, 2] * 3
    rows = list(csv.DictReader((tmp_path / "a" / "evaluations.csv").open()))
    assert len(rows) == summary["evaluations"] and summary["evaluations"] <= 25 + 50
    assert all(int(r["seed"]) == config["scenario_seed"] for r in rows)
    assert [r["group"] for r in rows[:25]] == [""] * 25 and all(r["group"] in "012" for r in rows[25:])
    assert summary["best_fitness"] == max(float(r["fitness"]) for r in rows)
    best = summary["best"]
    assert len(best["trees"]) == 3 and len(summary["heldout"]["seeds"]) == 5
    assert summary["heldout_best_fitness"] == summary["heldout_objectives"]["food"]
    layout = load_layout(tmp_path / "a" / "best" / "food_swarm.json", 9)
    assert list(layout.trees) == [best["trees"][i % 3] for i in range(9)]
    for g, tree in enumerate(best["trees"]):
        assert (tmp_path / "a" / "best" / f"food_group{g}.txt").read_text() == tree + "\n"
    capsys.readouterr()
    swarm = str(tmp_path / "a" / "best" / "food_swarm.json")
    seed = str(config["scenario_seed"])
    assert evaluate_main(["--swarm", swarm, "--seed", seed, "--trials", "1"]) == 0
    evaluated = json.loads(capsys.readouterr().out)
    assert evaluated["fitness"]["food"] == summary["best_fitness"]
    assert list(evaluated["descriptors"].values()) == best["descriptors"]
    # the validated choice: the best distinct teams by their first fitness, the highest validation mean
    first = {}
    for r in rows:
        first.setdefault(tuple(json.loads(r["trees"])), float(r["fitness"]))
    ranked = sorted(first.items(), key=lambda item: -item[1])
    validated = summary["validated"]
    assert [(tuple(c["trees"]), c["fitness"]) for c in validated["candidates"]] == ranked[:10]
    means = [c["validation_fitness"] for c in validated["candidates"]]
    assert validated["validation_fitness"] == max(means)
    assert validated["trees"] == validated["candidates"][means.index(max(means))]["trees"]
    assert not set(summary["validation"]["seeds"]) & set(summary["heldout"]["seeds"])
    chosen = team_layout(tuple(validated["trees"]), 9)
    for seeds, key in (
        (summary["validation"]["seeds"], "validation_fitness"),
        (summary["heldout"]["seeds"], "heldout_best_fitness"),
    ):
        scores = []
        for s in seeds:
            capsys.readouterr()
            layout_file = tmp_path / "validated_swarm.json"
            layout_file.write_text(json.dumps(chosen.as_json()))
            assert evaluate_main(["--swarm", str(layout_file), "--seed", str(s), "--trials", "1"]) == 0
            scores.append(json.loads(capsys.readouterr().out)["fitness"]["food"])
        assert validated[key] == pytest.approx(sum(scores) / len(scores), abs=1e-12)


def test_the_best_swarm_animates(tmp_path):
    from evolution_manager.viewing.animate import main as animate

    assert _team(tmp_path / "run", "--team", "2", "--evaluations", "5") == 0
    swarm = tmp_path / "run" / "best" / "food_swarm.json"
    assert animate(["--swarm", str(swarm), "--seed", "1", "--out", str(tmp_path / "best.gif")]) == 0
    assert (tmp_path / "best.gif").stat().st_size > 0


def test_a_run_stopped_and_resumed_ends_identical(tmp_path):
    assert _team(tmp_path / "straight", "--team", "3", "--evaluations", "100", "--seed", "5") == 0
    config = TeamConfig.from_json(json.loads((tmp_path / "straight" / "config.json").read_text()))
    evaluator = BatchEvaluator(config.world())
    stopped = TeamRun.start(config, tmp_path / "stopped", evaluator)
    for stop in (20, 40, 60):
        stopped.execute(checkpoint_interval=1e9, stop_after=stop)
        with open(tmp_path / "stopped" / "evaluations.csv", "a") as log:  # rows after the last checkpoint
            log.write("999,1,2,garbage\n")
        assert stopped.lock is not None
        stopped.lock.release()
        stopped = TeamRun.resume(tmp_path / "stopped", evaluator)
    assert 0 < stopped.produced < 100
    stopped.execute(checkpoint_interval=0)
    stopped.write_results()
    files = _files(tmp_path / "straight")
    assert _files(tmp_path / "stopped") == files and len(files) == 9


def test_a_killed_run_resumes_to_the_same_files(tmp_path):
    argv = ["--algorithm", "gp", "--objective", "food", "--trials", "1"]
    argv += ["--team", "2", "--evaluations", "800", "--seed", "6"]
    straight, killed = straight_and_killed(argv, tmp_path, rows=4)
    assert _files(killed, team=2) == _files(straight, team=2)


def test_an_experiment_runs_a_planned_team_run_to_the_files_of_evolve(tmp_path):
    from evolution_manager.studies.experiment import finished, produced_so_far, run_one

    assert _team(tmp_path / "evolved", "--team", "2", "--evaluations", "30", "--seed", "8") == 0
    config = TeamConfig.make(2, "food", 30, 8, trials=1)
    assert config.to_json() == json.loads((tmp_path / "evolved" / "config.json").read_text())
    assert produced_so_far(tmp_path / "planned", 30) == 0
    assert run_one(config.to_json(), str(tmp_path / "planned"), checkpoint_interval=0) == str(
        tmp_path / "planned"
    )
    assert finished(tmp_path / "planned") and produced_so_far(tmp_path / "planned", 30) == 30
    files = _files(tmp_path / "evolved", team=2)
    assert _files(tmp_path / "planned", team=2) == files and len(files) == 8
    other = TeamConfig.make(3, "food", 30, 8, trials=1)
    (
        tmp_path / "planned" / "summary.json"
    ).unlink()  # unfinished: it would be continued, but it is not the plan
    with pytest.raises(EvolutionError, match="another configuration"):
        run_one(other.to_json(), str(tmp_path / "planned"))


def test_fresh_scenarios_give_each_evaluated_team_a_scenario_of_its_own(tmp_path, capsys):
    """--scenarios fresh: evaluation i on evaluation_seed(seed, i), nothing answered from memory; recorded in
    config.json (a fixed run's file stays without the key); held-out and validation scenarios shared with a
    fixed run of the same scenario seed; a resume with the other design refused in one line."""
    extra = ["--team", "2", "--evaluations", "50", "--seed", "3"]
    assert _team(tmp_path / "a", *extra, "--scenarios", "fresh") == 0
    assert _team(tmp_path / "b", *extra, "--scenarios", "fresh") == 0
    assert _team(tmp_path / "fixed", *extra) == 0
    assert _files(tmp_path / "a", team=2) == _files(tmp_path / "b", team=2)
    config = json.loads((tmp_path / "a" / "config.json").read_text())
    assert config["scenarios"] == "fresh"
    assert "scenarios" not in json.loads((tmp_path / "fixed" / "config.json").read_text())
    rows = list(csv.DictReader((tmp_path / "a" / "evaluations.csv").open()))
    assert [int(r["seed"]) for r in rows] == [evaluation_seed(3, i) for i in range(len(rows))]
    # a row's fitness is its team's on its own scenario, even for a team evaluated before on another
    evaluator = BatchEvaluator(TeamConfig.from_json(config).world())
    k = OBJECTIVES.index("food")
    for row in (rows[0], rows[-1]):
        [(fitness, _, _)] = evaluate_teams(
            evaluator, [tuple(json.loads(row["trees"]))], 9, [int(row["seed"])], 1
        )
        assert fitness is not None and fitness[k] == float(row["fitness"])
    summary = json.loads((tmp_path / "a" / "summary.json").read_text())
    fixed = json.loads((tmp_path / "fixed" / "summary.json").read_text())
    assert summary["heldout"] == fixed["heldout"] and summary["validation"] == fixed["validation"]
    capsys.readouterr()
    resume = ["--out", str(tmp_path / "a"), "--resume", "--scenarios", "fixed", "--no-progress"]
    assert evolve(resume) == 2
    error = capsys.readouterr().err
    assert "--scenarios fixed differs from the run being resumed (fresh)" in error and error.count("\n") == 1


START = "sel(seq(in_nest, stop), forward)"
OTHER = "sel(seq(on_food, stop), forward_left)"


def test_a_start_tree_is_every_sub_groups_tree_of_the_first_generation(tmp_path):
    """--start-tree: the 25 initial teams are the start tree's homogeneous swarm, then each child of the first
    generation differs from it in the one sub-group it was varied in; the tree read from a file gives the
    same run; config.json keeps its canonical text; without it the first teams are random."""
    extra = ["--team", "3", "--evaluations", "50", "--seed", "3"]
    assert _team(tmp_path / "text", *extra, "--start-tree", START) == 0
    (tmp_path / "start.txt").write_text(START + "\n")
    assert _team(tmp_path / "file", *extra, "--start-tree", str(tmp_path / "start.txt")) == 0
    assert _files(tmp_path / "text") == _files(tmp_path / "file")
    config = json.loads((tmp_path / "text" / "config.json").read_text())
    assert config["start_tree"] == START
    rows = list(csv.DictReader((tmp_path / "text" / "evaluations.csv").open()))
    first = [r for r in rows if r["group"] == ""]
    assert len(first) == 25 and all(json.loads(r["trees"]) == [START] * 3 for r in first)
    progress = list(csv.DictReader((tmp_path / "text" / "progress.csv").open()))
    children = rows[25 : int(progress[1]["evaluations"])]  # the first generation varied (progress row 2)
    assert children and all(r["group"] != "" for r in children)
    for row in children:
        trees, group = json.loads(row["trees"]), int(row["group"])
        assert [t for g, t in enumerate(trees) if g != group] == [START, START]
    assert any(json.loads(r["trees"])[int(r["group"])] != START for r in children)
    assert _team(tmp_path / "random", *extra) == 0
    assert "start_tree" not in json.loads((tmp_path / "random" / "config.json").read_text())
    random_rows = list(csv.DictReader((tmp_path / "random" / "evaluations.csv").open()))
    assert all(json.loads(r["trees"]) != [START] * 3 for r in random_rows[:25])


def test_k_start_trees_start_sub_group_g_from_the_g_th(tmp_path, capsys):
    """--start-tree K times: every initial team runs the g-th tree in sub-group g; each child of the first
    generation keeps the others' trees; config.json lists them in order; --resume takes the same list and
    refuses another order."""
    extra = ["--team", "2", "--evaluations", "25", "--seed", "4"]
    assert _team(tmp_path / "run", *extra, "--start-tree", START, "--start-tree", OTHER) == 0
    assert json.loads((tmp_path / "run" / "config.json").read_text())["start_tree"] == [START, OTHER]
    rows = list(csv.DictReader((tmp_path / "run" / "evaluations.csv").open()))
    assert all(json.loads(r["trees"]) == [START, OTHER] for r in rows[:25])
    for row in rows[25:]:
        trees, group = json.loads(row["trees"]), int(row["group"])
        assert trees[1 - group] == [START, OTHER][1 - group]
    capsys.readouterr()
    resume = ["--out", str(tmp_path / "run"), "--resume", "--no-progress"]
    assert evolve([*resume, "--start-tree", OTHER, "--start-tree", START]) == 2
    error = capsys.readouterr().err
    assert "--start-tree differs from the run being resumed" in error and error.count("\n") == 1
    assert evolve([*resume, "--start-tree", START, "--start-tree", OTHER]) == 0


@pytest.mark.parametrize(
    ("extra", "words"),
    [
        (["--team", "3", "--start-tree", "sel(food_left1, forward)"], "the start tree is not a tree of task"),
        (["--team", "3", "--start-tree", "sel(forward"], "the start tree is not a tree of task"),
        (["--team", "3", "--start-tree", " "], "--start-tree: expected a tree"),
        (["--start-tree", START], "--start-tree seeds the teams of a team run: it goes with --team K"),
        (
            ["--team", "3", "--start-tree", START, "--start-tree", OTHER],
            "2 start trees for a team of 3; expected one (every sub-group starts from it) or 3",
        ),
        (
            ["--team", "2", "--start-tree", START, "--start-tree", "sel(food_left1, forward)"],
            "start tree 2 is not a tree of task",
        ),
    ],
)
def test_a_bad_start_tree_exits_2_with_one_line(tmp_path, capsys, extra, words):
    assert _team(tmp_path / "out", *extra) == 2
    error = capsys.readouterr().err
    assert words in error and error.count("\n") == 1 and "Traceback" not in error
    assert not (tmp_path / "out").exists()


def test_resume_refuses_another_start_tree_and_takes_the_same_one(tmp_path, capsys):
    assert _team(tmp_path / "run", "--team", "2", "--evaluations", "5", "--start-tree", START) == 0
    capsys.readouterr()
    resume = ["--out", str(tmp_path / "run"), "--resume", "--no-progress", "--start-tree"]
    assert evolve([*resume, "sel(seq(in_nest, stop), reverse)"]) == 2
    error = capsys.readouterr().err
    assert "--start-tree differs from the run being resumed" in error and error.count("\n") == 1
    assert evolve([*resume, START]) == 0


# Refusals ---------------------------------------------------------------------------------------------------
@pytest.mark.parametrize(
    ("extra", "words"),
    [
        (["--team", "0"], "--team 0: a team is 1 to 9 sub-groups"),
        (["--team", "-2"], "--team -2: a team is 1 to 9 sub-groups"),
        (["--team", "10"], "give K from 1 to 9"),
        (["--team", "2", "--algorithm", "qd"], "with --algorithm gp, not qd"),
        (["--team", "2", "--algorithm", "gp-fnd"], "with --algorithm gp, not gp-fnd"),
        (["--team", "2", "--swarm-from", "runs/x"], "--swarm-from does not apply to a team run"),
        (["--team", "2", "--nodes", "hierarchical"], "--nodes does not apply"),
        (["--team", "2", "--algorithm", "gp", "--objective", None], "--team needs --objective"),
    ],
)  # fmt: skip
def test_bad_team_options_exit_2_with_one_line(tmp_path, capsys, extra, words):
    argv = ["--algorithm", "gp", "--objective", "food", "--out", str(tmp_path / "out"), "--no-progress"]
    for i in range(0, len(extra), 2):
        if extra[i] in argv:
            at = argv.index(extra[i])
            del argv[at : at + 2]
        if extra[i + 1] is not None:
            argv += extra[i : i + 2]
    capsys.readouterr()
    assert evolve(argv) == 2
    error = capsys.readouterr().err
    assert words in error and error.count("\n") == 1 and "Traceback" not in error
    assert not (tmp_path / "out").exists()


def test_resume_of_a_team_run_refuses_another_team(tmp_path, capsys):
    assert _team(tmp_path / "run", "--team", "2", "--evaluations", "5") == 0
    for extra, words in (
        (["--team", "3"], "--team 3 differs from the run being resumed (2)"),
        (["--objective", "nest"], "--objective nest differs"),
        (["--task", MULTIFOOD], f"--task {MULTIFOOD} differs"),
    ):
        capsys.readouterr()
        assert evolve(["--out", str(tmp_path / "run"), "--resume", "--no-progress", *extra]) == 2
        error = capsys.readouterr().err
        assert words in error and error.count("\n") == 1


@pytest.mark.parametrize(
    ("damage", "words"),
    [
        (lambda state: state["population"][0]["trees"].pop(), "a team of 1 trees in a run of 2"),
        (lambda state: state["elites"][0]["trees"].__setitem__(0, "sel(forward"), "not a behaviour tree"),
        (lambda state: state.__setitem__("produced", -3), "produced"),
        (lambda state: state.pop("generation"), "generation"),
    ],
)
def test_a_damaged_checkpoint_is_refused_in_one_line(tmp_path, capsys, damage, words):
    assert _team(tmp_path / "run", "--team", "2", "--evaluations", "5") == 0
    (tmp_path / "run" / "summary.json").unlink()
    path = tmp_path / "run" / "checkpoint.json"
    state = json.loads(path.read_text())
    damage(state)
    path.write_text(json.dumps(state))
    before = (tmp_path / "run" / "evaluations.csv").read_bytes()
    capsys.readouterr()
    assert evolve(["--out", str(tmp_path / "run"), "--resume", "--no-progress"]) == 2
    error = capsys.readouterr().err
    assert "is damaged" in error and words in error and error.count("\n") == 1
    assert (tmp_path / "run" / "evaluations.csv").read_bytes() == before


def test_a_team_configuration_round_trips_and_takes_the_tasks_derating():
    config = TeamConfig.make(2, "foraging_biased", 200, 1, task=MULTIFOOD)
    assert TeamConfig.from_json(json.loads(json.dumps(config.to_json()))) == config
    assert config.gp.derating == "baseline" and config.label == "GP_team2_foraging_biased"
    assert TeamConfig.make(2, "food", 200, 1).gp.derating == "standard"
    fresh = TeamConfig.make(2, "food", 200, 1, scenarios="fresh")
    assert TeamConfig.from_json(json.loads(json.dumps(fresh.to_json()))) == fresh
    started = TeamConfig.make(2, "food", 200, 1, start_trees=[START])
    assert TeamConfig.from_json(json.loads(json.dumps(started.to_json()))) == started
    assert started.to_json()["start_tree"] == START  # one tree: its text, as the runs before K trees wrote it
    each = TeamConfig.make(2, "food", 200, 1, start_trees=[START, OTHER])
    assert each.to_json()["start_tree"] == [START, OTHER] and each.start_team() == (START, OTHER)
    assert TeamConfig.from_json(json.loads(json.dumps(each.to_json()))) == each
    assert started.start_team() == (START, START) and config.start_team() is None
    with pytest.raises(ConfigError, match="start_tree must be a tree text or a list of them, got 3"):
        TeamConfig.from_json({**each.to_json(), "start_tree": 3})
    assert (
        "start_tree" not in config.to_json()
    )  # the configuration files of runs without one stay as they were
    with pytest.raises(ConfigError, match="scenarios must be one of fixed, fresh, got 'new'"):
        TeamConfig.make(2, "food", 200, 1, scenarios="new")
    with pytest.raises(ConfigError, match="not a team run's configuration"):
        TeamConfig.from_json({**config.to_json(), "kind": "networks"})
