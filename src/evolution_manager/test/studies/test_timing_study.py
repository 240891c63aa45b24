"""The timing study's table (evolution_manager.studies.timing_study), from rows, without a graph: paired
differences, a seeded bootstrap interval, the committed trees it picks, and its CSV read back."""

from __future__ import annotations

from pathlib import Path

import pytest

from evolution_manager.errors import UsageError
from evolution_manager.studies.timing_study import (
    best_food_tree,
    best_forager_swarm,
    markdown,
    read_rows,
    study,
    study_trials,
    table,
    write_rows,
)

REPO = Path(__file__).resolve().parents[4]


def row(task: str, timing: str, trial: int, fitness: float) -> dict:
    return {
        "task": task, "objective": "food", "seed": 1, "trial": trial, "timing": timing,
        "rate": "1.0" if timing == "free" else "", "fitness": repr(fitness), "wall_s": "22.0",
        "nominal_s": "20.0",
    }  # fmt: skip


ROWS = [
    *(row("primitives", "lockstep", t, f) for t, f in ((0, 0.8), (5, 0.7), (10, 0.9))),
    *(row("primitives", "free", t, f) for t, f in ((0, 0.7), (5, 0.65), (10, 0.8))),
]


def test_the_difference_is_paired_by_trial_and_its_interval_is_seeded() -> None:
    (summary,) = table(ROWS, ci_seed=3)
    assert summary["n"] == 3
    assert summary["lockstep"] == pytest.approx(0.8) and summary["free"] == pytest.approx(0.7166666666)
    assert summary["difference"] == pytest.approx(-0.0833333333)
    low, high = summary["ci"]
    # within the three pairs' differences (-0.1, -0.05, -0.1)
    assert -0.1 - 1e-9 <= low <= summary["difference"] <= high <= -0.05 + 1e-9
    assert table(ROWS, ci_seed=3)[0]["ci"] == summary["ci"]  # the same seed, the same interval
    assert summary["wall_ratio"] == pytest.approx(1.1)


def test_a_trial_run_in_one_timing_only_is_left_out_and_one_pair_has_no_interval() -> None:
    rows = [row("primitives", "lockstep", 0, 0.5), row("primitives", "free", 0, 0.4)]
    rows.append(row("primitives", "lockstep", 5, 0.9))
    (summary,) = table(rows, ci_seed=1)
    assert summary["n"] == 1 and summary["ci"] is None
    assert "n/a (n < 2)" in markdown(rows, [], 1, {}, REPO)


def test_the_csv_reads_back_and_a_foreign_one_is_refused(tmp_path: Path) -> None:
    path = tmp_path / "trials.csv"
    write_rows(path, ROWS)
    assert table(read_rows(path), 3) == table(ROWS, 3)
    path.write_text("a,b\n1,2\n")
    with pytest.raises(UsageError, match="expected the columns"):
        read_rows(path)


def test_the_committed_trees_and_the_trials_first_of_their_chains() -> None:
    food = best_food_tree(REPO)
    assert food.task == "primitives" and len(food.trees) == 1 and "QD_food" in food.source
    swarm = best_forager_swarm(REPO)
    assert len(swarm.trees) == 9 and swarm.library is not None and swarm.library.is_file()
    assert study_trials("primitives", 3) == [0, 5, 10]
    with pytest.raises(UsageError, match="no experiments"):
        best_food_tree(REPO / "docs")


def test_the_table_is_remade_only_with_force_and_never_through_a_link(tmp_path: Path, capsys) -> None:
    write_rows(tmp_path / "trials.csv", ROWS)
    arguments = ["--out", str(tmp_path), "--table-only", "--repo", str(REPO)]
    assert study(arguments) == 0
    first = (tmp_path / "README.md").read_text()
    assert "| primitives | food | 3 |" in first
    assert study(arguments) == 2  # README.md exists now
    assert "exists" in capsys.readouterr().err
    assert study([*arguments, "--force"]) == 0
    assert (tmp_path / "README.md").read_text() == first  # the same rows, the same table
    (tmp_path / "README.md").unlink()
    target = tmp_path / "elsewhere.md"
    target.write_text("kept")
    (tmp_path / "README.md").symlink_to(target)
    assert study([*arguments, "--force"]) == 2
    assert target.read_text() == "kept"
