"""The run folder and the loop every kind of run shares (``evolution.run_folder``), through a small kind of
run of its own: each batch asks for the next numbers, evaluates each to its square and keeps their sum."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from evolution_manager.errors import RunDirectoryError
from evolution_manager.evolution.run_folder import (
    COMPOSITIONS,
    RunFolder,
    RunLoop,
    run_kind,
)
from evolution_manager.processes import is_locked


class SquaresFolder(RunFolder):
    def __init__(self, root: Path) -> None:
        super().__init__(root, ["evaluation", "square"], ["evaluations", "total"])


class Squares(RunLoop[int, int]):
    """Batches of ``batch`` numbers from 0 until ``budget`` are evaluated; the total of their squares kept."""

    def __init__(self, root: Path, budget: int, batch: int = 3) -> None:
        super().__init__()
        self.directory = SquaresFolder(root)
        self.budget, self.batch, self.total = budget, batch, 0

    @classmethod
    def start(cls, root: Path, budget: int) -> Squares:
        return cls._begin(
            SquaresFolder(root), lambda building: cls(building, budget), {"config.json": {"budget": budget}}
        )

    @classmethod
    def resume(cls, root: Path) -> Squares:
        folder = SquaresFolder(root)

        def load() -> Squares:
            run = cls(root, json.loads(folder.config.read_text())["budget"])
            state = folder.read_checkpoint()
            folder.check_logs()
            run.evaluations, run.total = state["evaluations"], state["total"]
            run.offsets = folder.read_offsets(state["offsets"])
            return run

        return cls._reopen(folder, load)

    @property
    def done(self) -> bool:
        return self.evaluations >= self.budget

    def progress(self) -> tuple[int, int]:
        return self.evaluations, self.budget

    def _ask(self) -> list[int]:
        return list(range(self.evaluations, min(self.budget, self.evaluations + self.batch)))

    def _evaluate(self, batch: list[int]) -> list[int]:
        return [n * n for n in batch]

    def _tell(self, batch: list[int], answers: list[int]) -> None:
        self.total += sum(answers)
        self.evaluations += len(batch)
        rows = [[str(n), str(square)] for n, square in zip(batch, answers, strict=True)]
        self.offsets["evaluations"] = self.directory.evaluations.append(rows)
        self.offsets["progress"] = self.directory.progress.append([[str(self.evaluations), str(self.total)]])

    def checkpoint(self) -> None:
        state = {"evaluations": self.evaluations, "total": self.total, "offsets": self.offsets}
        self.directory.write_checkpoint(state)


def _files(root: Path) -> dict[str, bytes]:
    return {p.name: p.read_bytes() for p in sorted(root.iterdir()) if p.name != ".lock"}


def test_a_new_folder_appears_whole_with_its_lock_and_first_checkpoint(tmp_path):
    leftover = tmp_path / ".run.new-abandoned"  # a start killed before its rename, holding no lock
    leftover.mkdir()
    run = Squares.start(tmp_path / "run", 10)
    assert not leftover.exists() and [p.name for p in tmp_path.iterdir()] == ["run"]
    assert run.directory.root == tmp_path / "run" and is_locked(tmp_path / "run" / ".lock")
    assert sorted(_files(tmp_path / "run")) == [
        "checkpoint.json",
        "config.json",
        "evaluations.csv",
        "progress.csv",
    ]
    assert (tmp_path / "run" / "evaluations.csv").read_text() == "evaluation,square\n"
    state = json.loads((tmp_path / "run" / "checkpoint.json").read_text())
    assert state == {
        "format": 1,
        "evaluations": 0,
        "total": 0,
        "offsets": {"evaluations": 18, "progress": 18},
    }
    run.lock.release()
    assert not is_locked(tmp_path / "run" / ".lock")


def test_a_folder_holding_anything_is_never_started_in(tmp_path):
    Squares.start(tmp_path / "run", 10).lock.release()
    (tmp_path / "full").mkdir()
    (tmp_path / "full" / "notes.txt").write_text("mine\n")
    (tmp_path / "file").write_text("mine\n")
    for name, words in [
        ("run", "already holds a run: continue it with --resume"),
        ("full", "is not empty and holds no run"),
        ("file", "is a file, not a directory"),
    ]:
        with pytest.raises(RunDirectoryError, match=words):
            Squares.start(tmp_path / name, 10)
    assert (tmp_path / "full" / "notes.txt").read_text() == "mine\n"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["file", "full", "run"]


def test_the_loop_reports_progress_and_checkpoints_at_its_cadence(tmp_path):
    run = Squares.start(tmp_path / "run", 10)
    seen: list[tuple[int, int]] = []
    saved: list[int] = []
    run.execute(
        lambda done, budget: seen.append((done, budget)), 1e9, before_checkpoint=lambda: saved.append(0)
    )
    assert seen == [(3, 10), (6, 10), (9, 10), (10, 10)] and len(saved) == 1  # only at the end
    assert run.total == sum(n * n for n in range(10)) and run.done
    assert run.timing.total > 0 and run.timing.evaluator >= 0
    other = Squares.start(tmp_path / "other", 10)
    other.execute(checkpoint_interval=0, before_checkpoint=lambda: saved.append(1))
    assert saved.count(1) == 5  # after each of the four batches, and at the end
    assert _files(tmp_path / "other") == _files(tmp_path / "run")


def test_a_resumed_run_cuts_its_logs_back_and_ends_as_an_uninterrupted_one(tmp_path):
    Squares.start(tmp_path / "straight", 20).execute(checkpoint_interval=0)
    stopped = Squares.start(tmp_path / "stopped", 20)
    for stop in (4, 11):
        stopped.execute(checkpoint_interval=1e9, stop_after=stop)
        with open(tmp_path / "stopped" / "evaluations.csv", "a") as log:  # rows after the last checkpoint
            log.write("99,9801\n")
        (tmp_path / "stopped" / ".summary.json.x1.tmp").write_text("{")  # a killed atomic write
        stopped.lock.release()
        stopped = Squares.resume(tmp_path / "stopped")
        assert not (tmp_path / "stopped" / ".summary.json.x1.tmp").exists()
        assert stopped.evaluations == (6 if stop == 4 else 12)
        assert stopped.directory.evaluations.read()[-1]["evaluation"] == str(stopped.evaluations - 1)
    stopped.execute(checkpoint_interval=0)
    assert _files(tmp_path / "stopped") == _files(tmp_path / "straight")


def test_a_planted_link_or_a_damaged_checkpoint_is_refused_before_anything_changes(tmp_path):
    run = Squares.start(tmp_path / "run", 10)
    run.execute(checkpoint_interval=1e9, stop_after=3)
    run.lock.release()
    with open(tmp_path / "run" / "evaluations.csv", "a") as log:
        log.write("99,9801\n")
    before = _files(tmp_path / "run")
    (tmp_path / "run" / "summary.json").symlink_to(tmp_path / "elsewhere.json")
    with pytest.raises(RunDirectoryError, match=r"summary\.json"):
        Squares.resume(tmp_path / "run")
    assert not is_locked(tmp_path / "run" / ".lock")  # released
    (tmp_path / "run" / "summary.json").unlink()
    checkpoint = tmp_path / "run" / "checkpoint.json"
    state = json.loads(checkpoint.read_text())
    checkpoint.write_text(json.dumps({**state, "format": 2}))
    with pytest.raises(RunDirectoryError, match="is not a checkpoint of format 1"):
        Squares.resume(tmp_path / "run")
    checkpoint.write_text(json.dumps({**state, "offsets": {"evaluations": 0, "progress": 999}}))
    with pytest.raises(ValueError, match=r"offsets\.progress 999 is beyond the end of progress\.csv"):
        Squares.resume(tmp_path / "run")
    after = _files(tmp_path / "run")
    assert after.pop("checkpoint.json") != before.pop("checkpoint.json") and after == before
    with pytest.raises(RunDirectoryError, match="holds no run to resume"):
        Squares.resume(tmp_path / "nothing")


def test_the_kind_of_a_run_is_read_from_its_configuration(tmp_path):
    Squares.start(tmp_path / "trees", 10)
    (tmp_path / "compositions").mkdir()
    (tmp_path / "compositions" / "config.json").write_text(json.dumps({"kind": COMPOSITIONS}))
    (tmp_path / "damaged").mkdir()
    (tmp_path / "damaged" / "config.json").write_text("{")
    assert [run_kind(tmp_path / n) for n in ("trees", "compositions", "damaged", "missing")] == [
        "trees",
        "compositions",
        None,
        None,
    ]
