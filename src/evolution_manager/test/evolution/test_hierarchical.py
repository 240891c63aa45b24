"""The hierarchical node set of the 2024 follow-up (composites, got_food, on_food, in_nest and a library's
names) and the flat baseline's derating: what the GP may produce, how it draws leaves, and that a seeded run
is reproducible."""

from __future__ import annotations

import csv
import json
import random
import re
from collections import Counter

import pytest
from toy import ToyEvaluator

from bt_controller.language import ACTIONS, CONDITIONS, CONDITIONS_2024, library_from_json
from evolution_manager.evolution.algorithms import GeneticProgramming, MapElites, as_outcome
from evolution_manager.evolution.deap_trees import HIERARCHICAL_CONDITIONS, OBJECTIVES, make_primitive_set
from evolution_manager.evolution.operators import choose_leaf
from evolution_manager.evolution.parameters import DERATINGS, GPParameters, QDParameters
from evolution_manager.evolution.run_config import RunConfig
from evolution_manager.studies.evolve import evolve
from swarm_sim.evaluation import EvaluationRequest

FAMILIES = ("increaseDensity", "gotoNest", "gotoFood", "reduceDensity", "goAwayFromNest", "goAwayFromFood")
PRIMITIVES = {
    "gotoNest1": "sel(in_nest, seq(nest_left, forward_left), seq(nest_right, forward_right), forward)",
    "gotoFood6": "sel(on_food, seq(food_left, forward_left), seq(food_right, forward_right), forward)",
    "goAwayFromNest2": "prob(reverse, reverse_left, reverse_right)",
    "reduceDensity5": "seq(robot_left, forward_right)",
}
DOCUMENT = {"format": 1, "primitives": [{"name": n, "tree": t} for n, t in PRIMITIVES.items()]}
LIBRARY = library_from_json(DOCUMENT, "primitives.json")
HEADS = re.compile(r"\b(seq|sel|prob|success)(@\d+)?\(")


def leaves(text: str) -> list[str]:
    """The leaves of a tree text as written (primitive names unexpanded)."""
    return re.findall(r"[A-Za-z_][A-Za-z0-9_]*", HEADS.sub("", text))


def test_the_node_set_has_no_actions_and_draws_a_condition_or_a_primitive_half_the_time_each():
    names = [f"{family}{k}" for family in FAMILIES for k in range(1, 9)]  # the authors' 48
    library = library_from_json(
        {"format": 1, "primitives": [{"name": n, "tree": "forward"} for n in names]}, "48.json"
    )
    pset = make_primitive_set(HIERARCHICAL_CONDITIONS, library, "hierarchical")
    assert [t.name for t in pset.terminals[pset.ret]] == [*HIERARCHICAL_CONDITIONS, *names]
    assert sorted(p.name for p in pset.primitives[pset.ret]) == sorted(
        f"{c}{n}" for c in ("seq", "sel", "prob") for n in (2, 3, 4)
    )
    rng = random.Random(5)
    draws = Counter(choose_leaf(pset, rng).name for _ in range(96_000))
    conditions = sum(draws[c] for c in HIERARCHICAL_CONDITIONS)
    assert abs(conditions / 96_000 - 0.5) < 0.01  # not 3/51, as a uniform draw over the terminals gives
    for c in HIERARCHICAL_CONDITIONS:
        assert abs(draws[c] / 96_000 - 1 / 6) < 0.01
    assert set(draws) == {*HIERARCHICAL_CONDITIONS, *names}
    assert max(abs(draws[n] / 96_000 - 1 / 96) for n in names) < 0.003
    # the flat set keeps DEAP's uniform draw (the 2023 runs' bytes)
    flat = make_primitive_set(CONDITIONS, library)
    assert not hasattr(flat, "leaf_classes")
    a, b = random.Random(3), random.Random(3)
    assert [choose_leaf(flat, a).name for _ in range(50)] == [
        b.choice(flat.terminals[flat.ret]).name for _ in range(50)
    ]
    with pytest.raises(ValueError, match="needs a library"):
        make_primitive_set(HIERARCHICAL_CONDITIONS, None, "hierarchical")


@pytest.mark.parametrize("algorithm", ["gp", "qd"])
def test_evolution_never_leaves_the_hierarchical_node_set(algorithm):
    allowed = {*HIERARCHICAL_CONDITIONS, *PRIMITIVES}
    if algorithm == "gp":
        search = GeneticProgramming(
            [OBJECTIVES.index("foraging")],
            3000,
            11,
            GPParameters(),
            HIERARCHICAL_CONDITIONS,
            LIBRARY,
            "hierarchical",
        )
    else:
        search = MapElites(
            OBJECTIVES.index("foraging"),
            3000,
            11,
            QDParameters(),
            HIERARCHICAL_CONDITIONS,
            LIBRARY,
            nodes="hierarchical",
        )
    evaluator = ToyEvaluator()
    seen: Counter[str] = Counter()
    while not search.done:
        texts = search.ask()
        for text in texts:
            seen.update(leaves(text))
            assert set(leaves(text)) <= allowed, text
        search.tell([as_outcome(r) for r in evaluator.evaluate([EvaluationRequest(t, 1, 1) for t in texts])])
    assert set(seen) == allowed  # every leaf occurs: the check saw the whole set
    assert not set(seen) & set(ACTIONS)


def test_the_flat_foraging_baseline_derates_as_the_authors_and_the_rest_as_in_2023():
    standard, baseline = DERATINGS["standard"], DERATINGS["baseline"]
    assert [standard(n) for n in (1, 10, 11, 1000, 1001)] == [1.0, 1.0, 1 - 1 / 990, 1 - 990 / 990, 0.0]
    sizes = (1, 64, 65, 1000, 6994, 6995)
    assert [baseline(n) for n in sizes] == [1.0, 1.0, 1 - 1 / 6930, 1 - 936 / 6930, 0.0, 0.0]
    flat = RunConfig.make("gp", "foraging", 100, 1, task="foraging")
    assert (flat.nodes, flat.gp.derating, flat.conditions) == ("flat", "baseline", CONDITIONS_2024)
    assert flat.to_json()["gp"]["derating"] == "baseline"
    library = ("primitives.json", LIBRARY.digest)
    hierarchical = RunConfig.make(
        "gp", "foraging", 100, 1, task="foraging", library=library[0], library_digest=library[1]
    )
    assert (hierarchical.nodes, hierarchical.gp.derating) == ("hierarchical", "standard")
    assert hierarchical.conditions == HIERARCHICAL_CONDITIONS
    assert RunConfig.from_json(hierarchical.to_json()) == hierarchical
    # a 2023 run's configuration is written as before node sets and deratings existed
    paper = RunConfig.make("qd", "food", 100, 1)
    assert "nodes" not in paper.to_json() and "derating" not in paper.to_json()["gp"]
    assert RunConfig.from_json(paper.to_json()) == paper
    # a library over the flat set (low-level nodes and names, as --library did before node sets)
    mixed = RunConfig.make(
        "gp", "foraging", 100, 1, task="foraging", library=library[0], library_digest=library[1], nodes="flat"
    )
    assert (mixed.nodes, mixed.gp.derating, mixed.conditions) == ("flat", "standard", CONDITIONS_2024)


def test_a_seeded_hierarchical_run_is_reproducible_and_refuses_what_it_cannot_run(tmp_path, capsys):
    library = tmp_path / "primitives.json"
    library.write_text(json.dumps(DOCUMENT))
    common = ["--algorithm", "gp", "--objective", "foraging", "--task", "foraging", "--evaluations", "50"]
    common += ["--library", str(library), "--seed", "4", "--trials", "2", "--no-progress", "--no-figures"]
    assert evolve([*common, "--out", str(tmp_path / "a")]) == 0
    assert evolve([*common, "--out", str(tmp_path / "b")]) == 0
    for name in (
        "config.json",
        "evaluations.csv",
        "progress.csv",
        "repertoire_foraging.json",
        "summary.json",
    ):
        assert (tmp_path / "a" / name).read_bytes() == (tmp_path / "b" / name).read_bytes(), name
    config = json.loads((tmp_path / "a" / "config.json").read_text())
    assert config["nodes"] == "hierarchical" and "derating" not in config["gp"]
    with (tmp_path / "a" / "evaluations.csv").open() as f:
        trees = [row["tree"] for row in csv.DictReader(f)]
    allowed = {*HIERARCHICAL_CONDITIONS, *PRIMITIVES}
    assert len(trees) > 25
    assert all(set(leaves(t)) <= allowed for t in trees) and any(
        set(leaves(t)) & set(PRIMITIVES) for t in trees
    )
    # the best tree as people read it is simplified around its primitives, which keep their names
    summary = json.loads((tmp_path / "a" / "summary.json").read_text())["objectives"]["foraging"]
    assert set(leaves(summary["best_tree_simplified"])) <= allowed
    assert (tmp_path / "a" / "best" / "foraging.txt").read_text() == summary["best_tree_simplified"] + "\n"
    capsys.readouterr()
    assert evolve(["--out", str(tmp_path / "a"), "--resume", "--nodes", "flat"]) == 2
    assert "--nodes flat differs from the run being resumed (hierarchical)" in capsys.readouterr().err
    bare = ["--algorithm", "gp", "--objective", "foraging", "--task", "foraging", "--nodes", "hierarchical"]
    assert evolve([*bare, "--out", str(tmp_path / "c")]) == 2
    error = capsys.readouterr().err
    assert error.count("\n") == 1 and "give --library" in error and not (tmp_path / "c").exists()
