"""``explorer`` checks what it shows: a repertoire whose trees do not parse is refused, as ``library`` and
``adapt`` refuse it, and a library shown with ``--library`` must describe the run (its primitives from this
run on bins that hold their trees, every source bin inside its block). Hand-built run directories whose
answer is known; the library is built by the ``library`` command; no animations (no simulation)."""

from __future__ import annotations

import json
import shutil
from pathlib import Path

from evolution_manager.evolution.libraries import library_command
from evolution_manager.evolution.run_config import RunConfig
from evolution_manager.viewing.explorer import main as explorer

SHORT = "sel(on_food, forward)"
OTHER = "sel(in_nest, reverse)"


def make_run(root: Path, name: str, seed: int, items: list[tuple[tuple[int, int, int], str, float]]) -> Path:
    """A run directory of QD on food: config.json and repertoire_food.json holding ``items``."""
    path = root / name
    path.mkdir()
    config = RunConfig.make("qd", "food", 100, seed)
    (path / "config.json").write_text(json.dumps(config.to_json()))
    document = {
        "objective": "food",
        "shape": [8, 8, 8],
        "items": [
            {"bin": list(b), "tree": t, "fitness": f, "descriptors": [0.5, 0.5, 0.5], "evaluation": k}
            for k, (b, t, f) in enumerate(items)
        ],
    }
    (path / "repertoire_food.json").write_text(json.dumps(document))
    return path


def refused(capsys, argv: list[str], *words: str) -> str:
    capsys.readouterr()
    assert explorer(argv) == 2
    error = capsys.readouterr().err
    assert error.startswith("explorer: error: ") and error.count("\n") == 1, error
    assert "Traceback" not in error
    for word in words:
        assert word in error, error
    return error


def test_a_repertoire_whose_trees_do_not_parse_is_refused(tmp_path, capsys):
    run = make_run(tmp_path, "run", 1, [((0, 0, 0), SHORT, 0.5), ((1, 0, 0), "seq(forward, dance)", 0.4)])
    refused(capsys, [str(run), "--no-animations"], "repertoire_food.json: item 1: tree does not parse")
    assert not (run / "explorer.html").exists()
    # the simplified form the file holds is checked too (it is what the page shows)
    document = json.loads((run / "repertoire_food.json").read_text())
    document["items"][1]["tree"] = OTHER
    document["items"][1]["simplified"] = "sel(in_nest,"
    (run / "repertoire_food.json").write_text(json.dumps(document))
    refused(capsys, [str(run), "--no-animations"], "item 1: simplified tree does not parse")
    document["items"][1]["simplified"] = OTHER
    del document["items"][0]["tree"]
    (run / "repertoire_food.json").write_text(json.dumps(document))
    refused(capsys, [str(run), "--no-animations"], "item 0 has no tree")
    assert not (run / "explorer.html").exists()
    document["items"][0]["tree"] = SHORT
    (run / "repertoire_food.json").write_text(json.dumps(document))
    assert explorer([str(run), "--no-animations"]) == 0


def _library(tmp_path: Path, run: Path) -> Path:
    out = tmp_path / "lib.json"
    assert library_command(["--from", str(run), "--blocks", "8", "--out", str(out)]) == 0
    return out


def test_a_library_of_another_run_in_the_runs_folder_is_refused(tmp_path, capsys):
    """The run folder replaced by another run after the library was built: its primitives' bins are empty
    or hold other trees; refused in one line, nothing written."""
    run = make_run(tmp_path, "run", 1, [((0, 0, 0), SHORT, 0.5), ((7, 7, 7), SHORT, 0.6)])
    library = _library(tmp_path, run)
    assert explorer([str(run), "--library", str(library), "--no-animations"]) == 0  # its own run: shown
    (run / "explorer.html").unlink()

    shutil.rmtree(run)  # another run in its place: other trees in the same bins
    make_run(tmp_path, "run", 1, [((0, 0, 0), OTHER, 0.5), ((7, 7, 7), OTHER, 0.6)])
    refused(capsys, [str(run), "--library", str(library), "--no-animations"], "which holds other trees there")
    shutil.rmtree(run)  # the bins empty
    make_run(tmp_path, "run", 1, [((3, 3, 3), SHORT, 0.5)])
    refused(capsys, [str(run), "--library", str(library), "--no-animations"], "which is empty there")
    shutil.rmtree(run)  # the same trees, another seed
    make_run(tmp_path, "run", 2, [((0, 0, 0), SHORT, 0.5), ((7, 7, 7), SHORT, 0.6)])
    refused(capsys, [str(run), "--library", str(library), "--no-animations"], "seed 1", "has seed 2")
    assert not (run / "explorer.html").exists()


def test_a_source_bin_outside_its_block_is_refused(tmp_path, capsys):
    run = make_run(tmp_path, "run", 1, [((0, 0, 0), SHORT, 0.5), ((7, 7, 7), OTHER, 0.6)])
    library = _library(tmp_path, run)
    document = json.loads(library.read_text())
    document["primitives"][0]["source"]["bin"] = [7, 7, 0]  # block 0,0,0 holds bins 0..3
    moved = tmp_path / "moved.json"
    moved.write_text(json.dumps(document))
    refused(
        capsys,
        [str(run), "--library", str(moved), "--no-animations"],
        "source bin [7, 7, 0] is outside its block",
    )
    document["primitives"][0]["source"]["bin"] = [9, 0, 0]
    moved.write_text(json.dumps(document))
    refused(capsys, [str(run), "--library", str(moved), "--no-animations"], "outside the grid [8, 8, 8]")
    assert not (run / "explorer.html").exists()
