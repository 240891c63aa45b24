"""The explorer page and the trial animation: the animation reads the poses the node graph recorded, and the
explorer page of a small run, loaded in headless Chromium from file:// with a fragment, shows the chosen bin's
trees, values and animation, and exactly the filled bins of the run's repertoire files."""

from __future__ import annotations

import json
import subprocess
from html.parser import HTMLParser
from pathlib import Path

import numpy as np
import pytest
from headless import dump_dom
from PIL import Image

from bt_controller.language import parse, simplify, to_text
from bt_controller.robot import timeline
from evolution_manager.graph.startup import executable
from evolution_manager.recording.bags import read_bag
from evolution_manager.viewing.frames import frames_from_bag, frames_from_tree
from swarm_sim.model import DEFAULT

TREE = "sel(seq(robot_left, forward_left), prob(forward, reverse_right), seq(in_nest, in_nest, stop))"
SEED, TRIAL = 13, 1
STEPS = timeline.trial_steps(DEFAULT.timeline)
"""Control steps of one trial (160 under the paper profile)."""


def test_animation_frames_are_the_poses_the_graph_recorded(graph, tmp_path):
    bag = tmp_path / "trial.bag"
    graph.run(TREE, SEED, TRIAL, bag)
    states = [m.message for m in read_bag(bag) if m.topic == "/swarm_state"]
    recorded = {state.step: state for state in states if state.trial == TRIAL}
    assert len(states) == (TRIAL + 1) * len(recorded)  # the chain's earlier trial is in the bag, not drawn
    frames = frames_from_bag(bag)
    assert len(frames.steps) == len(recorded) == STEPS  # one frame per step of trial TRIAL
    for k, step in enumerate(frames.steps):
        poses = [[p.x, p.y, p.theta] for p in recorded[int(step)].poses]
        assert frames.poses[k].tolist() == poses
    # the in-process road gives the same frames: poses, actions, messages and fitness so far
    twin = frames_from_tree(TREE, SEED, TRIAL)
    np.testing.assert_array_equal(twin.poses, frames.poses)
    np.testing.assert_array_equal(twin.actions, frames.actions)
    np.testing.assert_array_equal(twin.ticks, frames.ticks)
    assert all(np.array_equal(a, b) for a, b in zip(twin.links, frames.links, strict=True))
    np.testing.assert_allclose(twin.fitness, frames.fitness, rtol=0, atol=1e-12)

    gif = tmp_path / "trial.gif"
    done = subprocess.run(
        [str(executable("evolution_manager", "animate")), "--bag", str(bag), "--out", str(gif)],
        capture_output=True,
        text=True,
        timeout=300,
    )
    assert done.returncode == 0, done.stderr
    with Image.open(gif) as image:
        assert image.n_frames == STEPS


class _Elements(HTMLParser):
    """Every element's tag and attributes, and the text inside #values."""

    def __init__(self) -> None:
        super().__init__()
        self.elements: list[tuple[str, dict[str, str]]] = []
        self.values_text: list[str] = []
        self._in_values = 0

    def handle_starttag(self, tag: str, attrs: list) -> None:
        attributes = {k: v or "" for k, v in attrs}
        self.elements.append((tag, attributes))
        if attributes.get("id") == "values" or self._in_values:
            self._in_values += 1

    def handle_endtag(self, tag: str) -> None:
        if self._in_values:
            self._in_values -= 1

    def handle_data(self, data: str) -> None:
        if self._in_values:
            self.values_text.append(data)

    def find(self, tag: str | None = None, **attrs: str) -> list[dict[str, str]]:
        wanted = {k.rstrip("_").replace("_", "-"): v for k, v in attrs.items()}
        return [
            a
            for t, a in self.elements
            if (tag is None or t == tag) and all(a.get(k) == v for k, v in wanted.items())
        ]


def rendered(page: Path, fragment: str) -> _Elements:
    parser = _Elements()
    parser.feed(dump_dom(page, fragment))
    return parser


@pytest.fixture(scope="module")
def small_run(tmp_path_factory):
    out = tmp_path_factory.mktemp("explorer") / "run"
    done = subprocess.run(
        [str(executable("evolution_manager", "evolve")), "--algorithm", "qd", "--objective", "food",
         "--evaluations", "150", "--seed", "4", "--out", str(out), "--no-progress"],
        capture_output=True, text=True, timeout=900,
    )  # fmt: skip
    assert done.returncode == 0, done.stderr[-3000:]
    return out


def filled_bins(repertoire: Path) -> set[str]:
    return {",".join(map(str, item["bin"])) for item in json.loads(repertoire.read_text())["items"]}


def test_the_run_shows_its_trees_simplified_with_the_originals_kept(small_run):
    for objective in ("density", "nest", "food"):
        for item in json.loads((small_run / f"repertoire_{objective}.json").read_text())["items"]:
            assert item["simplified"] == to_text(simplify(parse(item["tree"])))
    best = json.loads((small_run / "summary.json").read_text())["objectives"]["food"]
    assert (small_run / "best/food.txt").read_text().strip() == best["best_tree_simplified"]
    assert (small_run / "best/food.original.txt").read_text().strip() == best["best_tree"]
    for suffix in ("xml", "dot", "svg"):
        assert (small_run / f"best/food.{suffix}").stat().st_size > 0
    with Image.open(small_run / "best/food.png") as png:
        assert png.format == "PNG"


def test_explorer_opens_the_bin_of_the_fragment(small_run):
    page = small_run / "explorer.html"
    assert page.stat().st_size < 5_000_000
    document = json.loads((small_run / "repertoire_food.json").read_text())
    best = max(document["items"], key=lambda item: item["fitness"])
    bin_text = ",".join(map(str, best["bin"]))
    dom = rendered(page, f"objective=food&bin={bin_text}")

    cells = [a for a in dom.find("rect") if "cell" in a.get("class", "").split()]
    assert len(cells) == 512
    assert {a["data-bin"] for a in cells if "filled" in a["class"].split()} == filled_bins(
        small_run / "repertoire_food.json"
    )
    assert next(a for a in cells if "selected" in a["class"].split())["data-bin"] == bin_text

    assert dom.find("section", id="detail", data_objective="food", data_bin=bin_text)
    in_bin = sorted((i for i in document["items"] if i["bin"] == best["bin"]), key=lambda i: -i["fitness"])
    shown = {
        i["simplified"]: i for i in reversed(in_bin)
    }  # the fittest of each simplified tree stands for it
    values = " ".join(dom.values_text)
    for item in shown.values():
        assert f"{item['fitness']:.4f}" in values
        assert all(f"{d:.4f}" in values for d in item["descriptors"])
    drawn = {a["data-tree"] for a in dom.find("div") if "tree" in a.get("class", "").split()}
    assert best["simplified"] in drawn and best["tree"] in drawn
    assert dom.find("svg", class_="tree-drawing")
    (canvas,) = dom.find("canvas", id="animation")
    assert int(canvas["data-frames"]) == STEPS // 2 + 1  # every second step of the trial, and the last
    assert canvas["data-tree"] == best["simplified"]


def test_explorer_heatmaps_of_another_objective(small_run):
    dom = rendered(small_run / "explorer.html", "objective=nest")
    filled = {a["data-bin"] for a in dom.find("rect") if "filled" in a.get("class", "").split()}
    assert filled == filled_bins(small_run / "repertoire_nest.json")
    assert dom.find("div", id="heatmaps", data_objective="nest")
    assert dom.find("section", id="detail", data_bin="")


def test_explorer_colours_by_held_out_fitness_from_the_runs_heldout_json(small_run):
    heldout = json.loads((small_run / "heldout.json").read_text())["objectives"]["food"]["bins"]
    scored = {",".join(map(str, row["bin"])): row["heldout_fitness"] for row in heldout}
    assert scored, "the run wrote no held-out scores"
    best_bin = max(scored, key=lambda b: scored[b])
    dom = rendered(small_run / "explorer.html", f"objective=food&bin={best_bin}&colour=held-out")
    assert dom.find("div", id="heatmaps", data_colour="held-out")
    cells = {a["data-bin"]: a for a in dom.find("rect") if "filled" in a.get("class", "").split()}
    assert {b: float(a["data-value"]) for b, a in cells.items() if a["data-value"]} == pytest.approx(
        scored, abs=5e-5
    )
    values = " ".join(dom.values_text)
    assert f"{scored[best_bin]:.4f}" in values  # held-out beside in-run fitness in the bin's table
    in_run = rendered(small_run / "explorer.html", f"objective=food&bin={best_bin}")
    assert in_run.find("div", id="heatmaps", data_colour="in-run")
    food = json.loads((small_run / "repertoire_food.json").read_text())["items"]
    best_in_run = {}
    for item in food:
        key = ",".join(map(str, item["bin"]))
        best_in_run[key] = max(best_in_run.get(key, 0.0), item["fitness"])
    shown = {a["data-bin"]: float(a["data-value"]) for a in in_run.find("rect") if a.get("data-value")}
    assert shown == pytest.approx(best_in_run, abs=5e-5)


def test_explorer_shows_trees_that_simplify_alike_once_with_their_count(small_run):
    food = json.loads((small_run / "repertoire_food.json").read_text())["items"]
    by_bin: dict[str, list[str]] = {}
    for item in food:
        by_bin.setdefault(",".join(map(str, item["bin"])), []).append(item["simplified"])
    clones = {b: s for b, s in by_bin.items() if len(set(s)) < len(s)}
    page = (small_run / "explorer.html").read_text()
    payload = page.split('<script type="application/json" id="data">', 1)[1].split("</script>", 1)[0]
    data = json.loads(payload.replace("<\\/", "</"))
    for key, simplified in by_bin.items():
        items = data["objectives"]["food"]["bins"][key]
        assert sorted(i["simplified"] for i in items) == sorted(set(simplified))  # each simplified tree once
        assert sum(i["copies"] for i in items) == len(simplified)
    if clones:  # a bin with copies says how many in the browser
        key = next(iter(clones))
        dom = rendered(small_run / "explorer.html", f"objective=food&bin={key}")
        assert dom.find("div", class_="tree copies")


def test_a_run_on_a_task_s_own_regions_shows_them_in_its_explorer(tmp_path):
    """A run of a task whose regions are not the papers' arena (the authors' arena 9 with its three food
    kinds, shortened): its explorer is written (valid JSON: no NaN gap), decodes the poses in the task's arena
    and draws every piece of the trial's regions, each kind in its colour (the food kinds, then the nest)."""
    shown = subprocess.run(
        [str(executable("swarm_sim", "task")), "arena", "9", "--bias", "1"],
        capture_output=True,
        text=True,
        check=True,
    )
    task_file = tmp_path / "arena9.yaml"
    task_file.write_text(shown.stdout.replace("ticks: 200", "ticks: 20"))
    out = tmp_path / "run"
    done = subprocess.run(
        [str(executable("evolution_manager", "evolve")), "--algorithm", "qd", "--objective", "foraging",
         "--task", str(task_file), "--evaluations", "20", "--trials", "2", "--seed", "2", "--out", str(out),
         "--no-progress"],
        capture_output=True, text=True, timeout=900,
    )  # fmt: skip
    assert done.returncode == 0, done.stderr[-3000:]
    best = max(
        json.loads((out / "repertoire_foraging.json").read_text())["items"], key=lambda i: i["fitness"]
    )
    dom = rendered(out / "explorer.html", f"objective=foraging&bin={','.join(map(str, best['bin']))}")
    (canvas,) = dom.find("canvas", id="animation")
    assert canvas["data-regions"] == "; ".join(["food disc", *["food2 disc"] * 3, "food3 disc", "nest disc"])
