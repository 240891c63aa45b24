"""The harder adaptation benchmark and adaptation per robot: per-robot Intelligent Trial and Error changes
only the robots a condition strikes; the 70 % rule keeps a harsh condition and drops a mild one; runs.csv has
one row per method, task, condition, seed and repertoire; the held-out scenarios never meet an adaptation
scenario; an interrupted benchmark reuses its filter scores and ceilings, and each ceiling's search saves
itself under its own key."""

import csv
import io
import json
import math
from pathlib import Path

import numpy as np
import pytest
from small_repertoires import top_food_repertoire

from evolution_manager.adaptation import adapt_benchmark
from evolution_manager.adaptation.adapt import adapt
from evolution_manager.adaptation.search import (
    AdaptationError,
    CompositionEvaluation,
    IntelligentTrialAndError,
    ITEParameters,
    composition,
    load_candidates,
    run_picker,
    struck_robots,
)
from swarm_sim.core.trial_data import setup_chain
from swarm_sim.evaluation import BatchEvaluator, SwarmRequest
from swarm_sim.model import DEFAULT, apply_conditions


def test_a_composition_changes_only_the_robots_it_names():
    assert composition("b", "t", (1, 3), 5).trees == ("b", "t", "b", "t", "b")
    assert composition("b", "t", (), 3).trees == ("b", "b", "b")
    with pytest.raises(AdaptationError, match=r"robot ids in \[0, 4\]"):
        composition("b", "t", (5,), 5)


@pytest.mark.parametrize(
    ("conditions", "expected"),
    [
        (["dead-robots=2"], (0, 1)),
        (["weak-wheel=3:0.5"], (6, 7, 8)),
        (["message-loss=0.5", "gap=900"], ()),
        (["robots=4", "dead-robots=1", "weak-wheel=1:0.5"], (0, 3)),
    ],
)
def test_struck_robots_are_the_ones_the_condition_damages(conditions, expected):
    config, _ = apply_conditions(conditions)
    assert struck_robots(config, 1) == struck_robots(config, 2) == expected


def test_struck_robots_under_a_fault_rate_or_file_are_the_faulty_ones(tmp_path):
    config, _ = apply_conditions(["faults=0.4:wheel-dead,rab-deaf"])
    seen = set()
    for seed in range(1, 6):
        # The robots the simulator makes faulty in every chain of that seed's trials.
        faulty = tuple(int(i) for i in np.flatnonzero(setup_chain(seed, 0, config).faults))
        assert faulty == tuple(int(i) for i in np.flatnonzero(setup_chain(seed, 1, config).faults))
        assert struck_robots(config, seed) == faulty
        seen.add(faulty)
    assert len(seen) > 1  # drawn per seed
    faults = tmp_path / "faults.json"
    faults.write_text(json.dumps({"2": "rab-deaf", "5": "wheel-reversed"}))
    config, _ = apply_conditions([f"faults={faults}"])
    assert struck_robots(config, 1) == struck_robots(config, 9) == (2, 5)


class _Spy(BatchEvaluator):
    """A batch evaluator that keeps every request it was given."""

    def __init__(self, *args, **kwargs):
        super().__init__(*args, **kwargs)
        self.requests = []

    def evaluate(self, requests):
        self.requests.extend(requests)
        return super().evaluate(requests)


def test_per_robot_ite_changes_only_the_struck_robots(tmp_path):
    run = top_food_repertoire(tmp_path / "run", 6)
    candidates = load_candidates(run, "food")
    base = max(candidates, key=lambda c: c.prior).tree
    faults = tmp_path / "faults.json"
    faults.write_text(json.dumps({"2": "rab-deaf", "5": "wheel-reversed"}))
    config, _ = apply_conditions([f"faults={faults}"])
    spy = _Spy(config)
    search = IntelligentTrialAndError(candidates, 4, ITEParameters(stop_fraction=None))
    run_picker(search, CompositionEvaluation(spy, config, 3, base, 1), "food")
    assert len(search.tried) == 4 and all(isinstance(r, SwarmRequest) for r in spy.requests)
    assert {r.seed for r in spy.requests} == {3}
    for request, tried in zip(spy.requests, search.tried, strict=True):
        trees = request.swarm.trees
        assert [trees[i] for i in (0, 1, 3, 4, 6, 7, 8)] == [base] * 7
        assert trees[2] == trees[5] == tried.tree
    assert len({t.tree for t in search.tried}) == 4  # other trees were tried on robots 2 and 5
    # The command: --per-robot records the robots it changed.
    argv = ["--repertoire", str(run), "--objective", "food", "--condition", f"faults={faults}"]
    assert adapt([*argv, "--budget", "2", "--trials", "1", "--per-robot", "--out", str(tmp_path / "a")]) == 0
    document = json.loads((tmp_path / "a" / "adaptation.json").read_text())
    assert document["robots"] == [2, 5] and len(document["tried"]) <= 2


@pytest.mark.parametrize(
    ("ratios", "expected"),
    [
        ([0.69], True),
        ([0.7], False),
        ([0.2, 0.8, 0.75], False),
        ([0.2, 0.65, 0.9], True),
        ([math.nan], False),
        ([0.1, math.nan], False),
    ],
)
def test_the_filter_keeps_a_condition_below_70_percent_of_the_fault_free_score(ratios, expected):
    assert adapt_benchmark.kept(ratios) is expected


def test_fractions_count_from_the_floor():
    assert adapt_benchmark.relative(0.6, 0.8) == pytest.approx(0.75)
    assert adapt_benchmark.relative(0.6, 0.8, 0.5) == pytest.approx(1 / 3)
    assert math.isnan(adapt_benchmark.relative(0.6, 0.5, 0.5))
    run = adapt_benchmark.Run("ite", "r", 1, ["a", "b", "c"], [0.55, 0.73, 0.8], 0.8, 0.8)
    assert run.trials_to_90() == 2  # the bar 0.9 x 0.8 = 0.72
    run.floor = 0.5
    assert run.trials_to_90() == 3  # the bar 0.5 + 0.9 x 0.3 = 0.77


def test_condition_sets_split_at_commas_but_keep_fault_kinds_and_name_their_family():
    split = adapt_benchmark.split_condition_set("faults=0.3:wheel-dead,wheel-weak,message-loss=0.5")
    assert split == ["faults=0.3:wheel-dead,wheel-weak", "message-loss=0.5"]
    for text, family in [
        ("faults=0.3:wheel-dead,wheel-weak", "wheel"),
        ("faults=0.3:rab-deaf", "receiver"),
        ("faults=0.3", "mixed"),
        ("dead-robots=3", "dead robots"),
        ("faults=0.3:disruptive,message-loss=0.5", "mixed"),
    ]:
        config, record = apply_conditions(adapt_benchmark.split_condition_set(text), DEFAULT)
        assert adapt_benchmark.fault_family(config, record) == family, text


def test_heldout_scenarios_are_seeded_and_never_an_adaptation_scenario():
    seeds = set(range(1, 11))
    heldout = adapt_benchmark.scenario_seeds(74, 20, seeds)
    assert heldout == adapt_benchmark.scenario_seeds(74, 20, seeds) and len(set(heldout)) == 20
    assert not set(heldout) & seeds
    # A seed it would draw that is an adaptation scenario is passed over.
    skipped = adapt_benchmark.scenario_seeds(74, 20, seeds | {heldout[0]})
    assert skipped[:19] == heldout[1:] and heldout[0] not in skipped


def _rows(path):
    with path.open(newline="") as handle:
        return list(csv.reader(handle))


def test_the_benchmark_keeps_a_harsh_condition_drops_a_mild_one_and_resumes(tmp_path, monkeypatch):
    repertoire = top_food_repertoire(tmp_path / "run", 5)
    out = tmp_path / "out"
    argv = ["--repertoires", str(repertoire), "--condition-set", "faults=1.0:ground-stuck"]
    argv += ["--condition-set", "message-loss=0", "--seeds", "2", "--budget", "3", "--ceiling", "8"]
    argv += ["--trials", "1", "--filter-scenarios", "2", "--heldout", "3", "--no-progress", "--out", str(out)]
    scored = []

    class Recording(adapt_benchmark.Scores):
        def __init__(self, evaluator, local, config, seeds, trials, k):
            scored.append(tuple(seeds))
            super().__init__(evaluator, local, config, seeds, trials, k)

    monkeypatch.setattr(adapt_benchmark, "Scores", Recording)
    with pytest.raises(SystemExit) as ended:
        adapt_benchmark.main(argv)
    assert ended.value.code == 0
    # The filter: blind ground sensors keep below 70 % of the fault-free score, a lossless radio keeps it all.
    filtered = {row[0]: row for row in _rows(out / "conditions.csv")[1:]}
    assert float(filtered["faults=1.0:ground-stuck"][6]) < 0.7 <= float(filtered["message-loss=0"][6])
    assert (
        filtered["faults=1.0:ground-stuck"][1] == "ground sensor" and filtered["message-loss=0"][1] == "radio"
    )
    summary = json.loads((out / "summary.json").read_text())
    assert (
        summary["candidates"]["faults=1.0:ground-stuck"]["kept"]
        and not summary["candidates"]["message-loss=0"]["kept"]
    )
    assert summary["task"] == "primitives" and summary["objective"] == "food"
    # runs.csv: one row per method, task, condition, seed (and repertoire), for the kept condition only.
    rows = _rows(out / "runs.csv")
    assert rows[0] == adapt_benchmark.RUN_HEADER and rows[0][:6] == [
        "method",
        "task",
        "condition",
        "seed",
        "repertoire",
        "trials_to_90",
    ]
    body = [dict(zip(rows[0], row, strict=True)) for row in rows[1:]]
    assert sorted((r["method"], r["seed"]) for r in body) == sorted(
        (m, s) for m in adapt_benchmark.METHODS for s in ("1", "2")
    )
    assert {(r["task"], r["condition"]) for r in body} == {("primitives", "faults=1.0:ground-stuck")}
    for r in body:
        assert r["trials_to_90"] == "" or 1 <= int(r["trials_to_90"]) <= 3
        assert math.isfinite(float(r["heldout_final"])) and float(r["heldout_pre_fault"]) > 0
        assert (r["repertoire"] == "") == r["method"].endswith("-scratch")
    assert _rows(out / "trials.csv")[0][:3] == ["task", "condition", "method"]
    report = (out / "report.md").read_text()
    assert "| ground sensor | 1 | 1 |" in report and "| radio | 1 | 0 |" in report and "SMBO" in report
    # The held-out and filter scenarios: seeded, apart, and never the adaptation scenarios 1 and 2.
    sets = set(scored)
    assert len(sets) == 2 and {len(s) for s in sets} == {2, 3}
    filter_seeds, heldout_seeds = sorted(sets, key=len)
    assert not (set(filter_seeds) | set(heldout_seeds)) & {1, 2}
    assert not set(filter_seeds) & set(heldout_seeds)
    # Resumed: the filter's scores and the ceilings are read back, not computed again.
    table = _rows(out / "conditions.csv")
    for row in table:
        if row[0] == "message-loss=0":
            row[5] = f"{0.1 * float(row[4]):.6f}"  # the score under the condition, as if it fell to 10 %
    with (out / "conditions.csv").open("w", newline="") as handle:
        csv.writer(handle, lineterminator="\n").writerows(table)
    ceilings = []
    real = adapt_benchmark.reevolve

    def counting(algorithm, objective, budget, seed, evaluate, setting=None, checkpoint=None):
        if budget == 8:
            ceilings.append(checkpoint.key)
        return real(algorithm, objective, budget, seed, evaluate, setting, checkpoint)

    monkeypatch.setattr(adapt_benchmark, "reevolve", counting)
    with pytest.raises(SystemExit) as ended:
        adapt_benchmark.main(argv)
    assert ended.value.code == 0
    summary = json.loads((out / "summary.json").read_text())
    assert summary["candidates"]["message-loss=0"]["kept"]  # the edited score was read back
    assert len(ceilings) == 4  # the new condition's 2 seeds x 2 algorithms; the old ceilings were reused
    # Each ceiling's search saves itself under its own key, and its checkpoint goes once it is written.
    assert sorted((k["condition"], k["seed"], k["algorithm"]) for k in ceilings) == sorted(
        ("message-loss=0", s, a) for s in (1, 2) for a in ("qd", "gp")
    )
    assert not (out / "ceiling-checkpoint.json").exists()


RESULTS = Path(__file__).resolve().parents[4] / "docs" / "results" / "adaptation"


def _measures(mine: list[dict], floor: float) -> str:
    """The cells a report gives a group of runs: their number, the median trials to 90 % of the pre-fault
    score, the fraction recovered within 10 and 30 trials, and the median held-out re-scores at 10 trials and
    at the budget (as fractions of the best tree's fault-free score there, counted from ``floor``)."""
    hits = [int(r["trials_to_90"]) if r["trials_to_90"] else math.inf for r in mine]
    scores = [
        np.median(
            [adapt_benchmark.relative(float(r[key]), float(r["heldout_pre_fault"]), floor) for r in mine]
        )
        for key in ("heldout_at_10", "heldout_final")
    ]
    middle = float(np.median(hits))
    cells = [str(len(mine)), "never in 30" if math.isinf(middle) else f"{middle:g}"]
    cells += [f"{100 * sum(h <= at for h in hits) / len(hits):.0f} %" for at in (10, 30)]
    cells += [f"{100 * float(v):.0f} %" for v in scores]
    return " | ".join(cells)


@pytest.mark.parametrize(("task", "floor", "kept"), [("primitives", 0.5, 6), ("foraging", 0.0, 7)])
def test_a_committed_task_reports_condition_table_is_its_runs_csv(task, floor, kept):
    """docs/results/adaptation/<task>: per kept condition and method, the runs, the fraction recovered
    within 10 and 30 trials and the median held-out re-scores recomputed from its runs.csv."""
    folder = RESULTS / task
    rows = list(csv.DictReader(io.StringIO((folder / "runs.csv").read_text())))
    report = (folder / "report.md").read_text()
    assert json.loads((folder / "summary.json").read_text())["floor"] == floor
    conditions = list(dict.fromkeys(r["condition"] for r in rows))
    assert len(conditions) == kept
    for condition in conditions:
        for method in adapt_benchmark.METHODS:
            mine = [r for r in rows if r["condition"] == condition and r["method"] == method]
            cells = f"| {condition} | {adapt_benchmark.LABELS[method]} | {_measures(mine, floor)} |"
            assert cells in report, cells


def test_the_adaptation_pages_tables_are_the_tasks_runs_and_ceilings():
    """docs/results/adaptation/README.md: runs.csv is the two tasks' runs.csv joined; the table against the
    goal (every kept condition of a task) and the ceilings over the pre-fault score recomputed from them."""
    page = (RESULTS / "README.md").read_text()
    joined = (RESULTS / "runs.csv").read_text().splitlines()
    parts = [(RESULTS / task / "runs.csv").read_text().splitlines() for task in ("primitives", "foraging")]
    assert joined == [parts[0][0], *parts[0][1:], *parts[1][1:]] and parts[0][0] == parts[1][0]
    rows = list(csv.DictReader(io.StringIO("\n".join(joined))))
    reached = 0
    for task in ("primitives", "foraging"):
        floor = json.loads((RESULTS / task / "summary.json").read_text())["floor"]
        mine = [r for r in rows if r["task"] == task]
        kept = len({r["condition"] for r in mine})
        for method in adapt_benchmark.METHODS:
            of_method = [r for r in mine if r["method"] == method]
            cells = f"| {task} | {adapt_benchmark.LABELS[method]} | {kept} | {_measures(of_method, floor)} |"
            assert cells in page, cells
        ceilings: dict[tuple[str, str], float] = {}
        for r in csv.DictReader(io.StringIO((RESULTS / task / "ceilings.csv").read_text())):
            key = (r["condition"], r["seed"])
            ceilings[key] = max(ceilings.get(key, -math.inf), float(r["best_fitness"]))
        for (condition, seed), ceiling in ceilings.items():
            pre = np.median(
                [
                    float(r["pre_fault"])
                    for r in mine
                    if (r["condition"], r["seed"]) == (condition, seed) and r["repertoire"]
                ]
            )
            share = (ceiling - floor) / (pre - floor)
            reached += share >= 0.9
            assert f"| {task} | {condition} | {seed} | {100 * share:.0f} % |" in page
    assert f"It reaches 90 % of the pre-fault score in {reached} of 25 condition-seeds" in page
