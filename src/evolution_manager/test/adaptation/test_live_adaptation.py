"""Live adaptation's pure core (``evolution_manager.adaptation.live``): a window's measure is the task's
objective, and the state machine goes from the windows before a fault, through the trials Intelligent Trial
and Error asks for, to the tree that brings the swarm back (or the best tried)."""

import json
import math
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from evolution_manager.adaptation.live import LiveAdaptation, LiveSettings, window_measure
from evolution_manager.adaptation.search import AdaptationError, Candidate
from swarm_sim.model import DEFAULT

CAP = DEFAULT.params().estimate_cap
CANDIDATES = [
    Candidate((0, 0, 0), "forward", 0.9, (0.05, 0.05, 0.05)),
    Candidate((3, 3, 3), "sel(on_food, forward_left)", 0.7, (0.4, 0.4, 0.4)),
    Candidate((7, 7, 7), "reverse", 0.6, (0.9, 0.9, 0.9)),
]
SETTINGS = LiveSettings(window=40, lead=4, budget=2, stop_fraction=0.9, swap="faulty")


def _values(food):
    """Smoothed (nest, food, density) per robot with the given food estimates."""
    return np.array([[1000.0, f, 0.5] for f in food])


def test_the_food_measure_is_the_food_objective_over_the_window_averaged_over_robots():
    initial = _values([2000.0, 2000.0, 1000.0])
    final = _values([0.0, 1000.0, 3000.0])
    no_deliveries = np.zeros((3, 1), dtype=np.int64)
    expected = [1.0, 0.5 * (1000.0 / CAP + 1.0), 0.5 * (-2000.0 / CAP + 1.0)]  # final 0: 1
    assert window_measure("food", initial, final, no_deliveries, DEFAULT) == pytest.approx(np.mean(expected))
    assert window_measure("foraging", initial, final, np.array([[2], [0], [1]]), DEFAULT) == pytest.approx(
        1.0
    )
    # the balanced measure is the swarm's: 3 x its least kind per robot (kinds 2 and 3 once each, of 3 robots)
    kinds = np.array([[2, 0, 1], [0, 1, 0], [1, 0, 0]])
    assert window_measure("foraging_balanced", initial, final, kinds, DEFAULT) == pytest.approx(1.0)


def test_objectives_read_from_true_positions_are_not_measured_live():
    with pytest.raises(AdaptationError, match="cannot be measured live"):
        window_measure("ifood", _values([0.0]), _values([0.0]), np.zeros((1, 1)), DEFAULT)
    with pytest.raises(AdaptationError, match="shapes"):
        window_measure("food", _values([0.0, 1.0]), _values([0.0]), np.zeros((1, 1)), DEFAULT)


def _before_fault(core, measures=(0.8, 0.8)):
    for measure in measures:
        assert core.close_window(measure) is None
    return core


def test_windows_follow_each_other_until_the_fault_and_set_the_target():
    core = _before_fault(LiveAdaptation(CANDIDATES, 6, SETTINGS, first_step=1))
    assert [(w.start, w.end, w.phase) for w in core.windows] == [
        (1, 40, "before-fault"),
        (41, 80, "before-fault"),
    ]
    assert core.target == pytest.approx(0.72)
    assert core.trees == ["forward"] * 6  # the repertoire's best on every robot


def test_a_fault_that_hurts_starts_trials_on_the_faulty_robots_until_performance_is_back():
    core = _before_fault(LiveAdaptation(CANDIDATES, 6, SETTINGS))
    core.fault(95, [4, 1])
    assert (core.start, core.phase, core.faulty) == (95, "after-fault", (1, 4))
    swap = core.close_window(0.3)  # the unchanged trees under the fault: far below 0.72
    assert swap is not None and swap.trial == 1 and swap.robots == (1, 4)
    assert swap.step == 134 + 4 and core.start == swap.step  # lead steps after the window's last step
    assert swap.tree != "forward" and core.trees == [
        "forward",
        swap.tree,
        "forward",
        "forward",
        swap.tree,
        "forward",
    ]
    assert core.unchanged == 0.3 and core.search is not None
    assert [t.tree for t in core.search.tried] == [
        "forward"
    ]  # told the unchanged window as the best's fitness
    assert core.close_window(0.75) is None  # back above the target: kept
    assert core.phase == "kept" and core.stop_reason.startswith("recovered at trial 1")
    assert core.windows[-1].phase == "trial" and core.windows[-1].trial == 1
    assert core.close_window(0.7) is None and core.windows[-1].phase == "kept"


def test_when_the_budget_is_spent_the_best_tree_tried_comes_back():
    core = _before_fault(LiveAdaptation(CANDIDATES, 4, SETTINGS))
    core.fault(81, [2])
    first = core.close_window(0.2)
    second = core.close_window(0.6)  # trial 1: better, still below the target
    assert first is not None and second is not None and second.tree not in (first.tree, "forward")
    final = core.close_window(0.4)  # trial 2: worse; the budget of 2 is spent
    assert final is not None and final.trial == 0 and final.tree == first.tree and final.robots == (2,)
    assert core.phase == "kept" and "budget of 2 trials spent" in core.stop_reason
    assert core.trees[2] == first.tree and core.trees[0] == "forward"


def test_the_unchanged_tree_stays_when_it_was_the_best_and_every_robot_can_be_swapped():
    settings = LiveSettings(window=40, lead=4, budget=1, swap="all")
    core = _before_fault(LiveAdaptation(CANDIDATES, 3, settings))
    core.fault(81, [0])
    trial = core.close_window(0.5)
    assert trial is not None and trial.robots == (0, 1, 2)
    back = core.close_window(0.1)
    assert back is not None and back.tree == "forward" and core.trees == ["forward"] * 3


def test_a_fault_the_swarm_shrugs_off_changes_nothing():
    core = _before_fault(LiveAdaptation(CANDIDATES, 3, SETTINGS))
    core.fault(81, [1])
    assert core.close_window(0.79) is None
    assert core.phase == "kept" and "nothing to adapt" in core.stop_reason and core.swaps == []


def test_watching_a_fault_that_left_the_swarm_at_the_target_adapts_when_its_harm_shows_late():
    core = _before_fault(LiveAdaptation(CANDIDATES, 3, replace(SETTINGS, watch=True)))
    core.fault(81, [1])
    assert core.close_window(0.79) is None and core.swaps == []  # at the target (0.72): nothing yet
    assert core.phase == "kept" and "watching" in core.stop_reason and core.watching
    assert core.close_window(0.75) is None and core.swaps == []  # still at the target
    swap = core.close_window(0.3)  # the harm shows: the trials start as after the fault
    assert swap is not None and swap.trial == 1 and swap.robots == (1,) and swap.step == 200 + 4
    assert core.unchanged == 0.3 and core.phase == "trial" and not core.watching and core.stop_reason == ""
    assert [t.tree for t in core.search.tried] == ["forward"]  # told the late window as the best's fitness
    assert [(w.phase, w.trial) for w in core.windows[2:]] == [("after-fault", 0), ("kept", 0), ("kept", 0)]
    assert core.close_window(0.8) is None and core.stop_reason.startswith("recovered at trial 1")
    assert core.close_window(0.1) is None and core.swaps == [swap]  # once recovered, no more watching
    unwatched = _before_fault(LiveAdaptation(CANDIDATES, 3, SETTINGS))
    unwatched.fault(81, [1])
    assert unwatched.close_window(0.79) is None and unwatched.close_window(0.3) is None
    assert unwatched.swaps == [] and "nothing to adapt" in unwatched.stop_reason


def test_a_fault_before_the_first_window_ended_is_refused_and_a_late_one_drops_the_windows_it_struck():
    core = LiveAdaptation(CANDIDATES, 3, SETTINGS)
    with pytest.raises(AdaptationError, match="before the first window ended"):
        core.fault(20, [0])
    core = _before_fault(LiveAdaptation(CANDIDATES, 3, SETTINGS), (0.8, 0.4))
    core.fault(60, [0])  # announced after the second window (41..80) had closed: it measured the fault
    assert [w.end for w in core.windows] == [40] and core.target == pytest.approx(0.72)


def test_a_swap_that_came_too_late_is_made_again_later_with_its_window():
    core = _before_fault(LiveAdaptation(CANDIDATES, 3, SETTINGS))
    core.fault(81, [1])
    swap = core.close_window(0.1)
    again = core.swap_refused(130)
    assert (again.step, again.tree, again.robots) == (134, swap.tree, swap.robots)
    assert core.swaps == [again] and core.start == 134


def test_settings_and_measures_are_checked():
    for bad in ({"window": 0}, {"lead": 1.5}, {"stop_fraction": 0.0}, {"swap": "some"}, {"watch": 1}):
        with pytest.raises(AdaptationError):
            LiveSettings(**bad)
    with pytest.raises(AdaptationError, match="finite"):
        LiveAdaptation(CANDIDATES, 3, SETTINGS).close_window(math.nan)


def test_a_fault_announced_before_the_window_before_it_was_measured_waits_for_that_window():
    core = _before_fault(LiveAdaptation(CANDIDATES, 3, SETTINGS), (0.8,))
    core.fault(81, [2])  # the window 41..80 is still under way: its last answers have not come
    assert core.phase == "before-fault" and core.start == 41
    assert core.close_window(0.6) is None
    assert [w.end for w in core.windows] == [40, 80] and core.target == pytest.approx(0.63)
    assert (core.phase, core.start, core.faulty) == ("after-fault", 81, (2,))


def _live_table(adapted: dict, control: dict) -> list[str]:
    """The window table of docs/results/adaptation/live-foraging/README.md: each window of the adapted run
    beside the same window of the control run (the same command, nothing adapted), each as deliveries per
    robot and as the swarm's deliveries."""
    robots = adapted["robots"]
    seconds = adapted["settings"]["window"] / 8  # 8 steps a simulated second
    bins = {e["trial"]: e["bin"] for e in adapted["events"] if e["kind"] == "swap"}
    before = len([w for w in adapted["windows"] if w["phase"] == "before-fault"])
    reference = before - adapted["settings"]["reference"]

    def cell(measure: float) -> str:
        count = round(measure * robots)
        assert math.isclose(measure * robots, count)  # the foraging measure: deliveries per robot
        return f"{measure:.3f} ({count})"

    rows = []
    for k, (mine, theirs) in enumerate(zip(adapted["windows"], control["windows"], strict=True)):
        assert (mine["start"], mine["end"]) == (theirs["start"], theirs["end"])
        span = f"{(mine['start'] - 1) / 8:g}-{mine['end'] / 8:g}"
        phase, trial = mine["phase"], mine["trial"]
        if phase == "before-fault":
            label, trees = (
                ("before the fault (the reference)" if k >= reference else "before the fault"),
                "best",
            )
        elif phase == "after-fault":
            label, trees = "after the fault", "best"
        elif phase == "trial":
            label, trees = f"trial {trial}", f"bin {bins[trial]}"
        else:
            label, trees = "kept", f"bin {bins[trial]} (trial {trial})"
        rows.append(f"| {span} | {label} | {trees} | {cell(mine['measure'])} | {cell(theirs['measure'])} |")
        assert mine["end"] - mine["start"] + 1 == seconds * 8
    after = [k for k, w in enumerate(adapted["windows"]) if w["phase"] == "kept"]
    means = [np.mean([run["windows"][k]["measure"] for k in after]) for run in (adapted, control)]
    rows.append(f"| mean of the {len(after)} kept windows | | | {means[0]:.3f} | {means[1]:.3f} |")
    totals = [round(sum(w["measure"] for w in run["windows"]) * robots) for run in (adapted, control)]
    rows.append(f"| the whole trial (every window) | | | {totals[0]} deliveries | {totals[1]} deliveries |")
    return rows


def _seed_row(run: dict) -> str:
    """One row of the README's table of seeds: the run's kind, the reference, the window after the fault, the
    trees tried, why it stopped, the mean of its last 10 windows (320-720 s) and its deliveries."""
    robots = run["robots"]
    kind = "control" if run["settings"]["stop_fraction"] < 0.5 else "adapted"
    kind += ", --watch" if run["settings"].get("watch") else ""
    kind += ", --swap all" if run["settings"]["swap"] == "all" else ""
    before = [w["measure"] for w in run["windows"] if w["phase"] == "before-fault"]
    reference = float(np.mean(before[-run["settings"]["reference"] :]))
    after = next(w["measure"] for w in run["windows"] if w["phase"] == "after-fault")
    tried = ", ".join(str(e["bin"]) for e in run["events"] if e["kind"] == "swap" and e["trial"]) or "none"
    last = float(np.mean([w["measure"] for w in run["windows"][-10:]]))
    total = round(sum(w["measure"] for w in run["windows"]) * robots)
    return (
        f"| {run['seed']} | {kind} | {reference:.3f} | {after:.3f} | {tried} | {run['stopped']} | "
        f"{last:.3f} | {total} |"
    )


def test_the_committed_live_foraging_readmes_table_is_its_adaptation_live_json():
    """docs/results/adaptation/live-foraging: the README's windows, phases, trees and measures, the adapted
    run's beside the control's, recomputed from the two adaptation_live.json; the control ran the same trial
    to the fault and kept the repertoire's best tree."""
    folder = Path(__file__).resolve().parents[4] / "docs" / "results" / "adaptation" / "live-foraging"
    adapted = json.loads((folder / "adaptation_live.json").read_text())
    control = json.loads((folder / "control" / "adaptation_live.json").read_text())
    readme = (folder / "README.md").read_text()
    for row in _live_table(adapted, control):
        assert row in readme, row
    windows = [(w["measure"], w["phase"]) for w in adapted["windows"]]
    first_swap = min(e["step"] for e in adapted["events"] if e["kind"] == "swap")
    same = [w for w in adapted["windows"] if w["end"] < first_swap]
    assert [w["measure"] for w in same] == [w["measure"] for w in control["windows"][: len(same)]]
    assert control["trials_used"] == 0 and "nothing to adapt" in control["stopped"]
    assert adapted["stopped"] in readme and windows[-1][1] == "kept"
    assert f"target {adapted['target']:.3f}" in readme
    runs = sorted(folder.glob("**/adaptation_live.json"))
    assert len(runs) == 7
    for path in runs:
        assert _seed_row(json.loads(path.read_text())) in readme, path
