"""adapt --graph: every candidate loaded into the controller nodes and run by the simulator node in the
changed world, recorded, under the repertoire's model profile (here ``clean``); it chooses the same tree with
the same fitness as the batch road."""

import json

from bt_controller.language import library_from_json, parse
from evolution_manager.adaptation.adapt import adapt
from evolution_manager.evolution.run_config import RunConfig
from evolution_manager.graph.nodes.trial import RESULT_TOPIC
from evolution_manager.recording.bags import read_bag
from swarm_sim.evaluation import named_values
from swarm_sim.tasks import task_named

TRIAL_START_TOPIC = "/trial_start"

ITEMS = [
    {"bin": [2, 4, 7], "tree": "reverse", "fitness": 0.95, "descriptors": [0.3, 0.55, 0.9], "evaluation": 1},
    {"bin": [4, 6, 2], "tree": "sel(on_food, forward_left)", "fitness": 0.9, "descriptors": [0.5, 0.8, 0.3]},
    {"bin": [7, 0, 0], "tree": "seq(food_left, forward)", "fitness": 0.6, "descriptors": [0.9, 0.1, 0.0]},
]


def test_graph_and_batch_roads_choose_the_same_tree(tmp_path):
    run = tmp_path / "run"
    run.mkdir()
    items = [{"evaluation": k, **item} for k, item in enumerate(ITEMS)]
    (run / "repertoire_food.json").write_text(json.dumps({"items": items}))
    config = RunConfig.make("qd", "food", 50, 0, profile="clean")
    (run / "config.json").write_text(json.dumps(config.to_json()))
    args = ["--repertoire", str(run), "--objective", "food", "--budget", "2", "--trials", "1", "--seed", "5"]
    args += ["--condition", "robots=5", "--condition", "dead-robots=2", "--condition", "message-loss=0.4"]
    args += ["--no-stop"]
    assert adapt([*args, "--out", str(tmp_path / "batch")]) == 0
    assert adapt([*args, "--graph", "--out", str(tmp_path / "graph")]) == 0
    batch = json.loads((tmp_path / "batch" / "adaptation.json").read_text())
    graph = json.loads((tmp_path / "graph" / "adaptation.json").read_text())
    assert graph["road"] == "graph" and batch["road"] == "batch"
    assert graph["profile"] == batch["profile"] == "clean"
    assert (graph["tree"], graph["fitness"]) == (batch["tree"], batch["fitness"])
    assert graph["tried"] == batch["tried"]
    assert len(graph["tried"]) == 2
    bags = sorted((tmp_path / "graph" / "bags").iterdir())
    assert [b.name for b in bags] == ["evaluation_001_trial_00", "evaluation_002_trial_00"]
    for bag, tried in zip(bags, graph["tried"], strict=True):
        results = [m for m in read_bag(bag) if m.topic == RESULT_TOPIC]
        assert len(results) == 1
        assert results[0].message.tree == tried["tree"]
        assert (
            named_values(results[0].message)["food"] == tried["fitness"]
        )  # one trial: the evaluation is that trial
        assert results[0].message.profile == "clean"


def test_graph_adapts_a_foraging_repertoire_of_primitives_on_its_own_task(tmp_path):
    """A repertoire evolved over a library, on the foraging task: the graph runs that task (its 200-tick
    trials, not the primitives'), the controllers get each tree with its primitives written out, and the
    choice and its fitness are the batch road's."""
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
        {"bin": [4, 4, 7], "tree": "sel(seq(got_food, nest_left, forward_left), toFood)", "fitness": 0.9},
        {"bin": [7, 0, 0], "tree": "seq(food_left, forward)", "fitness": 0.4},
    ]
    items = [
        {**item, "descriptors": [b / 8 for b in item["bin"]], "evaluation": k} for k, item in enumerate(items)
    ]
    (run / "repertoire_foraging.json").write_text(json.dumps({"items": items}))
    args = ["--repertoire", str(run), "--objective", "foraging", "--budget", "2", "--trials", "1"]
    args += ["--seed", "3", "--condition", "robots=4", "--condition", "dead-robots=1", "--no-stop"]
    assert adapt([*args, "--out", str(tmp_path / "batch")]) == 0
    assert adapt([*args, "--graph", "--out", str(tmp_path / "graph")]) == 0
    batch = json.loads((tmp_path / "batch" / "adaptation.json").read_text())
    graph = json.loads((tmp_path / "graph" / "adaptation.json").read_text())
    assert [t["fitness"] for t in graph["tried"]] == [t["fitness"] for t in batch["tried"]]
    assert graph["fitness"] == batch["fitness"]
    # the batch road keeps the library's names; the graph's trees are the same trees written out
    assert batch["tried"][0]["tree"] == items[0]["tree"]
    assert "toFood" not in graph["tried"][0]["tree"]
    assert parse(graph["tried"][0]["tree"]) == library.parse(items[0]["tree"])
    first = sorted((tmp_path / "graph" / "bags").iterdir())[0]
    starts = [m.message for m in read_bag(first) if m.topic == TRIAL_START_TOPIC]
    assert starts and {s.ticks for s in starts} == {task_named("foraging").trials.ticks} == {200}
