"""Adaptation: Intelligent Trial and Error stays inside the repertoire and its budget, is deterministic for a
seed, follows the map's prior and learns from a poor trial; the adapt command writes its results and refuses
bad input in one line."""

import json
import math
from dataclasses import replace

import numpy as np
import pytest

from bt_controller.language import library_from_json, parse
from evolution_manager.adaptation.adapt import adapt
from evolution_manager.adaptation.adapt_live import main as adapt_live_main
from evolution_manager.adaptation.search import (
    AdaptationError,
    Candidate,
    ConditionEvaluation,
    IntelligentTrialAndError,
    ITEParameters,
    RandomPicks,
    SearchCheckpoint,
    load_candidates,
    reevolve,
    repertoire_setting,
    saved_search,
    written_out,
)
from evolution_manager.errors import AskTellError
from evolution_manager.evolution.deap_trees import ACTIONS
from evolution_manager.evolution.run_config import RunConfig
from swarm_sim.evaluation import BatchEvaluator
from swarm_sim.model import DEFAULT, apply_conditions


def _grid_candidates(count=60, seed=0):
    rng = np.random.default_rng(seed)
    bins = sorted({tuple(int(v) for v in rng.integers(0, 8, 3)) for _ in range(count)})
    return [
        Candidate(
            b,
            f"seq({ACTIONS[sum(b) % len(ACTIONS)]}, stop)",
            float(rng.uniform(0.5, 1.0)),
            tuple((np.array(b) + 0.5) / 8),
        )
        for b in bins
    ]


def _changed_world(candidate):
    """A damaged world: trees with high movement lose most of their fitness."""
    return candidate.prior - 0.6 * max(0.0, candidate.descriptors[0] - 0.4)


def _drive(search, world):
    while not search.done:
        candidate = search.ask()
        search.tell(world(candidate), candidate.descriptors)
    return search


def test_ite_stays_in_the_repertoire_and_the_budget_and_never_repeats_a_bin():
    candidates = _grid_candidates()
    for budget in (1, 7, 20):
        search = _drive(
            IntelligentTrialAndError(candidates, budget, ITEParameters(stop_fraction=None)), _changed_world
        )
        assert len(search.tried) == budget
        assert len({t.bin for t in search.tried}) == budget
        assert all((t.bin, t.tree) in {(c.bin, c.tree) for c in candidates} for t in search.tried)
        with pytest.raises(AskTellError, match="over"):
            search.ask()
    few = candidates[:3]
    search = _drive(IntelligentTrialAndError(few, 20, ITEParameters(stop_fraction=None)), _changed_world)
    assert len(search.tried) == 3 and search.stop_reason == "every bin tried"


def test_ite_starts_from_the_best_of_the_map_and_moves_away_from_a_poor_region():
    candidates = _grid_candidates()
    search = IntelligentTrialAndError(candidates, 20, ITEParameters(stop_fraction=None))
    first = search.ask()
    assert first.prior == max(c.prior for c in candidates)
    search.tell(first.prior - 0.5, first.descriptors)
    # The GP lowers the expectation of the first bin's neighbours, not of far bins.
    distance = np.linalg.norm(np.array([c.descriptors for c in candidates]) - first.descriptors, axis=1)
    drop = np.array([c.prior for c in candidates]) - search.mean
    assert drop[distance < 0.15].min() > 0.1
    assert np.abs(drop[distance > 0.9]).max() < 0.01


def test_ite_stops_by_the_papers_rule():
    candidates = _grid_candidates()
    # An undamaged world: the first tree is as good as expected, so the search stops at once.
    search = _drive(IntelligentTrialAndError(candidates, 20), lambda c: c.prior)
    assert len(search.tried) == 1 and search.stop_reason.startswith("best observed >= 0.9")
    # Damaged: it goes on until the best observed reaches 0.9 of the highest posterior mean.
    search = _drive(IntelligentTrialAndError(candidates, 20), _changed_world)
    best = max(t.fitness for t in search.tried)
    assert best >= 0.9 * search.tried[-1].expected_max
    for k in range(len(search.tried) - 1):
        assert max(t.fitness for t in search.tried[: k + 1]) < 0.9 * search.tried[k].expected_max


def test_ite_and_random_picks_are_deterministic():
    candidates = _grid_candidates()
    runs = [
        [
            t.bin
            for t in _drive(
                IntelligentTrialAndError(candidates, 15, ITEParameters(stop_fraction=None)), _changed_world
            ).tried
        ]
        for _ in range(2)
    ]
    assert runs[0] == runs[1]
    picks = [
        [t.bin for t in _drive(RandomPicks(candidates, 10, seed), _changed_world).tried] for seed in (4, 4, 5)
    ]
    assert picks[0] == picks[1] != picks[2]


def test_ask_and_tell_out_of_order_and_bad_options_are_refused():
    search = IntelligentTrialAndError(_grid_candidates(), 3)
    with pytest.raises(AskTellError, match="ask"):
        search.tell(0.5)
    search.ask()
    with pytest.raises(AskTellError, match="twice"):
        search.ask()
    with pytest.raises(AskTellError, match="finite"):
        search.tell(math.nan)
    with pytest.raises(ValueError, match="budget"):
        IntelligentTrialAndError(_grid_candidates(), 0)
    with pytest.raises(ValueError, match="stop_fraction"):
        ITEParameters(stop_fraction=1.5)


def _repertoire_file(directory, items, profile="paper"):
    """A run directory holding only a food repertoire of ``items`` and the configuration of its run."""
    directory.mkdir(parents=True, exist_ok=True)
    document = {"objective": "food", "items": items}
    (directory / "repertoire_food.json").write_text(json.dumps(document))
    config = RunConfig.make("qd", "food", 50, 0, profile=profile)
    (directory / "config.json").write_text(json.dumps(config.to_json()))
    return directory


SMALL = [
    {"bin": [2, 4, 7], "tree": "forward", "fitness": 0.90, "descriptors": [0.3, 0.5, 0.9], "evaluation": 1},
    {"bin": [2, 4, 7], "tree": "reverse", "fitness": 0.95, "descriptors": [0.3, 0.55, 0.9], "evaluation": 2},
    {
        "bin": [4, 6, 2],
        "tree": "sel(on_food, forward_left)",
        "fitness": 0.7,
        "descriptors": [0.5, 0.8, 0.3],
        "evaluation": 3,
    },
    {
        "bin": [7, 0, 0],
        "tree": "seq(food_left, forward)",
        "fitness": 0.6,
        "descriptors": [0.9, 0.1, 0.0],
        "evaluation": 4,
    },
]


def test_load_candidates_keeps_each_bins_best_and_refuses_bad_files(tmp_path):
    run = _repertoire_file(tmp_path / "run", SMALL)
    candidates = load_candidates(run, "food")
    assert [(c.bin, c.tree) for c in candidates] == [
        ((2, 4, 7), "reverse"),
        ((4, 6, 2), "sel(on_food, forward_left)"),
        ((7, 0, 0), "seq(food_left, forward)"),
    ]
    with pytest.raises(AdaptationError, match="no repertoire of nest"):
        load_candidates(run, "nest")
    with pytest.raises(AdaptationError, match="empty"):
        load_candidates(_repertoire_file(tmp_path / "empty", []), "food")
    (tmp_path / "bad").mkdir()
    (tmp_path / "bad" / "repertoire_food.json").write_text('{"items": [{"bin": [1]}]}')
    with pytest.raises(AdaptationError, match="not a repertoire file"):
        load_candidates(tmp_path / "bad", "food")
    # A bin's tree must be tree text that parses (found by the fuzz test: a null tree reached the evaluator).
    for tree, reason in [(None, "must be tree text, got None"), ("forwrd", "is not a tree: .*unknown")]:
        damaged = [{**SMALL[0], "tree": tree}, *SMALL[1:]]
        with pytest.raises(AdaptationError, match=f"the tree of bin \\[2, 4, 7\\] {reason}"):
            load_candidates(_repertoire_file(tmp_path / f"tree-{tree}", damaged), "food")


def test_a_repertoire_of_primitives_is_adapted_from_with_its_trees_written_out(tmp_path, capsys):
    document = {
        "format": 1,
        "primitives": [{"name": "toFood", "tree": "sel(seq(food_left, forward_left), forward)"}],
    }
    library = library_from_json(document, "lib.json")
    run = tmp_path / "run"
    run.mkdir()
    (run / "library.json").write_text(json.dumps(document))
    config = RunConfig.make(
        "qd", "foraging", 50, 0, task="foraging", library="lib.json", library_digest=library.digest
    )
    (run / "config.json").write_text(json.dumps(config.to_json()))
    items = [
        {"bin": [4, 4, 7], "tree": "sel(seq(got_food, in_nest), toFood)", "descriptors": [0.55, 0.55, 0.9]},
        {"bin": [7, 0, 0], "tree": "seq(food_left, forward)", "descriptors": [0.9, 0.1, 0.0]},
    ]
    items = [{**item, "fitness": 0.9 - k / 2, "evaluation": k} for k, item in enumerate(items)]
    (run / "repertoire_foraging.json").write_text(json.dumps({"items": items}))
    with pytest.raises(AdaptationError, match="unknown node 'toFood'"):
        load_candidates(run, "foraging")  # the primitive's name means nothing without the run's library
    setting = repertoire_setting(run)
    named = load_candidates(run, "foraging", setting.library)
    plain = written_out(named, setting.library)
    assert [c.tree for c in named] == [item["tree"] for item in items]
    assert "toFood" not in plain[0].tree and plain[1] == named[1]
    # the same tree, in text a controller without the library reads (what load_tree sends a robot)
    assert parse(plain[0].tree) == library.parse(items[0]["tree"])
    assert [(c.bin, c.prior, c.descriptors) for c in plain] == [
        (c.bin, c.prior, c.descriptors) for c in named
    ]
    assert written_out(named, None) == named
    # adapt-live takes such a run: it gets past the repertoire to the first check of its options
    args = ["--repertoire", str(run), "--objective", "foraging", "--faults", "1:ground-stuck"]
    args += ["--fault-at", "50", "--duration", "10", "--out", str(tmp_path / "live"), "--every", "0"]
    assert adapt_live_main(args) == 2
    assert "--fault-at 50.0 s is not before the trial's end" in capsys.readouterr().err


@pytest.mark.parametrize("profile", ["paper", "clean"])
def test_real_adaptation_with_the_batch_evaluator_stays_in_budget_and_records_everything(
    tmp_path, capsys, profile
):
    run = _repertoire_file(tmp_path / "run", SMALL, profile)
    args = ["--repertoire", str(run), "--objective", "food", "--condition", "dead-robots=4"]
    args += ["--condition", "message-loss=0.5", "--budget", "2", "--trials", "2", "--seed", "3", "--no-stop"]
    assert adapt([*args, "--out", str(tmp_path / "a")]) == 0
    assert adapt([*args, "--out", str(tmp_path / "b")]) == 0
    first = json.loads((tmp_path / "a" / "adaptation.json").read_text())
    second = json.loads((tmp_path / "b" / "adaptation.json").read_text())
    assert first == second
    assert first["conditions"] == {"dead-robots": 4, "message-loss": 0.5} and first["seed"] == 3
    assert first["profile"] == profile  # the repertoire's, from its config.json
    assert [t["tree"] for t in first["tried"]] == ["reverse", "sel(on_food, forward_left)"]
    assert first["fitness"] == max(t["fitness"] for t in first["tried"])
    assert first["tree"] in {item["tree"] for item in SMALL}
    assert (tmp_path / "a" / "adaptation.png").stat().st_size > 1000
    # Each trial is one evaluation in the changed world, which the evaluate command reproduces.
    config, _ = apply_conditions(["dead-robots=4", "message-loss=0.5"], replace(DEFAULT, profile=profile))
    evaluation = ConditionEvaluation(BatchEvaluator(config), 3, 2)
    assert [o.fitness[2] for o in evaluation(["reverse", "sel(on_food, forward_left)"])] == [
        t["fitness"] for t in first["tried"]
    ]
    capsys.readouterr()
    assert adapt([*args, "--out", str(tmp_path / "a")]) == 2  # never overwritten
    assert "already holds an adaptation" in capsys.readouterr().err


@pytest.mark.parametrize(
    ("extra", "says"),
    [
        (
            ["--condition", "dead-robots=99"],
            "--condition: condition dead-robots=99: expected a number of robots",
        ),
        (["--condition", "wings=2"], "unknown condition 'wings'"),
        (["--budget", "0"], "expected a positive integer"),
        (["--stop-fraction", "2"], "stop_fraction must be in (0, 1]"),
    ],
)
def test_bad_adapt_options_are_one_line_errors(tmp_path, capsys, extra, says):
    run = _repertoire_file(tmp_path / "run", SMALL)
    args = ["--repertoire", str(run), "--objective", "food", "--out", str(tmp_path / "out"), *extra]
    assert adapt(args) == 2
    err = capsys.readouterr().err
    assert says in err and err.count("\n") == 1
    assert not (tmp_path / "out").exists()


def test_reevolution_spends_exactly_its_budget_in_the_changed_world():
    config, _ = apply_conditions(["weak-wheel=9:0.5"])
    evaluation = ConditionEvaluation(BatchEvaluator(config), 1, 1)
    for algorithm in ("qd", "gp"):
        trees, fitness = reevolve(algorithm, "food", 30, 2, evaluation)
        assert len(trees) == len(fitness) == 30
        assert all(0.0 <= f <= 1.0 for f in fitness)


class _KilledAfter(ConditionEvaluation):
    """Evaluations that stop the search (as a kill would) at their ``calls``-th batch."""

    def __init__(self, evaluator, seed, trials, calls):
        super().__init__(evaluator, seed, trials)
        self.calls = calls

    def __call__(self, trees):
        self.calls -= 1
        if self.calls == 0:
            raise KeyboardInterrupt
        return super().__call__(trees)


@pytest.mark.parametrize("algorithm", ["qd", "gp"])
def test_a_killed_reevolution_continues_from_its_checkpoint_as_if_never_killed(tmp_path, algorithm):
    config, _ = apply_conditions(["weak-wheel=9:0.5"])
    budget = 190  # MAP-Elites: its first batch of 100, then batches of 50; GP: generations of 25
    whole = ConditionEvaluation(BatchEvaluator(config), 1, 1)
    expected = reevolve(algorithm, "food", budget, 2, whole)
    checkpoint = SearchCheckpoint(tmp_path / "ceiling.json", {"algorithm": algorithm}, every=0.0)
    with pytest.raises(KeyboardInterrupt):
        killed = _KilledAfter(BatchEvaluator(config), 1, 1, calls=3)
        reevolve(algorithm, "food", budget, 2, killed, None, checkpoint)
    saved = saved_search(checkpoint)
    assert saved is not None and 0 < len(saved["trees"]) < budget
    again = ConditionEvaluation(BatchEvaluator(config), 1, 1)
    assert reevolve(algorithm, "food", budget, 2, again, None, checkpoint) == expected
    assert again.simulated == whole.simulated  # what was simulated before the kill is not simulated again
    assert saved_search(SearchCheckpoint(checkpoint.path, {"algorithm": "other"})) is None


def test_a_damaged_reevolution_checkpoint_is_named_and_left_as_it_is(tmp_path):
    config, _ = apply_conditions(["weak-wheel=9:0.5"])
    path = tmp_path / "ceiling.json"
    path.write_text('{"key": {"algorithm": "qd"}, "search": ')
    checkpoint = SearchCheckpoint(path, {"algorithm": "qd"})
    with pytest.raises(AdaptationError, match=r"ceiling\.json.*remove it to start that search afresh"):
        reevolve("qd", "food", 30, 2, ConditionEvaluation(BatchEvaluator(config), 1, 1), None, checkpoint)
    path.write_text('{"key": {"algorithm": "qd"}, "search": {}, "trees": [], "fitness": []}')
    with pytest.raises(AdaptationError, match="is damaged"):
        reevolve("qd", "food", 30, 2, ConditionEvaluation(BatchEvaluator(config), 1, 1), None, checkpoint)
    assert path.read_text().startswith('{"key": {"algorithm": "qd"}, "search": {}')
