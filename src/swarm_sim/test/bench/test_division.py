"""``division-bench``: its hand-written trees are in the balanced task's node set and do what their names
say, its swarms and its table; a task of one food kind refused in one line (its options out of range:
``test_batch``)."""

from __future__ import annotations

import re
import subprocess
import sys

import numpy as np
import pytest
from scipy.stats import wilcoxon

from bt_controller.language import parse
from swarm_sim.bench import division
from swarm_sim.evaluation import BatchEvaluator, SwarmRequest
from swarm_sim.model import OBJECTIVES, SwarmLayout
from swarm_sim.tasks import task_named

COMPOSITES = {"sel", "seq", "prob", "success"}


def _leaves(tree: str) -> set[str]:
    return set(re.findall(r"[a-z_0-9]+", tree)) - COMPOSITES


def test_every_tree_parses_and_uses_only_the_tasks_nodes():
    task = task_named(division.TASK)
    assert "foraging_balanced" in task.objectives
    built = division.swarms(task.robots.count)
    assert list(built) == [
        "any kind", *(f"only kind {k}" for k in (1, 2, 3)), *(f"prefers kind {k}" for k in (1, 2, 3)),
        "random kind (prob)", "wanderer (no food condition)", division.SPECIALISTS,
        "specialists (prefer kind k)",
    ]  # fmt: skip
    for composition, trees in built.values():
        assert len(trees) == task.robots.count
        assert (composition == "homogeneous") == (len(set(trees)) == 1)
        for tree in set(trees):
            parse(tree)
            assert _leaves(tree) <= set(task.nodes.conditions) | set(task.nodes.actions), tree
    # each forager of one kind reads only its own kind; one that prefers a kind seeks only it; the
    # specialists are three groups of three, robot i in group i mod 3 (a team's and robots.carries' groups)
    for k in division.KINDS:
        kinds = {int(name[-1]) for name in _leaves(division.kind_forager(k)) if name[-1].isdigit()}
        assert kinds == {k}
        seeking = {n for n in _leaves(division.preferring_forager(k)) if n.startswith("food_")}
        assert seeking == {f"food_left{k}", f"food_right{k}"}
    assert built[division.SPECIALISTS][1] == tuple(division.kind_forager(1 + i % 3) for i in range(9))
    preferring = built["specialists (prefer kind k)"][1]
    assert preferring == tuple(division.preferring_forager(1 + i % 3) for i in range(9))
    assert "prob(sel(" in division.random_kind_forager()
    assert not any(n.startswith(("food_", "on_food")) for n in _leaves(division.wanderer()))


def test_a_specialist_swarm_delivers_its_kinds_and_scores_its_least_kind():
    """Seed 3, ten trials (one of which delivers every kind): every group delivers its kind, and the balanced
    score (the mean over trials of K times the least kind) is at most K times the least of the mean
    deliveries, and at most foraging."""
    config = task_named(division.TASK).config()
    trees = division.swarms(config.n_robots)[division.SPECIALISTS][1]
    (result,) = BatchEvaluator(config).evaluate([SwarmRequest(SwarmLayout(trees), 3, 10)])
    named = dict(zip(OBJECTIVES, result.fitness, strict=True))
    kinds = [named[f"foraging{k}"] for k in division.KINDS]
    assert all(k > 0 for k in kinds)  # every group fetches its kind
    assert named["foraging_balanced"] == pytest.approx(3 / 90)  # one trial in ten: 3 x 1/9
    assert named["foraging_balanced"] < 3 * min(kinds)
    assert named["foraging_balanced"] <= named["foraging"] + 1e-12


def test_the_table_gives_mean_sem_and_the_ratio_to_the_best_homogeneous_swarm():
    def row(name: str, composition: str, seed: int, balanced: float) -> dict[str, str]:
        values = {c: "1.0" for c in division.COLUMNS} | {"foraging_balanced": repr(balanced)}
        return {"swarm": name, "composition": composition, "seed": str(seed), "trials": "10", **values}

    rows = [row("a", "homogeneous", s, v) for s, v in ((1, 0.2), (2, 0.4))]
    rows += [row("b", "homogeneous", s, v) for s, v in ((1, 0.1), (2, 0.1))]
    rows += [row("c", "heterogeneous", s, v) for s, v in ((1, 0.5), (2, 0.7))]
    rows += [row("d", "heterogeneous", s, v) for s, v in ((1, 0.1), (2, 0.2))]
    text = division.table(rows)
    assert "| a | homogeneous | 2 | 0.300 ± 0.100 | 1.000 ± 0.000 |" in text
    assert "- c / best homogeneous (a), foraging_balanced: 0.600 / 0.300 = 2.00\n" in text
    assert "- d / best homogeneous (a), foraging_balanced: 0.150 / 0.300 = 0.50\n" in text
    assert division.read_rows(division.rows_csv(rows)) == rows


def test_the_paired_table_compares_seed_by_seed_with_the_best_homogeneous_swarm_on_each_objective():
    def row(name: str, composition: str, seed: int, foraging: float, balanced: float) -> dict[str, str]:
        values = {c: "0.0" for c in division.COLUMNS}
        values |= {"foraging": repr(foraging), "foraging_balanced": repr(balanced)}
        return {"swarm": name, "composition": composition, "seed": str(seed), "trials": "10", **values}

    seeds = range(1, 9)
    # "a" is the best homogeneous swarm on foraging, "b" on foraging_balanced; "c" beats "a" by 0.1 to 0.8
    # seed by seed on foraging although the seeds spread far more than that (a paired comparison sees it).
    rows = [row("a", "homogeneous", s, 10.0 * s, 0.1) for s in seeds]
    rows += [row("b", "homogeneous", s, 1.0, 0.5) for s in seeds]
    rows += [row("c", "heterogeneous", s, 10.0 * s + 0.1 * s, 0.5) for s in seeds]
    text = division.paired_table(rows)
    lines = text.splitlines()
    assert lines[0] == "| swarm | objective | best homogeneous | mean difference | 95 % CI | Wilcoxon p |"
    differences = [0.1 * s for s in seeds]
    p = wilcoxon(differences).pvalue
    assert lines[2].startswith(f"| c | foraging | a | +{np.mean(differences):.3f} | [+0.")
    assert lines[2].endswith(f"| {p:.3g} |") and p < 0.01
    low, high = (float(v) for v in lines[2].split("[")[1].split("]")[0].split(", "))
    assert 0.1 < low < np.mean(differences) < high < 0.8
    assert lines[3] == "| c | foraging_balanced | b | +0.000 | [+0.000, +0.000] | 1 |"  # no difference at all
    assert division.paired_table(rows) == text  # one seeded generator: the table is recomputed exactly
    with pytest.raises(ValueError, match="not run on the same seeds"):
        division.paired_table(rows[:-1])


def test_on_the_carriers_task_the_two_specialist_swarms_are_one_controller_with_other_draws():
    """Under ``multifood-arena6-carriers`` a robot carries only its group's kind, so going home with any kind
    is going home with its own: the preferring specialists are the strict ones, but for their ``prob`` node's
    draw key (its place in the tree). Keyed alike, they score alike to the bit."""
    config = task_named("multifood-arena6-carriers").config()
    built = division.swarms(config.n_robots)
    strict = built[division.SPECIALISTS][1]
    keyed = tuple(
        tree.replace("prob(forward, forward_left", "prob@18(forward, forward_left")
        for tree in built["specialists (prefer kind k)"][1]
    )
    assert all(str(parse(tree)).count("prob") == 1 for tree in strict)
    evaluator = BatchEvaluator(config)
    a, b = evaluator.evaluate([SwarmRequest(SwarmLayout(trees), 1, 5) for trees in (strict, keyed)])
    assert a.fitness == b.fitness and a.fitness[OBJECTIVES.index("foraging")] > 0


def test_a_task_of_one_food_kind_is_refused_in_one_line():
    done = subprocess.run(
        [sys.executable, "-m", "swarm_sim.bench.division", "--task", "foraging", "--seeds", "2"],
        capture_output=True,
        text=True,
    )
    assert done.returncode == 2 and done.stderr.count("\n") == 1
    assert "needs a task with 3 food kinds, got 'foraging'" in done.stderr
    with pytest.raises(SystemExit):
        division.main(["--seeds", "1"])


def test_an_out_that_is_a_link_is_refused_before_measuring_and_nothing_is_written(tmp_path, capsys):
    elsewhere = tmp_path / "elsewhere.csv"
    elsewhere.write_text("kept\n")
    link = tmp_path / "rows.csv"
    link.symlink_to(elsewhere)
    assert division.main(["--seeds", "2", "--trials", "1", "--out", str(link)]) == 2
    said = capsys.readouterr().err
    assert said.count("\n") == 1 and said.startswith("division-bench: error: --out") and "link" in said
    assert elsewhere.read_text() == "kept\n" and link.is_symlink()
