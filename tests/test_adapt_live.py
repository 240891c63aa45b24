"""adapt-live end to end: a small swarm runs one trial through the node graph, faults are injected into the
running simulator, the adaptation node swaps a tree into the faulty robot through load_tree, and the bag holds
the faults, the swap and the windows' performance."""

import json

from evolution_manager.adaptation.adapt_live import main
from evolution_manager.evolution.run_config import RunConfig
from evolution_manager.recording.bags import read_bag
from evolution_manager.recording.reproduce import RESULT_TOPIC
from evolution_manager.viewing.frames import frames_from_bag

ITEMS = [
    {
        "bin": [4, 4, 7],
        "tree": "sel(seq(on_food, stop), seq(food_left, forward_left), forward)",
        "fitness": 0.95,
        "descriptors": [0.55, 0.55, 0.9],
    },
    {"bin": [4, 6, 2], "tree": "sel(on_food, forward_left)", "fitness": 0.9, "descriptors": [0.5, 0.8, 0.3]},
    {"bin": [7, 0, 0], "tree": "seq(food_left, forward)", "fitness": 0.6, "descriptors": [0.9, 0.1, 0.0]},
]


def test_a_fault_injected_live_is_answered_by_a_swap_recorded_in_the_bag(tmp_path):
    run = tmp_path / "run"
    run.mkdir()
    items = [{"evaluation": k, **item} for k, item in enumerate(ITEMS)]
    (run / "repertoire_food.json").write_text(json.dumps({"items": items}))
    (run / "config.json").write_text(
        json.dumps(RunConfig.make("qd", "food", 50, 0, profile="clean").to_json())
    )
    out = tmp_path / "live"
    args = ["--repertoire", str(run), "--objective", "food", "--robots", "3", "--seed", "3", "--every", "0"]
    args += ["--faults", "0:ground-stuck 1:ground-stuck", "--fault-at", "4", "--duration", "14"]
    args += ["--window", "2", "--budget", "1", "--stop-fraction", "1", "--out", str(out)]
    assert main(args) == 0
    document = json.loads((out / "adaptation_live.json").read_text())
    assert document["faulty"] == [0, 1] and document["fault_step"] == 33
    swaps = [e for e in document["events"] if e["kind"] == "swap"]
    assert swaps and swaps[0]["robots"] == [0, 1] and swaps[0]["trial"] == 1
    # held at each window's end (hold_step), the swap lands on the step after the window that chose it
    assert document["swaps_retimed"] == 0 and swaps[0]["step"] == document["windows"][2]["end"] + 1
    messages = list(read_bag(out / "live.bag"))
    faults = [m.message for m in messages if m.topic == "/faults"]
    assert [list(f.kinds) for f in faults] == [["", "", ""], ["ground-stuck", "ground-stuck", ""]]
    assert faults[1].step == 33
    events = [m.message for m in messages if m.topic == "/adaptation"]
    assert [e.kind for e in events] == [e["kind"] for e in document["events"]]
    swapped = [e for e in events if e.kind == "swap"]
    assert [(list(e.robots), e.step) for e in swapped] == [(e["robots"], e["step"]) for e in swaps]
    first = swapped[0]
    assert first.trees[0] == first.trees[1] != first.trees[2] == ITEMS[0]["tree"]  # the faulty robots' tree
    windows = [e for e in events if e.kind == "window"]
    assert windows[0].phase == "before-fault" and windows[2].phase == "after-fault"
    assert windows[2].measure < windows[2].target  # the fault cost performance: hence the swap
    assert all(0.0 <= w.measure <= 1.0 for w in windows)
    assert len([m for m in messages if m.topic == RESULT_TOPIC]) == 1
    frames = frames_from_bag(out / "live.bag")  # the animation marks the faulty and the swapped robots
    assert frames.faulty is not None and frames.swapped is not None
    steps = list(frames.steps)
    assert not frames.faulty[steps.index(32)].any()
    assert frames.faulty[steps.index(33)].tolist() == [True, True, False]
    assert not frames.swapped[steps.index(first.step) - 1].any()
    assert frames.swapped[steps.index(swapped[-1].step)].tolist() == [True, True, False]
