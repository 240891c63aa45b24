"""Run folders are shared (tarballs, ``git clone`` of ``experiments/``, which stores symbolic links): a link
planted where a command writes is refused in one line, never written through, and what it points to is
left as it was (issue 41)."""

from __future__ import annotations

import shutil
from pathlib import Path

import pytest

from evolution_manager.evolution.run import Run
from evolution_manager.evolution.run_config import RunConfig
from evolution_manager.studies.evolve import evolve
from swarm_sim.evaluation import BatchEvaluator

QUIET = ["--no-progress", "--checkpoint-every", "0"]


@pytest.fixture(scope="module")
def unfinished(tmp_path_factory) -> Path:
    """A real run (the simulator, one trial per evaluation) stopped after its first batch."""
    out = tmp_path_factory.mktemp("links") / "run"
    config = RunConfig.make("qd", "food", 20, 5, trials=1)
    run = Run.start(config, out, BatchEvaluator(config.world(), threads=1))
    run.execute(checkpoint_interval=0, stop_after=1)
    assert not run.done
    assert run.lock is not None
    run.lock.release()
    return out


def _copy(run: Path, where: Path) -> Path:
    copy = where / "run"
    shutil.copytree(run, copy, symlinks=True)
    return copy


def test_a_planted_lock_link_is_refused_and_its_target_kept(unfinished, tmp_path, capsys):
    run = _copy(unfinished, tmp_path)
    precious = tmp_path / "precious"
    precious.write_text("keep me\n")
    (run / ".lock").unlink()
    (run / ".lock").symlink_to(precious)
    assert evolve(["--out", str(run), "--resume", *QUIET]) == 2
    error = capsys.readouterr().err.strip()
    assert "\n" not in error and ".lock is a symbolic link" in error, error
    assert precious.read_text() == "keep me\n"
