"""The swarm explorer (``viewing.swarm_explorer``): ``explorer RUN_DIR`` of a composition run and of a team
run, tiny runs made here (a MAP-Elites food run as the repertoire, MAP-Elites and a GA over its compositions,
a team of three), each page opened in headless Chromium from file:// with a fragment: the grid's filled
bins, a bin's swarm (its nine robots by tree, a legend in the trial's colours, each distinct tree drawn, the
canvas drawn), the marked swarms of summary.json, a team's sub-groups; and the refusals, in one line."""

from __future__ import annotations

import csv
import json
import os
import subprocess
from pathlib import Path

import pytest
from headless import dump_dom
from test_explorer_and_animation import rendered

from bt_controller.robot import timeline
from evolution_manager.evolution.compositions import CompositionConfig, bin_of
from evolution_manager.evolution.teams import TeamConfig
from evolution_manager.graph.startup import executable
from evolution_manager.studies.evolve import evolve
from evolution_manager.viewing.explorer import main as explorer

AXES = ("movement", "rotation", "conditionality")


@pytest.fixture(scope="module")
def runs(tmp_path_factory):
    """A tiny MAP-Elites food run, and over its repertoires a MAP-Elites and a GA composition run; a team
    run of three trees; each with its explorer page built by the command."""
    root = tmp_path_factory.mktemp("swarms")
    source = root / "qd-food"
    common = ["--trials", "1", "--no-progress", "--checkpoint-every", "0"]
    args = ["--algorithm", "qd", "--objective", "food", "--evaluations", "30", "--trials", "1"]
    assert evolve([*args, "--out", str(source), "--no-figures", "--no-progress"]) == 0
    for algorithm in ("qd", "ga"):
        argv = ["--task", "foraging", "--swarm-from", str(source), "--algorithm", algorithm]
        argv += ["--evaluations", "30", "--seed", "3", "--out", str(root / algorithm)]
        assert evolve([*argv, *common]) == 0
    team = ["--algorithm", "gp", "--objective", "food", "--team", "3", "--evaluations", "25", "--seed", "2"]
    assert evolve([*team, "--out", str(root / "team"), *common]) == 0
    for name in ("qd", "ga", "team"):
        done = subprocess.run(
            [str(executable("evolution_manager", "explorer")), str(root / name)],
            capture_output=True, text=True, timeout=900,
        )  # fmt: skip
        assert done.returncode == 0, done.stderr[-3000:]
    return root


def payload(page: Path) -> dict:
    text = page.read_text()
    data = text.split('<script type="application/json" id="data">', 1)[1].split("</script>", 1)[0]
    return json.loads(data.replace("<\\/", "</"))


def frames_of(run: Path) -> int:
    """Frames of a stored trial of ``run``'s world: every second sensing step, and the last."""
    config = json.loads((run / "config.json").read_text())
    kind = CompositionConfig if config["kind"] == "compositions" else TeamConfig
    return timeline.trial_steps(kind.from_json(config).world().timeline) // 2 + 1


def check_swarm(dom, trees: list[str], shown_trees: list[str], frames: int) -> None:
    """The shown swarm runs ``trees`` (robot 0 first; ``shown_trees``: their simplified texts): nine robot
    rows, a legend whose groups are the robots of each distinct tree in one colour each (the trial's), every
    distinct tree drawn, and the canvas drawn with its frames."""
    robots = dom.find("tr", class_="robot")
    assert [r["data-tree"] for r in robots] == shown_trees
    groups = [a for a in dom.find("div") if a.get("class") == "group"]
    members = [[int(i) for i in g["data-robots"].split(",")] for g in groups]
    assert sorted(i for m in members for i in m) == list(range(len(trees)))
    for m in members:  # one group: the robots of one tree
        assert {trees[i] for i in m} == {trees[m[0]]}
    assert len({trees[m[0]] for m in members}) == len(members)
    assert len({g["data-colour"] for g in groups}) == len(groups)
    drawn = {a["data-tree"] for a in dom.find("div") if "simplified" in a.get("class", "").split()}
    assert drawn == set(shown_trees)
    assert dom.find("svg", class_="tree-drawing")
    (canvas,) = dom.find("canvas", id="animation")
    assert int(canvas["data-frames"]) == frames and canvas.get("data-drawn", "") != ""
    colours = canvas["data-robot-colours"].split(",")
    for g, m in zip(groups, members, strict=True):
        assert {colours[i] for i in m} == {g["data-colour"]}


def simplified_of(data: dict, swarm: dict) -> tuple[list[str], list[str]]:
    """The swarm's tree and simplified tree of each robot, from the page's data."""
    rows = [data["trees"][swarm["groups"][g]["tree"]] for g in swarm["robots"]]
    return [r["tree"] for r in rows], [r["simplified"] for r in rows]


def test_a_composition_runs_grid_and_a_bins_swarm(runs):
    run = runs / "qd"
    page = run / "explorer.html"
    assert page.stat().st_size < 5_000_000
    archive = json.loads((run / "repertoire_compositions.json").read_text())["items"]
    best = max(archive, key=lambda i: i["fitness"])
    key = ",".join(map(str, best["bin"]))
    dom = rendered(page, f"bin={key}")
    cells = [a for a in dom.find("rect") if "cell" in a.get("class", "").split()]
    assert len(cells) == 512
    filled = {a["data-bin"]: float(a["data-value"]) for a in cells if "filled" in a["class"].split()}
    assert filled == pytest.approx({",".join(map(str, i["bin"])): i["fitness"] for i in archive}, abs=5e-5)
    assert next(a for a in cells if "selected" in a["class"].split())["data-bin"] == key
    assert dom.find("div", id="heatmaps", data_source="archive")
    assert dom.find("section", id="detail", data_bin=key, data_swarm="")
    assert f"{best['fitness']:.4f}" in " ".join(dom.values_text)
    assert all(f"{d:.4f}" in " ".join(dom.values_text) for d in best["descriptors"])
    data = payload(page)
    trees, shown = simplified_of(data, data["grid"]["bins"][key])
    assert trees == best["trees"]
    check_swarm(dom, trees, shown, frames_of(run))
    # each robot's cell as cells.json lists it
    cell_list = json.loads((run / "cells.json").read_text())["cells"]
    swarm = data["grid"]["bins"][key]
    assert swarm["cells"] == best["genome"]
    assert [cell_list[c]["tree"] for c in swarm["cells"]] == trees
    assert [data["cells"][c]["bin"] for c in swarm["cells"]] == [
        ",".join(map(str, cell_list[c]["bin"])) for c in best["genome"]
    ]


@pytest.mark.parametrize("name", ["best", "validated", "homogeneous", "homogeneous-validated"])
def test_the_marked_swarms_of_summary_json(runs, name):
    run = runs / "qd"
    summary = json.loads((run / "summary.json").read_text())
    expected = {
        "best": (summary["best"]["trees"], summary["heldout_best_fitness"]),
        "validated": (summary["validated"]["trees"], summary["validated"]["heldout_best_fitness"]),
        "homogeneous": ([summary["homogeneous"]["tree"]] * 9, summary["homogeneous"]["heldout_best_fitness"]),
        "homogeneous-validated": (
            summary["homogeneous"]["validated"]["trees"],
            summary["homogeneous"]["validated"]["heldout_best_fitness"],
        ),
    }[name]
    dom = rendered(run / "explorer.html", f"swarm={name}")
    assert dom.find("section", id="detail", data_swarm=name)
    assert dom.find("span", class_="mark", id="mark")
    assert dom.find("button", class_="swarm active", data_swarm=name)
    trees, held_out = expected
    assert f"{held_out:.4f}" in " ".join(dom.values_text)
    data = payload(run / "explorer.html")
    shown_trees, shown = simplified_of(data, data["marked"][name])
    assert shown_trees == trees
    check_swarm(dom, trees, shown, frames_of(run))
    if name == "homogeneous":
        assert len(data["marked"][name]["groups"]) == 1


def test_a_ga_composition_run_bins_every_evaluated_composition(runs):
    run = runs / "ga"
    assert not (run / "repertoire_compositions.json").exists()
    fittest: dict[str, float] = {}
    with open(run / "evaluations.csv", newline="") as handle:
        for row in csv.DictReader(handle):
            if row["foraging"]:
                key = ",".join(map(str, bin_of([float(row[a]) for a in AXES])))
                fittest[key] = max(fittest.get(key, -1.0), float(row["foraging"]))
    key = max(fittest, key=lambda k: fittest[k])
    dom = rendered(run / "explorer.html", f"bin={key}")
    assert dom.find("div", id="heatmaps", data_source="evaluated")
    filled = {a["data-bin"]: float(a["data-value"]) for a in dom.find("rect") if a.get("data-value")}
    assert filled == pytest.approx(fittest, abs=5e-5)
    data = payload(run / "explorer.html")
    check_swarm(dom, *simplified_of(data, data["grid"]["bins"][key]), frames_of(run))


def test_a_team_run_shows_its_sub_groups_and_says_it_has_no_grid(runs):
    run = runs / "team"
    summary = json.loads((run / "summary.json").read_text())
    for name, team in (("best", summary["best"]["trees"]), ("validated", summary["validated"]["trees"])):
        dom = rendered(run / "explorer.html", f"swarm={name}")
        assert dom.find("p", id="no-grid") and not [a for a in dom.find("rect") if "data-bin" in a]
        trees = [team[i % 3] for i in range(9)]
        data = payload(run / "explorer.html")
        assert simplified_of(data, data["marked"][name])[0] == trees
        assert data["marked"][name]["subgroups"] == [i % 3 for i in range(9)]
        firsts = {}  # each distinct tree's robots, in the order of its first robot
        for i, tree in enumerate(trees):
            firsts.setdefault(tree, []).append(str(i))
        groups = [a for a in dom.find("div") if a.get("class") == "group"]
        assert [g["data-robots"] for g in groups] == [",".join(r) for r in firsts.values()]
        check_swarm(dom, trees, simplified_of(data, data["marked"][name])[1], frames_of(run))


def test_a_tree_runs_page_is_still_the_tree_explorer(runs):
    assert explorer([str(runs / "qd-food"), "--no-animations"]) == 0
    page = (runs / "qd-food" / "explorer.html").read_text()
    assert "Repertoire explorer" in page and "swarm-legend" not in page


def _refused(capsys, argv: list[str], *words: str) -> None:
    capsys.readouterr()
    assert explorer(argv) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and err.startswith("explorer: error: "), err
    assert all(w in err for w in words), err


def test_damaged_swarm_runs_are_refused_in_one_line(runs, tmp_path, capsys):
    copy = tmp_path / "copy"
    subprocess.run(["cp", "-r", str(runs / "qd"), str(copy)], check=True)
    (copy / "explorer.html").unlink()
    cells = json.loads((copy / "cells.json").read_text())
    cells["cells"][0]["tree"] = "sel(on_food, forward)"
    (copy / "cells.json").write_text(json.dumps(cells))
    _refused(capsys, [str(copy), "--no-animations"], "cells.json", "not the cell list the run started with")
    (copy / "cells.json").write_text("{")
    _refused(capsys, [str(copy), "--no-animations"], "cells.json", "not a readable JSON file")
    (copy / "cells.json").write_text((runs / "qd" / "cells.json").read_text())
    summary = json.loads((copy / "summary.json").read_text())
    summary["best"]["genome"] = [999] * 9
    (copy / "summary.json").write_text(json.dumps(summary))
    _refused(capsys, [str(copy), "--no-animations"], "summary.json", "best genome", "cell indices")
    (copy / "summary.json").write_text((runs / "qd" / "summary.json").read_text())
    archive = json.loads((copy / "repertoire_compositions.json").read_text())
    archive["items"][0]["bin"] = 7
    (copy / "repertoire_compositions.json").write_text(json.dumps(archive))
    _refused(capsys, [str(copy), "--no-animations"], "repertoire_compositions.json", "item 0: bin must be")
    archive["items"][0]["bin"] = [0, 0, 0]
    archive["items"][0]["trees"] = "not read: the genome names the cells"
    archive["items"][0]["genome"][0] = "sel(on_food, forward)"
    (copy / "repertoire_compositions.json").write_text(json.dumps(archive))
    _refused(capsys, [str(copy), "--no-animations"], "item 0: genome must be 9 cell indices")
    (copy / "repertoire_compositions.json").write_text(
        (runs / "qd" / "repertoire_compositions.json").read_text()
    )
    _refused(capsys, [str(copy), "--library", str(copy / "cells.json")], "--library", "compositions run")
    config = json.loads((copy / "config.json").read_text())
    (copy / "config.json").write_text(json.dumps({**config, "evaluations": "many"}))
    _refused(capsys, [str(copy), "--no-animations"], "config.json", "evaluations")
    assert not (copy / "explorer.html").exists()
    team = tmp_path / "team"
    subprocess.run(["cp", "-r", str(runs / "team"), str(team)], check=True)
    (team / "summary.json").unlink()
    _refused(capsys, [str(team), "--no-animations"], "no summary.json with a best team")


def test_a_ga_runs_damaged_log_is_refused_in_one_line(runs, tmp_path, capsys):
    copy = tmp_path / "copy"
    subprocess.run(["cp", "-r", str(runs / "ga"), str(copy)], check=True)
    lines = (copy / "evaluations.csv").read_text().splitlines()
    header = lines[0].split(",")
    row = lines[3].split(",")
    row[header.index("rotation")] = "nan"
    (copy / "evaluations.csv").write_text("\n".join([*lines[:3], ",".join(row), *lines[4:]]) + "\n")
    _refused(capsys, [str(copy), "--no-animations"], "evaluations.csv", "evaluation 2 has no finite numbers")


def test_nothing_is_written_through_a_link(runs, tmp_path, capsys):
    copy = tmp_path / "copy"
    subprocess.run(["cp", "-r", str(runs / "team"), str(copy)], check=True)
    (copy / "explorer.html").unlink()
    target = tmp_path / "elsewhere.html"
    target.write_text("kept")
    os.symlink(target, copy / "explorer.html")
    capsys.readouterr()
    assert explorer([str(copy), "--no-animations"]) == 2
    assert "explorer.html" in capsys.readouterr().err
    assert target.read_text() == "kept"


def test_a_page_without_animations_says_so(runs, tmp_path):
    copy = tmp_path / "copy"
    subprocess.run(["cp", "-r", str(runs / "team"), str(copy)], check=True)
    assert explorer([str(copy), "--no-animations"]) == 0
    assert 'id="no-animation"' in dump_dom(copy / "explorer.html", "swarm=best")


@pytest.fixture(scope="module")
def multifood(tmp_path_factory):
    """A composition run on the authors' arena 9 (three food kinds, kind 1 preferred; trials shortened to
    20 ticks) maximising foraging_biased, binned by the deliveries of each kind, from a tiny MAP-Elites run
    there."""
    root = tmp_path_factory.mktemp("multifood")
    shown = subprocess.run(
        [str(executable("swarm_sim", "task")), "arena", "9", "--bias", "1"],
        capture_output=True, text=True, check=True,
    )  # fmt: skip
    task = root / "arena9.yaml"
    task.write_text(shown.stdout.replace("ticks: 200", "ticks: 20"))
    source, run = root / "source", root / "swarms"
    args = ["--algorithm", "qd", "--objective", "foraging", "--task", str(task), "--evaluations", "20"]
    assert (
        evolve([*args, "--trials", "1", "--seed", "2", "--out", str(source), "--no-figures", "--no-progress"])
        == 0
    )
    args = [
        "--task",
        str(task),
        "--swarm-from",
        str(source),
        "--algorithm",
        "qd",
        "--objective",
        "foraging_biased",
    ]
    args += ["--descriptors", "deliveries", "--evaluations", "20", "--seed", "3", "--out", str(run)]
    assert evolve([*args, "--trials", "1", "--no-progress", "--checkpoint-every", "0"]) == 0
    assert explorer([str(run)]) == 0
    return run


def test_a_multifood_composition_run_shows_the_deliveries_of_each_kind(multifood):
    kinds = ["foraging1", "foraging2", "foraging3"]
    data = payload(multifood / "explorer.html")
    assert data["axes"] == kinds and data["objective"] == "foraging_biased"
    summary = json.loads((multifood / "summary.json").read_text())
    with open(multifood / "evaluations.csv", newline="") as handle:
        rows = list(csv.DictReader(handle))
    genome = " ".join(map(str, summary["validated"]["genome"]))
    first = next(r for r in rows if r["genome"] == genome)
    assert data["marked"]["validated"]["values"] == [float(first[k]) for k in kinds]
    assert data["marked"]["validated"]["evaluation"] == int(first["evaluation"])
    for name in ("best", "validated"):
        dom = rendered(multifood / "explorer.html", f"swarm={name}")
        assert {r["data-name"] for r in dom.find("tr") if "data-name" in r} >= set(kinds)
        for k, value in enumerate(summary["heldout_descriptors"] if name == "best" else []):
            assert f"{value:.4f}" in " ".join(dom.values_text), kinds[k]
        (canvas,) = dom.find("canvas", id="animation")
        assert "food2 disc" in canvas["data-regions"] and "nest disc" in canvas["data-regions"]
        check_swarm(dom, *simplified_of(data, data["marked"][name]), frames_of(multifood))
