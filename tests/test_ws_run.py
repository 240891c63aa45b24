"""ws/run: --list lists the installed executables; the fast path skips ws/setup only while nothing changed."""

import subprocess
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
WS_RUN = ROOT / "ws" / "run"
STAMP = ROOT / "ws" / ".stamp-ready"


def _run(*args):
    return subprocess.run([str(WS_RUN), *args], capture_output=True, text=True, check=False, timeout=900)


def test_list_prints_every_installed_executable():
    run = _run("--list")
    assert run.returncode == 0, run.stderr
    lines = run.stdout.splitlines()
    assert lines[0] == "Installed executables (ws/run PACKAGE EXECUTABLE):"
    for entry in ("swarm_sim evaluate", "swarm_sim validate", "evolution_manager evolve", "bt_controller bt"):
        assert f"  {entry}" in lines


def test_options_other_than_list_still_go_to_the_main_job():
    run = _run("--no-such-option")
    assert run.returncode == 2
    assert "--no-such-option" in run.stderr


def test_a_missing_ready_stamp_makes_ws_run_check_the_set_up_again():
    STAMP.unlink(missing_ok=True)
    assert _run("--list").returncode == 0
    assert STAMP.exists()  # ws/setup ran and finished
    assert not STAMP.with_name(".stamp-ready.new").exists()
