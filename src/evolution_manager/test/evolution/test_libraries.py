"""Primitive libraries from repertoires (``library``): the authors' choice per block, on hand-built run
directories whose answer can be worked out, and end to end on a small real run."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from bt_controller.language import load_library, parse, simplify, success, to_text, without_draw_keys
from evolution_manager.evolution.libraries import (
    FAMILIES,
    block_of,
    library_command,
    library_entry_tree,
    variant,
)
from evolution_manager.evolution.operators import derating
from evolution_manager.evolution.run_config import RunConfig

FOUR = "seq(forward, forward, forward, forward)"  # 5 nodes
SIXTEEN = f"seq({FOUR}, {FOUR}, {FOUR}, {FOUR})"  # 21 nodes
LONG = (
    f"seq(seq({SIXTEEN}, {SIXTEEN}, {SIXTEEN}, {SIXTEEN}), {SIXTEEN}, {FOUR})"  # 112 nodes: derated by 0.897
)
SHORT = "sel(on_food, forward)"
OTHER = "sel(in_nest, reverse)"


def make_run(
    root: Path,
    name: str,
    seed: int,
    repertoires: dict[str, list[tuple[tuple[int, int, int], str, float]]],
    profile: str = "paper",
    algorithm: str = "qd",
    heldout: dict[str, list[tuple[tuple[int, int, int], str, float]]] | None = None,
    task: str = "primitives",
) -> Path:
    """A run directory holding config.json, a repertoire file per objective and optionally heldout.json."""
    path = root / name
    path.mkdir()
    objectives = tuple(repertoires)
    if algorithm == "gp-fnd":
        config = RunConfig.make(
            "gp-fnd", None, 100, seed, profile=profile, fnd_objectives=objectives, task=task
        )
    else:
        config = RunConfig.make(algorithm, objectives[0], 100, seed, profile=profile, task=task)
    (path / "config.json").write_text(json.dumps(config.to_json()))
    for objective, items in repertoires.items():
        document = {
            "objective": objective,
            "shape": [8, 8, 8],
            "items": [
                {"bin": list(b), "tree": t, "fitness": f, "descriptors": [0.5, 0.5, 0.5], "evaluation": k}
                for k, (b, t, f) in enumerate(items)
            ],
        }
        (path / f"repertoire_{objective}.json").write_text(json.dumps(document))
    if heldout is not None:
        held = {
            o: {"bins": [{"bin": list(b), "tree": t, "heldout_fitness": h} for b, t, h in bins]}
            for o, bins in heldout.items()
        }
        (path / "heldout.json").write_text(json.dumps({"config": config.to_json(), "objectives": held}))
    return path


def build(tmp_path: Path, runs: list[Path], blocks: int = 8, name: str = "lib.json") -> dict:
    out = tmp_path / name
    args = ["--from", *map(str, runs), "--blocks", str(blocks), "--out", str(out)]
    assert library_command(args) == 0
    return {p["name"]: p for p in json.loads(out.read_text())["primitives"]}


def test_the_long_tree_loses_within_a_run_but_wins_across_runs_on_raw_fitness_under_paper(tmp_path):
    assert parse(LONG).size == 112 and derating(112) == pytest.approx(1 - 102 / 990)
    # run 1, block 1: the long tree is fitter raw (0.9) but derated (0.808) loses to the short one (0.85)
    # run 2, block 1: the long tree alone, raw 0.95 (derated 0.852); run 3: a short tree, 0.90
    one = make_run(tmp_path, "one", 1, {"food": [((0, 0, 0), LONG, 0.9), ((1, 2, 3), SHORT, 0.85)]})
    two = make_run(tmp_path, "two", 2, {"food": [((3, 3, 3), LONG, 0.95)]})
    three = make_run(tmp_path, "three", 3, {"food": [((2, 0, 1), OTHER, 0.90)]})
    # paper: across runs raw fitness, so run two's long tree (0.95 > 0.90 > 0.85)
    paper = build(tmp_path, [one, two, three])
    assert list(paper) == ["gotoFood1"]
    assert paper["gotoFood1"]["source"]["run"] == str(two) and paper["gotoFood1"]["source"]["seed"] == 2
    assert paper["gotoFood1"]["source"]["fitness"] == 0.95 and paper["gotoFood1"]["source"]["nodes"] == 112
    # without run two, run one offers its derated-best: the short tree, not the fitter long one
    assert build(tmp_path, [one], name="one.json")["gotoFood1"]["source"]["tree"] == SHORT

    # clean: derated throughout, so run three's short tree (0.90 > 0.852 > 0.85)
    runs = [
        make_run(tmp_path, f"clean{k}", k, {"food": items}, profile="clean")
        for k, items in enumerate(
            [
                [((0, 0, 0), LONG, 0.9), ((1, 2, 3), SHORT, 0.85)],
                [((3, 3, 3), LONG, 0.95)],
                [((2, 0, 1), OTHER, 0.9)],
            ]
        )
    ]
    clean = build(tmp_path, runs, name="clean.json")
    assert clean["gotoFood1"]["source"]["run"] == str(runs[2]) and clean["gotoFood1"]["tree"] == OTHER
    assert clean["gotoFood1"]["source"]["derated_fitness"] == 0.9


def test_blocks_number_as_the_authors_and_empty_blocks_are_left_out(tmp_path):
    assert variant(block_of((4, 0, 7), (8, 8, 8), 2), 2) == 4 * 1 + 2 * 0 + 1 + 1  # movement >= 0: 5-8
    assert variant(block_of((3, 7, 0), (8, 8, 8), 2), 2) == 3
    assert variant(block_of((4, 0, 7), (8, 8, 8), 4), 4) == 16 * 2 + 4 * 0 + 3 + 1
    assert {
        variant(block_of((i, j, k), (8, 8, 8), 4), 4) for i in range(8) for j in range(8) for k in range(8)
    } == set(range(1, 65))
    items = [((4, 0, 7), SHORT, 0.5), ((3, 7, 0), OTHER, 0.6), ((7, 7, 7), "forward", 0.4)]
    run = make_run(
        tmp_path, "run", 1, {"nest": items, "idensity": [((0, 0, 0), "stop", 0.3)]}, algorithm="gp-fnd"
    )
    eight = build(tmp_path, [run], 8, "eight.json")
    assert list(eight) == ["gotoNest3", "gotoNest6", "gotoNest8", "reduceDensity1"]  # the authors' order
    assert [eight[n]["source"]["bin"] for n in ("gotoNest3", "gotoNest6", "gotoNest8")] == [
        [3, 7, 0],
        [4, 0, 7],
        [7, 7, 7],
    ]
    assert eight["gotoNest6"]["source"]["block"] == [1, 0, 1] and eight["gotoNest6"]["source"]["blocks"] == 8
    assert list(build(tmp_path, [run], 64, "64.json")) == [
        "gotoNest29",
        "gotoNest36",
        "gotoNest64",
        "reduceDensity1",
    ]  # (1, 3, 0), (2, 0, 3), (3, 3, 3)
    one = build(tmp_path, [run], 1, "one.json")
    assert list(one) == ["gotoNest1", "reduceDensity1"] and one["gotoNest1"]["tree"] == OTHER  # 0.6, the best


def test_names_expand_to_their_simplified_trees_and_sources_carry_the_heldout_score(tmp_path):
    evolved = "seq(sel(food_left, food_left), sel(on_food, on_food), forward_left)"
    assert to_text(simplify(parse(evolved))) != evolved  # the simplifier has something to do
    run = make_run(
        tmp_path,
        "run",
        7,
        {"food": [((0, 0, 0), evolved, 0.7), ((7, 0, 0), SHORT, 0.6), ((7, 0, 1), OTHER, 0.65)]},
        heldout={"food": [((0, 0, 0), evolved, 0.66), ((7, 0, 1), "forward", 0.1)]},
    )
    entries = build(tmp_path, [run])
    assert entries["gotoFood1"]["tree"] == to_text(simplify(parse(evolved)))
    assert entries["gotoFood1"]["source"]["tree"] == evolved
    assert entries["gotoFood1"]["source"]["heldout_fitness"] == 0.66
    assert entries["gotoFood5"]["source"]["heldout_fitness"] is None  # heldout.json scored another tree there
    library = load_library(tmp_path / "lib.json")
    assert library.names == ("gotoFood1", "gotoFood5")
    tree = library.parse("sel(seq(got_food, gotoFood1), gotoFood5)")
    assert tree == parse(f"sel(seq(got_food, success({entries['gotoFood1']['tree']})), success({OTHER}))")
    assert library.fold(tree) == "sel(seq(got_food, gotoFood1), gotoFood5)"
    assert library.parse("gotoFood5") == success(parse(OTHER))


def test_draw_keys_are_dropped_so_each_copy_draws_on_its_own():
    keyed = parse("sel(prob@4(forward, stop), prob@0(reverse, seq(in_nest, stop)))")
    assert to_text(without_draw_keys(keyed)) == "sel(prob(forward, stop), prob(reverse, seq(in_nest, stop)))"
    evolved = "seq(sel(on_food, on_food), prob(forward, stop), prob(reverse, stop))"
    assert "@" in to_text(simplify(parse(evolved)))  # the simplifier moved a prob and kept its key
    assert library_entry_tree(evolved) == to_text(without_draw_keys(simplify(parse(evolved))))
    assert "@" not in library_entry_tree(evolved)


@pytest.mark.parametrize(
    ("case", "message"),
    [
        ("no-repertoire", "has no repertoire of food (repertoire_food.json)"),
        ("blocks", "--blocks must be 1, 8 or 64, got 27"),
        ("exists", "already exists: add --force"),
        ("link", "is a symbolic link"),
        ("profiles", "the runs mix profiles clean and paper"),
        ("not-a-run", "is not a run directory (no config.json)"),
        ("foraging", "no primitive objective"),
        ("twice", "names"),
        ("tasks", "the runs mix tasks, foraging and primitives"),
        ("empty", "hold no tree (every block is empty), so the library would have 0 primitives"),
    ],
)
def test_bad_input_is_one_line_and_status_2(tmp_path, capsys, case, message):
    good = make_run(tmp_path, "good", 1, {"food": [((0, 0, 0), SHORT, 0.5)]})
    out = tmp_path / "lib.json"
    runs, blocks = [good], "8"
    if case == "no-repertoire":
        (good / "repertoire_food.json").unlink()
    elif case == "blocks":
        blocks = "27"
    elif case == "exists":
        out.write_text("{}")
    elif case == "link":  # a dangling link: its target is never created
        out.symlink_to(tmp_path / "elsewhere.json")
    elif case == "profiles":
        runs.append(make_run(tmp_path, "clean", 2, {"food": [((0, 0, 0), SHORT, 0.5)]}, profile="clean"))
    elif case == "not-a-run":
        runs.append(tmp_path)
    elif case == "foraging":
        runs.append(make_run(tmp_path, "forager", 2, {"foraging": [((0, 0, 0), SHORT, 0.5)]}))
    elif case == "twice":
        runs.append(good)
    elif case == "tasks":  # 100 s trials beside 20 s ones: raw fitness not comparable
        runs.append(make_run(tmp_path, "long", 2, {"food": [((0, 0, 0), SHORT, 0.5)]}, task="foraging"))
    elif case == "empty":
        runs = [make_run(tmp_path, "empty", 2, {"food": []})]
    before = out.read_text() if out.exists() else None
    assert library_command(["--from", *map(str, runs), "--blocks", blocks, "--out", str(out)]) == 2
    error = capsys.readouterr().err
    assert error.startswith("library: error: ") and error.count("\n") == 1 and message in error, error
    assert (out.read_text() if out.exists() else None) == before


def test_a_library_from_a_small_real_run_is_read_by_evaluate(tmp_path, capsys):
    from evolution_manager.studies.evolve import evolve
    from swarm_sim.evaluation.cli import evaluate_main

    run = tmp_path / "qd_food"
    common = ["--algorithm", "qd", "--objective", "food", "--evaluations", "300", "--seed", "3"]
    assert evolve([*common, "--out", str(run), "--no-progress", "--no-figures"]) == 0
    assert library_command(["--from", str(run), "--blocks", "8", "--out", str(tmp_path / "lib.json")]) == 0
    library = load_library(tmp_path / "lib.json")
    repertoire = json.loads((run / "repertoire_food.json").read_text())["items"]
    assert library.names and all(name.startswith(FAMILIES["food"]) for name in library.names)
    for primitive in library.primitives:
        source = dict(primitive.source or {})
        k = int(primitive.name.removeprefix("gotoFood"))
        block = [[item for item in repertoire if variant(block_of(item["bin"], (8, 8, 8), 2), 2) == k]]
        best = max(f["fitness"] * derating(parse(f["tree"]).size) for f in block[0])
        assert source["derated_fitness"] == best and source["seed"] == 3 and source["run"] == str(run)
        assert primitive.text == library_entry_tree(str(source["tree"]))
    assert any((p.source or {}).get("heldout_fitness") is not None for p in library.primitives)
    capsys.readouterr()
    first = library.names[0]
    assert evaluate_main(["--tree", first, "--library", str(tmp_path / "lib.json"), "--trials", "2"]) == 0
    assert json.loads(capsys.readouterr().out)["tree"] == first
