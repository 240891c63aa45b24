"""The run loop and its directory (with the toy evaluator): resume, logs, passive grids, refusals."""

from __future__ import annotations

import csv
import itertools
import json

import pytest
from killed_runs import straight_and_killed
from recompute import check_metrics, check_repertoires
from toy import ToyEvaluator

from evolution_manager.errors import RunDirectoryError
from evolution_manager.evolution.deap_trees import OBJECTIVES
from evolution_manager.evolution.run import Run
from evolution_manager.evolution.run_config import RunConfig, evaluation_seed
from evolution_manager.evolution.run_results import run_results
from evolution_manager.viewing.results import write_results
from swarm_sim.model import PAPER_OBJECTIVES  # a primitives run's grids (RunConfig.grids)

RESULT_FILES = [
    "evaluations.csv",
    "progress.csv",
    "summary.json",
    "heldout.json",
    *(f"repertoire_{o}.json" for o in PAPER_OBJECTIVES),
]


def _files(root, names=RESULT_FILES):
    return {name: (root / name).read_bytes() for name in names if (root / name).exists()}


def _finish(run):
    run.execute(checkpoint_interval=0)
    write_results(run, run_results(run, run.evaluator), with_figures=False)
    return run


@pytest.mark.parametrize(
    "algorithm,objective,profile",
    [("gp", "food", "paper"), ("gp-fnd", None, "paper"), ("qd", "nest", "paper"), ("qd", "food", "clean")],
)
def test_a_resumed_run_ends_identical_to_an_uninterrupted_one(tmp_path, algorithm, objective, profile):
    config = RunConfig.make(algorithm, objective, 750, 11, profile=profile)
    straight = _finish(Run.start(config, tmp_path / "straight", ToyEvaluator()))
    stopped = Run.start(config, tmp_path / "stopped", ToyEvaluator())
    for stop in (90, 260, 430):
        stopped.execute(checkpoint_interval=0, stop_after=stop)
        # a crash after the last checkpoint leaves rows the checkpoint does not know about
        with open(tmp_path / "stopped" / "evaluations.csv", "a") as log:
            log.write("999,1,garbage\n")
        stopped = Run.resume(tmp_path / "stopped", ToyEvaluator())
    _finish(stopped)
    assert _files(tmp_path / "stopped") == _files(tmp_path / "straight")
    if algorithm == "qd":
        assert (tmp_path / "stopped" / "archive.json").read_bytes() == (
            tmp_path / "straight" / "archive.json"
        ).read_bytes()
    assert stopped.evaluations == straight.evaluations
    assert stopped.algorithm.produced == straight.algorithm.produced == 750
    # the fixed scenario's cache is rebuilt on resume: the same simulations saved (summary.json too)
    assert (stopped.simulations, stopped.simulations_saved, stopped.answers) == (
        straight.simulations,
        straight.simulations_saved,
        straight.answers,
    )
    assert straight.simulations_saved > 0
    assert ("inherited" in straight.answers) == (profile == "paper")


def test_a_killed_run_resumes_to_the_same_files(tmp_path):
    argv = ["--algorithm", "gp", "--objective", "food", "--evaluations", "300", "--trials", "1"]
    straight, killed = straight_and_killed([*argv, "--seed", "4", "--no-figures"], tmp_path, rows=4)
    assert _files(killed) == _files(straight)
    assert (straight / "heldout.json").exists() and len(_files(straight)) == len(RESULT_FILES)


def test_passive_grids_agree_with_a_recomputation_from_the_evaluation_log(tmp_path):
    run = _finish(
        Run.start(RunConfig.make("qd", "food", 900, 12), tmp_path / "r", ToyEvaluator(fail_on="stop, stop"))
    )
    with open(tmp_path / "r" / "evaluations.csv", newline="") as handle:
        rows = list(csv.DictReader(handle))
    assert [int(r["evaluation"]) for r in rows] == list(range(len(rows)))
    assert all(int(r["seed"]) == run.config.scenario_seed for r in rows)  # fixed scenarios
    assert any(r["error"] for r in rows)
    check_repertoires(tmp_path / "r")
    for objective in PAPER_OBJECTIVES:
        document = json.loads((tmp_path / "r" / f"repertoire_{objective}.json").read_text())
        grid = run.passive[objective]
        assert grid.qd_score == document["qd_score"] and grid.coverage == document["coverage"]
    archive = json.loads((tmp_path / "r" / "archive.json").read_text())
    assert archive["items"] == json.loads((tmp_path / "r" / "repertoire_food.json").read_text())["items"]


def test_progress_is_one_row_per_batch_and_never_loses_quality(tmp_path):
    _finish(Run.start(RunConfig.make("qd", "density", 400, 13), tmp_path / "r", ToyEvaluator()))
    with open(tmp_path / "r" / "progress.csv", newline="") as handle:
        rows = list(csv.DictReader(handle))
    counts = [int(r["evaluations"]) for r in rows]
    # the initial batch, then 8 batches of 50 varied parents of which the untouched ones are not evaluated
    assert counts[0] == 100 and len(counts) == 1 + 400 // 50
    assert all(0 < b - a <= 50 for a, b in itertools.pairwise(counts))
    for objective in PAPER_OBJECTIVES:
        for metric in ("best", "coverage", "qd_score"):
            values = [float(r[f"{metric}_{objective}"]) for r in rows]
            assert values == sorted(values)


def test_a_run_never_overwrites_another_and_resume_needs_a_run(tmp_path):
    config = RunConfig.make("gp", "nest", 60, 1)
    Run.start(config, tmp_path / "r", ToyEvaluator())
    before = _files(tmp_path / "r", ["config.json", "checkpoint.json"])
    with pytest.raises(RunDirectoryError, match="already holds a run"):
        Run.start(config, tmp_path / "r", ToyEvaluator())
    assert _files(tmp_path / "r", ["config.json", "checkpoint.json"]) == before
    with pytest.raises(RunDirectoryError, match="no run to resume"):
        Run.resume(tmp_path / "empty", ToyEvaluator())
    (tmp_path / "other").mkdir()
    (tmp_path / "other" / "progress.csv").write_text("someone else's file\n")
    with pytest.raises(RunDirectoryError, match="not empty"):
        Run.start(config, tmp_path / "other", ToyEvaluator())
    assert (tmp_path / "other" / "progress.csv").read_text() == "someone else's file\n"


def test_a_damaged_checkpoint_is_refused_with_its_name(tmp_path):
    Run.start(RunConfig.make("gp", "nest", 60, 1), tmp_path / "r", ToyEvaluator())
    (tmp_path / "r" / "checkpoint.json").write_text('{"format": 1, "config": ')
    with pytest.raises(RunDirectoryError, match=r"checkpoint\.json"):
        Run.resume(tmp_path / "r", ToyEvaluator())
    # A checkpoint that parses but holds a value of the wrong kind is refused too (the fuzz test found a
    # null timing accepted, failing later in a sum).
    Run.start(RunConfig.make("gp", "nest", 60, 1), tmp_path / "t", ToyEvaluator())
    state = json.loads((tmp_path / "t" / "checkpoint.json").read_text())
    for timing in [{"evaluator": None, "manager": 0.5}, {"evaluator": -1.0, "manager": 0.5}, [1.0, 2.0]]:
        (tmp_path / "t" / "checkpoint.json").write_text(json.dumps({**state, "timing": timing}))
        with pytest.raises(RunDirectoryError, match=r"checkpoint\.json.*timing"):
            Run.resume(tmp_path / "t", ToyEvaluator())


@pytest.mark.parametrize("algorithm,objective", [("gp", "nest"), ("gp-fnd", None)])
def test_gp_metrics_recomputed_from_the_run_files_equal_the_reported_ones(tmp_path, algorithm, objective):
    run = _finish(Run.start(RunConfig.make(algorithm, objective, 600, 14), tmp_path / "r", ToyEvaluator()))
    summary = json.loads((tmp_path / "r" / "summary.json").read_text())
    for o in PAPER_OBJECTIVES:
        check_metrics(tmp_path / "r", o, summary)
    for o in run.config.objectives:
        document = json.loads((tmp_path / "r" / f"repertoire_{o}.json").read_text())
        assert (
            document["items_per_bin"] == 1
            and len(document["items"]) == summary["objectives"][o]["repertoire_size"]
        )
        # GP's best is its elite: the best of the final population, which is the best ever kept
        assert summary["objectives"][o]["best_fitness"] == max(i["fitness"] for i in document["items"])
        # the last progress row measures the final repertoire
        last = run.directory.progress.read()[-1]
        for key, metric in (("best", "best_fitness"), ("coverage", "coverage"), ("qd_score", "qd_score")):
            assert float(last[f"{key}_{o}"]) == summary["objectives"][o][metric]


def test_fixed_scenarios_give_one_fitness_per_tree_and_fresh_ones_a_seed_per_evaluation(tmp_path):
    # clean: the cache is keyed on the tree text (paper keys it on the simplified form, see below)
    fixed_config = RunConfig.make("gp", "food", 500, 15, profile="clean")
    fixed = _finish(Run.start(fixed_config, tmp_path / "fixed", ToyEvaluator()))
    rows = fixed.directory.evaluations.read()
    values: dict[str, set] = {}
    for row in rows:
        values.setdefault(row["tree"], set()).add(tuple(row[k] for k in (*OBJECTIVES, "seed")))
    assert all(len(v) == 1 for v in values.values())
    assert fixed.simulations == len(values) and fixed.simulations_saved == len(rows) - len(values) > 0
    fresh_config = RunConfig.make("gp", "food", 500, 15, scenarios="fresh")
    fresh = _finish(Run.start(fresh_config, tmp_path / "fresh", ToyEvaluator()))
    seeds = [int(r["seed"]) for r in fresh.directory.evaluations.read()]
    assert seeds == [evaluation_seed(15, i) for i in range(len(seeds))]
    assert fresh.simulations_saved == 0 and fresh.simulations == len(seeds)
    config = json.loads((tmp_path / "fixed" / "config.json").read_text())
    assert config["scenarios"] == "fixed" and config["scenario_seed"] == fixed.config.scenario_seed
    assert RunConfig.make("gp", "food", 500, 15, scenario_seed=7).scenario_seed == 7


def test_evaluate_with_the_runs_scenario_seed_reproduces_every_stored_fitness(tmp_path):
    from swarm_sim.evaluation import BatchEvaluator
    from swarm_sim.evaluation.cli import run as evaluate_command

    run = _finish(Run.start(RunConfig.make("qd", "food", 50, 16), tmp_path / "r", BatchEvaluator()))
    rows = run.directory.evaluations.read()
    summary = json.loads((tmp_path / "r" / "summary.json").read_text())
    best = summary["objectives"]["food"]
    chosen = [r for r in rows if r["tree"] == best["best_tree"]][:1] + rows[:: max(1, len(rows) // 3)]
    seed = json.loads((tmp_path / "r" / "config.json").read_text())["scenario_seed"]
    for row in chosen:
        document = json.loads(evaluate_command(["--tree", row["tree"], "--seed", str(seed)]))
        stored = [float(row[k]) for k in (*OBJECTIVES, "movement", "rotation", "conditionality")]
        got = [*document["fitness"].values(), *document["descriptors"].values()]
        if run.answers[int(row["evaluation"])] == "inherited":  # a clone's values: conditionality may differ
            got, stored = got[:5], stored[:5]
        assert got == stored  # exactly
    assert chosen[0][best["evolved"] and "food"] and float(chosen[0]["food"]) == best["best_fitness"]


VALUES = (*OBJECTIVES, "movement", "rotation", "conditionality")


def _batches(root):
    """The rows of ``evaluations.csv``, batch by batch as ``progress.csv`` delimits them."""
    with open(root / "evaluations.csv", newline="") as handle:
        rows = list(csv.DictReader(handle))
    with open(root / "progress.csv", newline="") as handle:
        ends = [int(r["evaluations"]) for r in csv.DictReader(handle)]
    return [rows[start:end] for start, end in itertools.pairwise([0, *ends])]


def _clone_bins(root, objective, forms):
    """The bins of a repertoire file holding two or more trees of one simplified form: bin -> their items."""
    by_bin: dict[tuple, dict[str, list]] = {}
    for item in json.loads((root / f"repertoire_{objective}.json").read_text())["items"]:
        by_bin.setdefault(tuple(item["bin"]), {}).setdefault(forms(item["tree"]), []).append(item)
    return {b: items for b, groups in by_bin.items() for items in groups.values() if len(items) > 1}


def test_clean_grids_refuse_a_tree_whose_simplified_form_is_in_its_bin(tmp_path):
    """A real run (the simulator, qdpy's grid): no bin of any repertoire holds two trees of one simplified
    form, although its evaluations hold such clones that the text rule alone would keep."""
    from recompute import grids_from_log

    from evolution_manager.evolution.archive import SimplifiedForms
    from swarm_sim.evaluation import BatchEvaluator
    from swarm_sim.model import default_config

    root = tmp_path / "clean"
    evaluator = BatchEvaluator(default_config("clean"))
    _finish(Run.start(RunConfig.make("qd", "food", 400, 2, profile="clean"), root, evaluator))
    forms = SimplifiedForms()
    for objective in PAPER_OBJECTIVES:
        assert _clone_bins(root, objective, forms) == {}, objective
    check_repertoires(root, forms)  # the grids the rule builds from the evaluation log, item for item
    archive = json.loads((root / "archive.json").read_text())["items"]
    assert archive == json.loads((root / "repertoire_food.json").read_text())["items"]
    text_rule = grids_from_log(root)["food"]  # the same evaluations, clones refused only as the same text
    assert any(len({forms(t) for t, _, _ in items}) < len(items) for items in text_rule.values())


@pytest.mark.parametrize("algorithm", ["qd", "gp"])
def test_paper_answers_a_clone_of_an_earlier_batch_with_its_values_unsimulated(tmp_path, algorithm):
    """The authors' rule (qdpy/ea.py:372-382 with 447-496; gp/ea.py:357-371 with 506-555): a tree whose
    simplified form an earlier batch evaluated is not simulated and takes the fitness and descriptors,
    conditionality included, of that form's last (MAP-Elites; qdpy/ea.py:496) or first (GP;
    redundancy.py:1798-1822) evaluation in the batch that first met it; trees of one form first met in one
    batch are each simulated; in MAP-Elites a clone then enters the grid as any tree (its text alone is
    refused twice): same bin."""
    from evolution_manager.evolution.archive import SimplifiedForms
    from swarm_sim.evaluation import BatchEvaluator, EvaluationRequest

    root = tmp_path / "paper"
    config = RunConfig.make(algorithm, "food", 400, 2, profile="paper")
    run = _finish(Run.start(config, root, BatchEvaluator()))
    forms = SimplifiedForms()
    known: dict[str, tuple] = {}
    simulated: set[str] = set()
    inherited = []
    simulations = 0
    for batch in _batches(root):
        met: dict[str, tuple] = {}
        in_batch: set[str] = set()
        for row in batch:
            values = tuple(row[k] for k in VALUES)
            if forms(row["tree"]) in known:
                assert values == known[forms(row["tree"])]
                inherited.append(row)
                continue
            if algorithm == "qd" or forms(row["tree"]) not in met:  # MAP-Elites keeps the last, GP the first
                met[forms(row["tree"])] = values
            if row["tree"] not in in_batch:  # the same text again in the batch: its first copy's answer
                simulations += 1
                in_batch.add(row["tree"])
                simulated.add(row["tree"])
        known.update(met)
    summary = json.loads((root / "summary.json").read_text())
    assert summary["simulations"] == run.simulations == simulations
    assert run.answers.count("inherited") == len(inherited)
    clones = [row for row in inherited if row["tree"] not in simulated]  # never simulated in the run
    assert clones
    # simulated, a clone shows the world what its form's tree did: fitness, movement, rotation (not
    # necessarily conditionality: simplification removes condition ticks)
    requests = [EvaluationRequest(tree=r["tree"], seed=run.config.scenario_seed) for r in clones[:4]]
    for row, result in zip(clones[:4], BatchEvaluator().evaluate(requests), strict=True):
        assert [*result.fitness, *result.descriptors][:5] == [float(row[k]) for k in VALUES[:5]]
    if algorithm == "gp":  # its repertoire holds one tree per bin
        return
    clone_bins = _clone_bins(root, "food", forms)
    assert clone_bins  # paper keeps clones, with identical values
    for items in clone_bins.values():
        assert len({(i["fitness"], tuple(i["descriptors"])) for i in items}) == 1


class _KindsToy(ToyEvaluator):
    """The toy, with deliveries of food kinds 2 and 3 that vary with the tree (the toy's own has none)."""

    def one(self, request):
        result = super().one(request)
        if result.fitness is None:
            return result
        fitness = list(result.fitness)
        fitness[OBJECTIVES.index("foraging2")] = 0.4 * fitness[OBJECTIVES.index("food")]
        fitness[OBJECTIVES.index("foraging3")] = 0.6 * fitness[OBJECTIVES.index("nest")]
        return type(result)(tuple(fitness), result.descriptors, None)


def test_deliveries_over_a_quarter_bins_the_same_axes_twice_as_finely():
    from evolution_manager.evolution.descriptor_sets import descriptor_set
    from evolution_manager.evolution.run_config import ConfigError

    fitness = [0.0] * len(OBJECTIVES)
    for kind, value in (("foraging1", 0.05), ("foraging2", 0.2), ("foraging3", 0.3)):
        fitness[OBJECTIVES.index(kind)] = value
    assert descriptor_set("deliveries").point(fitness, (0, 0, 0)) == pytest.approx((0.1, 0.4, 0.6))
    assert descriptor_set("deliveries-0.25").point(fitness, (0, 0, 0)) == pytest.approx((0.2, 0.8, 1.0))
    config = RunConfig.make("qd", "foraging", 300, 5, task="multifood-arena6", descriptors="deliveries-0.25")
    assert RunConfig.from_json(config.to_json()) == config
    assert config.to_json()["descriptors"] == "deliveries-0.25"
    with pytest.raises(ConfigError, match=r"descriptors deliveries-0\.25 bins trees .* one kind of food"):
        RunConfig.make("qd", "foraging", 300, 5, task="foraging", descriptors="deliveries-0.25")


def test_a_run_over_the_deliveries_of_each_food_kind_bins_by_them_and_resumes_alike(tmp_path):
    from evolution_manager.evolution.descriptor_sets import DELIVERY_DOMAIN
    from evolution_manager.evolution.run_config import ConfigError

    config = RunConfig.make("qd", "foraging", 300, 5, task="multifood-arena6", descriptors="deliveries")
    assert config.to_json()["descriptors"] == "deliveries"
    assert RunConfig.from_json(config.to_json()) == config
    assert "descriptors" not in RunConfig.make("qd", "foraging", 300, 5).to_json()  # as before: unchanged
    with pytest.raises(ConfigError, match="one kind of food"):
        RunConfig.make("qd", "foraging", 300, 5, task="foraging", descriptors="deliveries")
    _finish(Run.start(config, tmp_path / "straight", _KindsToy()))
    stopped = Run.start(config, tmp_path / "stopped", _KindsToy())
    stopped.execute(checkpoint_interval=0, stop_after=120)
    _finish(Run.resume(tmp_path / "stopped", _KindsToy()))
    names = ["evaluations.csv", "progress.csv", "repertoire_foraging.json", "archive.json"]
    assert _files(tmp_path / "stopped", names) == _files(tmp_path / "straight", names)
    document = json.loads((tmp_path / "straight" / "repertoire_foraging.json").read_text())
    assert document["descriptors"] == ["foraging1", "foraging2", "foraging3"]
    with open(tmp_path / "straight" / "evaluations.csv") as handle:
        rows = {int(r["evaluation"]): r for r in csv.DictReader(handle)}
    assert {"movement", "rotation", "conditionality"} <= set(next(iter(rows.values())))  # the evaluator's
    for item in document["items"]:
        row = rows[item["evaluation"]]
        kinds = ("foraging1", "foraging2", "foraging3")
        expected = [min(1.0, float(row[k]) / DELIVERY_DOMAIN) for k in kinds]
        assert item["descriptors"] == pytest.approx(expected, abs=1e-12)
    assert len({tuple(i["bin"]) for i in document["items"]}) > 3  # spread over the kinds, not one bin
