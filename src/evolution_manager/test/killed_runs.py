"""A run killed mid-way and resumed ends with the files of an uninterrupted one: the check each kind of run
(tree, composition, network and team runs) makes through ``evolve``, as a user runs it."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
from pathlib import Path

from evolution_manager.studies.evolve import evolve

QUIET = ["--no-progress", "--checkpoint-every", "0"]
"""Every run here: no progress bar, a checkpoint after every batch."""


def straight_and_killed(argv: list[str], folder: Path, rows: int) -> tuple[Path, Path]:
    """Run ``evolve argv`` twice in ``folder``: ``straight`` uninterrupted, and ``killed`` in a process of its
    own, killed (SIGKILL to its whole process group) once its ``progress.csv`` holds more than ``rows`` lines,
    then continued to the end with ``evolve --resume``. Asserts that the kill came before the run ended, and
    returns the two run folders for the caller to compare."""
    straight, killed = folder / "straight", folder / "killed"
    assert evolve([*argv, "--out", str(straight), *QUIET]) == 0
    command = [*argv, "--out", str(killed), *QUIET]
    code = f"from evolution_manager.studies.evolve import evolve; evolve({command!r})"
    process = subprocess.Popen([sys.executable, "-c", code], start_new_session=True)
    progress = killed / "progress.csv"
    try:
        deadline = time.monotonic() + 300
        while process.poll() is None and time.monotonic() < deadline:
            if progress.exists() and len(progress.read_text().splitlines()) > rows:
                break
            time.sleep(0.02)
    finally:
        os.killpg(process.pid, signal.SIGKILL)
        process.wait()
    assert not (killed / "summary.json").exists(), "the kill came too late to interrupt the run"
    assert evolve(["--out", str(killed), "--resume", *QUIET]) == 0
    return straight, killed
