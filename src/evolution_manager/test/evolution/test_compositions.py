"""Compositions (``evolution.compositions``, ``evolve --swarm-from``): a repertoire cell per robot, evolved by
a GA or MAP-Elites on foraging, with the real simulator; the source repertoire is a tiny MAP-Elites run."""

from __future__ import annotations

import csv
import json
import random

import pytest
from killed_runs import straight_and_killed

from evolution_manager.errors import ConfigError
from evolution_manager.evolution.compositions import (
    ALGORITHMS,
    Cell,
    CompositionConfig,
    CompositionParameters,
    CompositionRun,
    bin_of,
    check_distinct_sources,
    evaluate_genomes,
    mutate,
    read_sources,
    two_point_crossover,
    vary,
)
from evolution_manager.evolution.parameters import GPParameters
from evolution_manager.evolution.run_config import evaluation_seed
from evolution_manager.studies.evolve import COMPOSITION_ALGORITHMS, evolve
from evolution_manager.studies.experiment import produced_so_far
from swarm_sim.evaluation import BatchEvaluator, EvaluationRequest
from swarm_sim.evaluation.cli import evaluate_main
from swarm_sim.model import OBJECTIVES, load_layout
from swarm_sim.tasks import FORAGING

COMPARED = [
    "config.json",
    "cells.json",
    "evaluations.csv",
    "progress.csv",
    "checkpoint.json",
    "summary.json",
    "repertoire_compositions.json",
    *(f"best/foraging_robot{i}.txt" for i in range(9)),
    "best/foraging_swarm.json",
]
"""Every file of a composition run but sessions.json (wall times)."""


def _files(root):
    return {name: (root / name).read_bytes() for name in COMPARED if (root / name).exists()}


@pytest.fixture(scope="module")
def source(tmp_path_factory):
    """A tiny MAP-Elites run on food (its repertoires: density, nest, food)."""
    out = tmp_path_factory.mktemp("source") / "qd-food"
    args = ["--algorithm", "qd", "--objective", "food", "--evaluations", "30", "--trials", "1"]
    assert evolve([*args, "--out", str(out), "--no-figures", "--no-progress"]) == 0
    return out


def _compose(source, out, algorithm, *extra):
    args = ["--task", "foraging", "--swarm-from", str(source), "--algorithm", algorithm, "--trials", "1"]
    return evolve([*args, "--out", str(out), "--no-progress", "--checkpoint-every", "0", *extra])


# Cells and genome operators --------------------------------------------------------------------------------
def test_cells_are_every_filled_bins_best_tree_in_a_fixed_order(source):
    cells = read_sources([source])[0]
    expected = []
    for objective in OBJECTIVES:  # objectives in OBJECTIVES order, bins in index order
        path = source / f"repertoire_{objective}.json"
        if not path.exists():
            continue
        best = {}
        for item in json.loads(path.read_text())["items"]:
            key = tuple(item["bin"])
            if key not in best or item["fitness"] > best[key][0]:
                best[key] = (item["fitness"], item["tree"])
        expected += [(objective, key, *best[key]) for key in sorted(best)]
    assert [(c.objective, c.bin, c.fitness, c.tree) for c in cells] == expected
    assert {c.objective for c in cells} == {"density", "nest", "food"}
    # two directories: the first's cells, then the second's
    assert read_sources([source, source])[0] == cells + cells


def test_two_point_crossover_keeps_every_cell_at_its_position():
    rng = random.Random(3)
    segments = set()
    for _ in range(300):
        a = tuple(rng.randrange(100) for _ in range(9))
        b = tuple(100 + rng.randrange(100) for _ in range(9))  # no cell of a is a cell of b
        c, d = two_point_crossover(a, b, rng)
        assert all(c[i] in (a[i], b[i]) and {c[i], d[i]} == {a[i], b[i]} for i in range(9))
        swapped = [i for i in range(9) if c[i] == b[i]]
        assert swapped and swapped == list(range(swapped[0], swapped[-1] + 1))  # one inner segment
        assert swapped[0] > 0 and swapped[-1] < 8
        segments.add((swapped[0], swapped[-1]))
    assert len(segments) > 20  # cut points vary


def test_mutation_changes_exactly_one_cell():
    rng = random.Random(4)
    positions = set()
    for n_cells in (2, 3, 50):
        for _ in range(200):
            genome = tuple(rng.randrange(n_cells) for _ in range(9))
            child = mutate(genome, rng, n_cells)
            changed = [i for i in range(9) if child[i] != genome[i]]
            assert len(changed) == 1 and 0 <= child[changed[0]] < n_cells
            positions.add(changed[0])
    assert positions == set(range(9))
    assert mutate((0,) * 9, rng, 1) == (0,) * 9  # one cell: nothing else to draw


def test_variation_is_seeded_and_keeps_the_batch_size():
    parents = [tuple(range(k, k + 9)) for k in range(24)]
    first = vary(parents, random.Random(5), 0.8, 0.5, 40)
    assert first == vary(parents, random.Random(5), 0.8, 0.5, 40) and len(first) == 24
    assert first != parents
    assert vary(parents, random.Random(5), 0.0, 0.0, 40) == parents


def test_the_ga_takes_the_2023_gps_parameters():
    p = CompositionConfig("ga", 10, 0, cells=1).parameters
    gp = GPParameters()
    assert (p.population, p.tournament, p.elites, p.crossover) == (25, 3, 1, 0.8)
    assert (p.population, p.tournament, p.elites, p.crossover) == (
        gp.population,
        gp.tournament,
        gp.elites_per_objective,
        gp.crossover,
    )


def test_nine_copies_of_one_cell_score_exactly_the_homogeneous_tree(source):
    cells = read_sources([source])[0]
    evaluator = BatchEvaluator(FORAGING.config("paper"))
    k = OBJECTIVES.index("foraging")
    picked = [0, len(cells) // 2, len(cells) - 1]
    members = evaluate_genomes(evaluator, cells, [(i,) * 9 for i in picked], 17, 2, 0)
    alone = evaluator.evaluate([EvaluationRequest(cells[i].tree, 17, 2) for i in picked])
    for member, result in zip(members, alone, strict=True):
        assert result.ok
        assert member.fitness == result.fitness[k] and member.descriptors == result.descriptors
    # a mixed composition is evaluated too (and is not simply one of its trees)
    [mixed] = evaluate_genomes(evaluator, cells, [tuple(picked * 3)], 17, 2, 0)
    assert mixed.fitness is not None and mixed.descriptors not in [r.descriptors for r in alone]


# Runs ------------------------------------------------------------------------------------------------------
@pytest.mark.parametrize("algorithm", ["ga", "qd"])
def test_same_seed_same_files_and_the_best_swarm_loads(source, tmp_path, capsys, algorithm):
    assert _compose(source, tmp_path / "a", algorithm, "--evaluations", "30", "--seed", "3") == 0
    assert _compose(source, tmp_path / "b", algorithm, "--evaluations", "30", "--seed", "3") == 0
    assert _compose(source, tmp_path / "c", algorithm, "--evaluations", "30", "--seed", "4") == 0
    a, b, c = (_files(tmp_path / n) for n in "abc")
    assert a == b
    assert a["evaluations.csv"] != c["evaluations.csv"]
    assert ("repertoire_compositions.json" in a) == (algorithm == "qd")
    summary = json.loads(a["summary.json"])
    config = summary["config"]
    initial = 25 if algorithm == "ga" else 100
    assert summary["evaluations"] == initial + 30 and summary["individuals_produced"] == 30
    rows = list(csv.DictReader((tmp_path / "a" / "evaluations.csv").open()))
    assert len(rows) == initial + 30 and all(int(r["seed"]) == config["scenario_seed"] for r in rows)
    assert summary["best_fitness"] == max(float(r["foraging"]) for r in rows)
    # the best composition: its layout file, its nine trees and the cells it names
    cells = read_sources([source])[0]
    best = summary["best"]
    layout = load_layout(tmp_path / "a" / "best" / "foraging_swarm.json", 9)
    assert list(layout.trees) == best["trees"] == [cells[k].tree for k in best["genome"]]
    assert [c["tree"] for c in best["cells"]] == best["trees"]
    for i, tree in enumerate(best["trees"]):
        assert (tmp_path / "a" / "best" / f"foraging_robot{i}.txt").read_text() == tree + "\n"
    capsys.readouterr()
    swarm = str(tmp_path / "a" / "best" / "foraging_swarm.json")
    seed = str(config["scenario_seed"])
    assert evaluate_main(["--swarm", swarm, "--task", "foraging", "--seed", seed, "--trials", "1"]) == 0
    evaluated = json.loads(capsys.readouterr().out)
    assert evaluated["fitness"]["foraging"] == summary["best_fitness"]
    assert list(evaluated["descriptors"].values()) == best["descriptors"]
    _check_validated(summary, rows, cells)
    if algorithm == "qd":  # the grid: one composition per bin, the bin its descriptors', the fittest there
        repertoire = json.loads(a["repertoire_compositions.json"])
        fittest = {}
        for r in rows:
            key = bin_of([float(r[d]) for d in ("movement", "rotation", "conditionality")])
            fittest[key] = max(fittest.get(key, -1.0), float(r["foraging"]))
        assert {tuple(i["bin"]): i["fitness"] for i in repertoire["items"]} == fittest
        assert all(tuple(i["bin"]) == bin_of(i["descriptors"]) for i in repertoire["items"])


def _check_validated(summary, rows, cells):
    """The validated choice: the run's best distinct genomes by their first fitness, the one of highest mean
    on the validation scenarios (re-scored here), its held-out score on the held-out scenarios; the
    homogeneous baseline chosen alike among the cells' nine copies."""
    validation = summary["validation"]
    assert validation["evaluations"] == 5 and validation["candidates"] == 10 and validation["trials"] == 1
    assert not set(validation["seeds"]) & set(summary["heldout"]["seeds"])
    first = {}
    for r in rows:
        first.setdefault(tuple(int(c) for c in r["genome"].split()), float(r["foraging"]))
    ranked = sorted(first.items(), key=lambda item: -item[1])  # stable: the earlier among equals
    validated = summary["validated"]
    candidates = validated["candidates"]
    assert [(tuple(c["genome"]), c["fitness"]) for c in candidates] == ranked[:10]
    means = [c["validation_fitness"] for c in candidates]
    assert validated["validation_fitness"] == max(means)
    assert validated["genome"] == candidates[means.index(max(means))]["genome"]
    assert validated["trees"] == [cells[k].tree for k in validated["genome"]]
    evaluator = BatchEvaluator(FORAGING.config("paper"))
    genome = tuple(validated["genome"])
    for seeds, key in (
        (validation["seeds"], "validation_fitness"),
        (summary["heldout"]["seeds"], "heldout_best_fitness"),
    ):
        again = evaluate_genomes(evaluator, cells, [genome] * len(seeds), 0, 1, 0, seeds)
        assert validated[key] == pytest.approx(sum(m.fitness for m in again) / len(again), abs=1e-12)
    homogeneous = summary["homogeneous"]["validated"]
    assert len(homogeneous["candidates"]) == min(10, len(cells))
    assert all(len(set(c["genome"])) == 1 for c in homogeneous["candidates"])
    assert (
        homogeneous["cell"] == homogeneous["genome"][0]
        and homogeneous["tree"] == cells[homogeneous["cell"]].tree
    )


@pytest.mark.parametrize(
    ("algorithm", "scenarios"), [("ga", "fixed"), ("qd", "fixed"), ("ga", "fresh"), ("ascent", "fixed")]
)
def test_a_run_stopped_and_resumed_ends_identical(source, tmp_path, algorithm, scenarios):
    extra = ["--evaluations", "120", "--seed", "5", "--scenarios", scenarios]
    assert _compose(source, tmp_path / "straight", algorithm, *extra) == 0
    cells = read_sources([source])[0]
    straight = json.loads((tmp_path / "straight" / "config.json").read_text())
    config = CompositionConfig.from_json(straight)
    evaluator = BatchEvaluator(config.world())
    stopped = CompositionRun.start(config, cells, tmp_path / "stopped", evaluator)
    progress: list[int] = []
    for stop in (30, 130, 180):
        stopped.execute(checkpoint_interval=1e9, stop_after=stop)
        # rows written after the last checkpoint (a crash before the next one)
        with open(tmp_path / "stopped" / "evaluations.csv", "a") as log:
            log.write("999,1,garbage\n")
        stopped.lock.release()
        stopped = CompositionRun.resume(tmp_path / "stopped", evaluator)
        # the experiment's progress bar reads a composition's checkpoint too
        progress.append(produced_so_far(tmp_path / "stopped", 120))
        assert progress[-1] == min(120, stopped.produced)
    assert progress[-1] > 0
    stopped.execute(checkpoint_interval=0)
    stopped.write_results()
    files = _files(tmp_path / "straight")
    assert _files(tmp_path / "stopped") == files and len(files) >= 14


@pytest.mark.parametrize("algorithm", ["ga", "qd"])
def test_groups_compose_one_cell_per_group_and_resume_identical(source, tmp_path, capsys, algorithm):
    """--swarm-groups 3: every genome evaluated runs one cell per group (robot i the cell of robot i mod 3),
    the best swarm too; the operators still vary the groups' cells; a stopped run resumes to the same files,
    and a resume with other groups is refused in one line."""
    extra = ["--evaluations", "60", "--seed", "5", "--swarm-groups", "3"]
    assert _compose(source, tmp_path / "straight", algorithm, *extra) == 0
    config = json.loads((tmp_path / "straight" / "config.json").read_text())
    assert config["parameters"]["groups"] == 3
    with open(tmp_path / "straight" / "evaluations.csv") as log:
        genomes = [tuple(int(c) for c in row["genome"].split()) for row in csv.DictReader(log)]
    assert len(genomes) >= 60 and all(g == tuple(g[i % 3] for i in range(9)) for g in genomes)
    assert len({g[:3] for g in genomes}) > 10 and any(len(set(g)) > 1 for g in genomes)
    trees = [(tmp_path / "straight" / f"best/foraging_robot{i}.txt").read_text() for i in range(9)]
    assert all(trees[i] == trees[i % 3] for i in range(9))
    cells = read_sources([source])[0]
    evaluator = BatchEvaluator(CompositionConfig.from_json(config).world())
    stopped = CompositionRun.start(
        CompositionConfig.from_json(config), cells, tmp_path / "stopped", evaluator
    )
    stopped.execute(checkpoint_interval=1e9, stop_after=30)
    stopped.lock.release()
    stopped = CompositionRun.resume(tmp_path / "stopped", evaluator)
    stopped.execute(checkpoint_interval=0)
    stopped.write_results()
    assert _files(tmp_path / "stopped") == _files(tmp_path / "straight")
    capsys.readouterr()
    assert evolve(["--out", str(tmp_path / "straight"), "--resume", "--swarm-groups", "4"]) == 2
    assert "--swarm-groups 4 differs from the run being resumed (3)" in capsys.readouterr().err


def test_ascent_takes_turns_over_the_groups_and_ends_at_best_responses(source, tmp_path):
    """--algorithm ascent --swarm-groups 3: the fittest cell's homogeneous swarm first; then each batch tries
    every other cell for one group, the groups in turn, the incumbent moving to a batch's fittest genome only
    when strictly fitter; given budget enough, the run ends early at a genome where no one group's change is
    fitter (each group's cell a best response), which is the best genome evaluated."""
    assert _compose(source, tmp_path / "a", "ascent", "--evaluations", "5000", "--seed", "2",
                    "--swarm-groups", "3") == 0  # fmt: skip
    cells = read_sources([source])[0]
    n = len(cells)
    rows = list(csv.DictReader((tmp_path / "a" / "evaluations.csv").open()))
    genomes = [tuple(int(c) for c in r["genome"].split()) for r in rows]
    fitness = {g: float(r["foraging"]) for g, r in zip(genomes, rows, strict=True)}
    fittest_cell = min(range(n), key=lambda c: (-cells[c].fitness, c))
    assert genomes[0] == (fittest_cell,) * 9
    summary = json.loads((tmp_path / "a" / "summary.json").read_text())
    assert summary["finished"] and summary["individuals_produced"] == len(rows) - 1 < 5000
    # batches of n - 1 genomes, group 0, 1, 2, 0, ... each varying one group of the incumbent
    incumbent = genomes[0]
    turns = 0
    for start in range(1, len(genomes), n - 1):
        batch = genomes[start : start + n - 1]
        group = turns % 3
        assert len(batch) == n - 1 and all(g == tuple(g[i % 3] for i in range(9)) for g in batch)
        assert {g[group] for g in batch} == set(range(n)) - {incumbent[group]}
        kept = [k for k in range(3) if k != group]
        assert all([g[k] for k in kept] == [incumbent[k] for k in kept] for g in batch)
        challenger = max(batch, key=lambda g: fitness[g])
        if fitness[challenger] > fitness[incumbent]:
            incumbent = challenger
        turns += 1
    assert turns >= 3 and summary["best"]["genome"] == list(incumbent)
    assert summary["best_fitness"] == fitness[incumbent] == max(fitness.values())
    # a best response for every group: every one-group change of the final genome was tried and no fitter
    for group in range(3):
        for cell in range(n):
            roles = list(incumbent[:3])
            roles[group] = cell
            neighbour = tuple(roles[i % 3] for i in range(9))
            assert fitness[neighbour] <= fitness[incumbent]


def test_ascent_stops_at_its_budget(source, tmp_path):
    """A budget smaller than a turn: the one batch cut to it, the run finished with it spent."""
    assert _compose(source, tmp_path / "a", "ascent", "--evaluations", "5", "--seed", "2") == 0
    summary = json.loads((tmp_path / "a" / "summary.json").read_text())
    assert summary["finished"] and summary["evaluations"] == 6 and summary["individuals_produced"] == 5
    rows = list(csv.DictReader((tmp_path / "a" / "evaluations.csv").open()))
    genomes = [tuple(int(c) for c in r["genome"].split()) for r in rows]
    # per robot (no groups): robot 0's turn first, five other cells in an order drawn from the run's seed
    tried = [g[0] for g in genomes[1:]]
    assert all(g[1:] == genomes[0][1:] for g in genomes[1:])
    assert len(set(tried)) == 5 and genomes[0][0] not in tried
    assert _compose(source, tmp_path / "b", "ascent", "--evaluations", "5", "--seed", "3") == 0
    other = list(csv.DictReader((tmp_path / "b" / "evaluations.csv").open()))
    assert [int(r["genome"].split()[0]) for r in other[1:]] != tried


def test_fresh_scenarios_give_each_evaluation_a_scenario_of_its_own(source, tmp_path, capsys):
    """--scenarios fresh: evaluation i on evaluation_seed(seed, i), as a tree run's; recorded in config.json
    (a fixed run's file stays as before, without the key), the same seed the same files, and a resume with
    the other design refused in one line."""
    extra = ["--evaluations", "30", "--seed", "3"]
    assert _compose(source, tmp_path / "a", "qd", *extra, "--scenarios", "fresh") == 0
    assert _compose(source, tmp_path / "b", "qd", *extra, "--scenarios", "fresh") == 0
    assert _compose(source, tmp_path / "fixed", "qd", *extra) == 0
    assert _files(tmp_path / "a") == _files(tmp_path / "b")
    config = json.loads((tmp_path / "a" / "config.json").read_text())
    assert config["scenarios"] == "fresh" and "scenarios" not in json.loads(
        (tmp_path / "fixed" / "config.json").read_text()
    )
    rows = list(csv.DictReader((tmp_path / "a" / "evaluations.csv").open()))
    assert [int(r["seed"]) for r in rows] == [evaluation_seed(3, i) for i in range(len(rows))]
    # a row's fitness is its genome's on its own scenario
    cells = read_sources([source])[0]
    evaluator = BatchEvaluator(FORAGING.config("paper"))
    for row in (rows[0], rows[-1]):
        genome = tuple(int(c) for c in row["genome"].split())
        [member] = evaluate_genomes(evaluator, cells, [genome], int(row["seed"]), 1, 0)
        assert member.fitness == float(row["foraging"])
    # held-out and validation scenarios come from the scenario seed, as a fixed run's: shared by both designs
    summary = json.loads((tmp_path / "a" / "summary.json").read_text())
    fixed = json.loads((tmp_path / "fixed" / "summary.json").read_text())
    assert summary["heldout"] == fixed["heldout"] and summary["validation"] == fixed["validation"]
    assert summary["homogeneous"] == fixed["homogeneous"]
    capsys.readouterr()
    resume = ["--out", str(tmp_path / "a"), "--resume", "--scenarios", "fixed", "--no-progress"]
    assert evolve(resume) == 2
    error = capsys.readouterr().err
    assert "--scenarios fixed differs from the run being resumed (fresh)" in error and error.count("\n") == 1


def test_a_killed_run_resumes_to_the_same_files(source, tmp_path):
    argv = ["--task", "foraging", "--swarm-from", str(source), "--algorithm", "ga"]
    argv += ["--evaluations", "1500", "--seed", "6", "--trials", "2"]
    straight, killed = straight_and_killed(argv, tmp_path, rows=6)
    assert _files(killed) == _files(straight)


def test_evolve_names_the_composition_algorithms_this_module_has():
    """evolve's copy of the algorithms (it loads this module late) is this module's list."""
    assert COMPOSITION_ALGORITHMS == ALGORITHMS


# Refusals --------------------------------------------------------------------------------------------------
_ASCENT = ["--algorithm", "ascent", "--task", "foraging", "--swarm-from", "SOURCE"]


@pytest.mark.parametrize(
    ("extra", "words"),
    [
        (["--algorithm", "qd", "--swarm-from", "SOURCE"], "add --task (foraging"),
        (["--algorithm", "ga", "--task", "foraging"], "give --swarm-from RUN_DIR"),
        (["--algorithm", "ga", "--task", "foraging", "--swarm-from", "EMPTY"], "holds no repertoire"),
        (["--algorithm", "qd", "--task", "foraging", "--swarm-from", "BARE"], "no cell to compose"),
        (["--algorithm", "qd", "--task", "foraging", "--swarm-from", "SOURCE", "--library", "LIB"],
         "--library cannot be combined with --swarm-from"),
        (["--algorithm", "gp", "--task", "foraging", "--swarm-from", "SOURCE"],
         "--algorithm ga, qd or ascent"),
        (["--algorithm", "ga", "--task", "foraging", "--swarm-from", "SOURCE", "--swarm-crossover", "mix"],
         "goes with algorithm qd"),
        (["--algorithm", "qd", "--task", "foraging", "--swarm-from", "SOURCE", "--descriptors", "deliveries"],
         "has one kind of food"),
        (["--algorithm", "ga", "--task", "foraging", "--swarm-from", "SOURCE", "SOURCE"], "is given twice"),
        (["--algorithm", "ga", "--task", "foraging", "--swarm-from", "SOURCE", "--homogeneous", "100000"],
         "--homogeneous 100000: the runs hold"),
        (["--algorithm", "ga", "--task", "foraging", "--swarm-from", "SOURCE", "--scenario-seed", "-1"],
         "--scenario-seed must be in [0, "),
        (["--algorithm", "ga", "--task", "foraging", "--swarm-from", "SOURCE", "--swarm-groups", "1"],
         "one group is a homogeneous swarm"),
        (["--algorithm", "ga", "--task", "foraging", "--swarm-from", "SOURCE", "--swarm-groups", "2"],
         "two-point crossover needs genomes of at least 3 cells"),
        (["--algorithm", "ga", "--task", "foraging", "--swarm-from", "SOURCE", "--swarm-groups", "10"],
         "groups 10: the task has 9 robots"),
        (["--algorithm", "qd", "--objective", "food", "--swarm-groups", "3"],
         "--swarm-groups varies compositions of repertoire cells: it goes with --swarm-from"),
        (["--algorithm", "ascent", "--task", "foraging"], "--algorithm ascent evolves compositions"),
        *(
            ([*_ASCENT, *more], words)
            for more, words in (
                (["--scenarios", "fresh"], "algorithm ascent compares every genome with the incumbent"),
                (["--homogeneous", "2"], "homogeneous 2: algorithm ascent starts from the fittest cell's"),
                (["--swarm-mutation", "all"], "cell_mutation 'all': algorithm ascent"),
            )
        ),
    ],
)  # fmt: skip
def test_bad_composition_options_exit_2_with_one_line(source, tmp_path, capsys, extra, words):
    (tmp_path / "empty").mkdir()
    bare = tmp_path / "bare"
    bare.mkdir()
    empty = json.loads((source / "repertoire_food.json").read_text())
    empty["items"] = []
    (bare / "repertoire_food.json").write_text(json.dumps(empty))
    library = tmp_path / "lib.json"
    library.write_text("{}")
    where = {"SOURCE": source, "EMPTY": tmp_path / "empty", "BARE": bare, "LIB": library}
    argv = [str(where.get(a, a)) for a in extra]
    capsys.readouterr()
    assert evolve([*argv, "--out", str(tmp_path / "out"), "--no-progress"]) == 2
    error = capsys.readouterr().err
    assert words in error and error.count("\n") == 1 and "Traceback" not in error
    assert not (tmp_path / "out").exists()


def test_homogeneous_beyond_the_cells_or_the_initial_population_is_refused(source, tmp_path, capsys):
    """--homogeneous K with K above the cells, or above the GA's population or MAP-Elites' first batch, was
    cut silently; now refused in one line naming the bound, before anything is written."""
    cells = len(read_sources([source])[0])
    parameters = CompositionParameters()
    for algorithm, initial in (("ga", parameters.population), ("qd", parameters.init_batch)):
        bound = min(cells, initial)
        capsys.readouterr()
        assert _compose(source, tmp_path / "out", algorithm, "--homogeneous", str(bound + 1)) == 2
        error = capsys.readouterr().err
        assert f"--homogeneous {bound + 1}:" in error and f"at most {bound}" in error
        assert error.count("\n") == 1 and "Traceback" not in error
        assert not (tmp_path / "out").exists()


def test_a_run_given_twice_to_swarm_from_is_refused(source, tmp_path, capsys):
    (tmp_path / "link").symlink_to(source)
    with pytest.raises(ConfigError, match="given twice"):
        check_distinct_sources([source, tmp_path / "link"])
    capsys.readouterr()
    argv = ["--task", "foraging", "--algorithm", "ga", "--swarm-from", str(source), str(tmp_path / "link")]
    assert evolve([*argv, "--out", str(tmp_path / "out"), "--no-progress"]) == 2
    error = capsys.readouterr().err
    assert "is given twice" in error and error.count("\n") == 1 and not (tmp_path / "out").exists()


def test_resume_of_a_composition_run_refuses_other_options(source, tmp_path, capsys):
    out = tmp_path / "run"
    assert _compose(source, out, "ga", "--evaluations", "10") == 0
    assert [p.name for p in tmp_path.iterdir()] == ["run"]  # built aside, renamed into place
    before = _files(out)
    capsys.readouterr()
    assert evolve(["--out", str(out), "--resume", "--task", "primitives"]) == 2
    assert "--task primitives differs from the run being resumed (foraging)" in capsys.readouterr().err
    assert evolve(["--out", str(out), "--resume", "--objective", "food"]) == 2
    assert "--objective food differs" in capsys.readouterr().err
    assert evolve(["--out", str(out), "--resume", "--swarm-mutation", "axis"]) == 2
    assert "--swarm-mutation axis differs from the run being resumed (one)" in capsys.readouterr().err
    assert evolve(["--out", str(out), "--resume", "--seed", "9"]) == 2
    assert "--seed 9 differs" in capsys.readouterr().err
    assert evolve(["--out", str(out), "--resume", "--swarm-from", str(source)]) == 2
    assert "leave it out with --resume" in capsys.readouterr().err
    assert evolve(["--out", str(out), "--resume", "--homogeneous", "3"]) == 2
    assert "--homogeneous 3 differs from the run being resumed (0)" in capsys.readouterr().err
    assert _compose(source, out, "ga", "--evaluations", "10") == 2
    assert "already holds a run" in capsys.readouterr().err
    assert _files(out) == before
    # a finished run resumed: nothing to do, the same files
    assert evolve(["--out", str(out), "--resume", "--no-progress"]) == 0
    assert _files(out) == before


def test_a_cell_list_is_json_round_trip():
    cell = Cell("runs/a", "food", (1, 2, 3), 0.5, "forward")
    assert Cell.from_json(cell.as_json()) == cell


def test_the_best_swarm_animates(source, tmp_path, capsys):
    from evolution_manager.viewing.animate import main as animate

    assert _compose(source, tmp_path / "run", "ga", "--evaluations", "5") == 0
    swarm = tmp_path / "run" / "best" / "foraging_swarm.json"
    assert animate(["--swarm", str(swarm), "--seed", "1", "--out", str(tmp_path / "best.gif")]) == 0
    assert (tmp_path / "best.gif").stat().st_size > 0


# Homogeneous seeds (beyond the authors' GA) ---------------------------------------------------------------
@pytest.mark.parametrize("algorithm", ["ga", "qd"])
def test_homogeneous_seeds_start_the_run_and_the_best_is_at_least_their_best(source, tmp_path, algorithm):
    """--homogeneous K: the first K genomes are the homogeneous swarms of the K fittest cells, so the best
    composition is at least as good as the best of them; without it the start is the authors' (all random)
    and config.json has no trace of the option."""
    cells = read_sources([source])[0]
    fittest = sorted(range(len(cells)), key=lambda c: (-cells[c].fitness, c))[:3]
    out = tmp_path / "seeded"
    assert _compose(source, out, algorithm, "--evaluations", "30", "--seed", "3", "--homogeneous", "3") == 0
    config = json.loads((out / "config.json").read_text())
    assert config["parameters"]["homogeneous"] == 3
    rows = list(csv.DictReader((out / "evaluations.csv").open()))
    assert [[int(c) for c in row["genome"].split()] for row in rows[:3]] == [[c] * 9 for c in fittest]
    homogeneous_best = max(float(row["foraging"]) for row in rows[:3] if row["foraging"])
    summary = json.loads((out / "summary.json").read_text())
    assert summary["best_fitness"] >= homogeneous_best
    plain = tmp_path / "plain"
    assert _compose(source, plain, algorithm, "--evaluations", "30", "--seed", "3") == 0
    assert "homogeneous" not in json.loads((plain / "config.json").read_text())["parameters"]
    first_plain = [row["genome"] for row in csv.DictReader((plain / "evaluations.csv").open())][:3]
    assert first_plain != [row["genome"] for row in rows[:3]]


def test_homogeneous_seeds_need_compositions(source, tmp_path, capsys):
    args = ["--algorithm", "qd", "--objective", "food", "--evaluations", "5", "--homogeneous", "2"]
    assert evolve([*args, "--out", str(tmp_path / "run"), "--no-progress"]) == 2
    assert "--homogeneous seeds compositions" in capsys.readouterr().err
    assert _compose(source, tmp_path / "zero", "ga", "--homogeneous", "0") == 2
    assert "--homogeneous" in capsys.readouterr().err
