"""Crash safety: what a kill, a lock or a half-written file leaves behind (issue 11's defects), each probed
with real processes and real kills. Locks per run directory and per bag; children that die with their parent;
``trial --tree`` text; an atomic run directory; run bags that survive a manager kill; one-line errors;
temporary files cleaned on resume; ``ws/setup`` that does not delete a repairable environment; signals that
end the main job with 130 / 143 and a job that can be continued; a killed evaluator noticed at once."""

from __future__ import annotations

import csv
import json
import os
import shutil
import signal
import subprocess
import sys
import textwrap
import time
from pathlib import Path

import numpy as np
import pytest

from evolution_manager.evolution.run_config import evaluation_seed
from evolution_manager.graph.dispatch import Dispatcher, Timeouts
from evolution_manager.graph.startup import executable
from evolution_manager.recording.bags import BagRecorder, read_bag, swarm_typestore
from swarm_ros.isolation import domain_environment, reserved_domain

ROOT = Path(__file__).resolve().parents[1]
QD = ["--algorithm", "qd", "--objective", "food"]
QUIET = ["--no-figures", "--no-progress"]
TWO_EVALUATORS = ["--evaluators", "2"]


# Helpers --------------------------------------------------------------------------------------------------
def exe(name: str) -> str:
    return str(executable("evolution_manager", name))


def descendants(pid: int) -> set[int]:
    """Every live process below ``pid``."""
    parents: dict[int, int] = {}
    for entry in Path("/proc").iterdir():
        if entry.name.isdigit():
            try:
                fields = (entry / "stat").read_text().rsplit(")", 1)[1].split()
            except OSError:
                continue
            if fields[0] != "Z":
                parents[int(entry.name)] = int(fields[1])
    found, frontier = set(), {pid}
    while frontier:
        frontier = {child for child, parent in parents.items() if parent in frontier} - found
        found |= frontier
    return found


def alive(pids: set[int]) -> set[int]:
    left = set()
    for pid in pids:
        try:
            state = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()[0]
        except OSError:
            continue
        if state != "Z":
            left.add(pid)
    return left


def wait_for(condition, what: str, timeout: float = 240.0, process: subprocess.Popen | None = None):
    deadline = time.monotonic() + timeout
    while not condition():
        if process is not None and process.poll() is not None:
            output = process.stdout.read() if process.stdout else ""
            raise AssertionError(f"the process ended (exit {process.returncode}) before {what}: {output}")
        assert time.monotonic() < deadline, f"timed out waiting for {what}"
        time.sleep(0.05)
    return condition()


def gone_soon(pids: set[int], timeout: float = 20.0) -> set[int]:
    """The processes of ``pids`` still alive after waiting up to ``timeout`` seconds for them to end."""
    deadline = time.monotonic() + timeout
    while alive(pids) and time.monotonic() < deadline:
        time.sleep(0.05)
    left = alive(pids)
    for pid in left:  # never leave them behind, even when the test fails
        os.kill(pid, signal.SIGKILL)
    return left


def one_line_error(stderr: str) -> str:
    lines = [line for line in stderr.strip().splitlines() if line.strip()]
    assert "Traceback" not in stderr, stderr
    assert len(lines) == 1, stderr
    return lines[0]


def python_child(tmp_path: Path, body: str) -> subprocess.Popen:
    """A Python process running ``body`` (with the workspace's imports)."""
    script = tmp_path / f"child_{time.monotonic_ns()}.py"
    script.write_text(textwrap.dedent(body))
    return subprocess.Popen(
        [sys.executable, str(script)], stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True
    )


def bag_evaluations(out: Path) -> list[int]:
    """The seeds of every /evaluations message of the run's bags, in order."""
    segments = sorted(out.glob("run*.bag"), key=lambda p: (p.name != "run.bag", len(p.name), p.name))
    return [m.message.seed for s in segments for m in read_bag(s) if m.topic == "/evaluations"]


def evaluation_rows(out: Path) -> int:
    """The rows of the run's evaluations.csv: every evaluation of the run (the budget counts individuals
    produced, which is not the number of rows)."""
    return len((out / "evaluations.csv").read_text().splitlines()) - 1


def progress_rows(out: Path) -> int:
    path = out / "progress.csv"
    return max(0, len(path.read_text().splitlines()) - 1) if path.exists() else 0


START_AND_HOLD = """
    import sys, time
    from pathlib import Path
    from evolution_manager.evolution.run_config import RunConfig
    from evolution_manager.evolution.run import Run
    run = Run.start(RunConfig.make("qd", "food", 100, 3), Path(sys.argv[0]).parent / "run", None)
    print("ready", flush=True)
    time.sleep(600)
"""


# 1. Locks -------------------------------------------------------------------------------------------------
def test_a_second_process_on_a_run_directory_or_a_bag_is_refused_naming_the_first(tmp_path):
    holder = python_child(tmp_path, START_AND_HOLD)
    try:
        assert holder.stdout.readline().strip() == "ready"
        before = (tmp_path / "run" / "checkpoint.json").read_bytes()
        done = subprocess.run(
            [exe("evolve"), "--out", str(tmp_path / "run"), "--resume", *QUIET],
            capture_output=True,
            text=True,
        )
        assert done.returncode == 2, done.stdout + done.stderr
        assert f"in use by process {holder.pid}" in one_line_error(done.stderr)
        assert (tmp_path / "run" / "checkpoint.json").read_bytes() == before
    finally:
        holder.kill()
        holder.wait()

    recording = python_child(
        tmp_path,
        f"""
        import time
        from evolution_manager.recording.bags import BagRecorder
        with BagRecorder({str(tmp_path / "bag")!r}) as bag:
            print("ready", flush=True)
            time.sleep(600)
        """,
    )
    try:
        assert recording.stdout.readline().strip() == "ready"
        done = subprocess.run(
            [exe("recover"), str(tmp_path / "bag"), str(tmp_path / "copy")], capture_output=True, text=True
        )
        assert done.returncode == 2
        assert f"being written by process {recording.pid}" in one_line_error(done.stderr)
        assert not (tmp_path / "copy").exists()
    finally:
        recording.kill()
        recording.wait()


# 2. Children die with their parent ------------------------------------------------------------------------
def test_kill_9_of_trial_or_manager_leaves_no_node_process(tmp_path):
    trial = subprocess.Popen(
        [exe("trial"), "--tree", "sel(seq(on_food, stop), forward)", "--bag", str(tmp_path / "t.bag")],
        stdout=subprocess.DEVNULL,
        stderr=subprocess.DEVNULL,
    )
    # the simulator and the process holding the nine controllers (`--controller-processes one`)
    nodes = wait_for(lambda: len(descendants(trial.pid)) >= 2 and descendants(trial.pid), "the trial graph")
    trial.kill()
    trial.wait()
    assert gone_soon(nodes) == set(), "node processes outlived their trial"

    with reserved_domain() as domain:
        manager = subprocess.Popen(
            [exe("manager"), *QD, "--evaluations", "100000", "--out", str(tmp_path / "m"), *TWO_EVALUATORS],
            env=domain_environment(domain),
            stdout=subprocess.DEVNULL,
            stderr=subprocess.DEVNULL,
        )
        evaluators = wait_for(
            lambda: len(descendants(manager.pid)) >= 2 and descendants(manager.pid), "the evaluators"
        )
        manager.kill()
        manager.wait()
        assert gone_soon(evaluators) == set(), "evaluators outlived their manager"


# 3. trial --tree is tree text unless it names a file ------------------------------------------------------
def test_trial_reads_long_tree_text_as_text(tmp_path):
    text = "sel(seq(on_food, stop), " + "no_such_leaf_" * 25 + ")"
    assert len(text) > 255
    done = subprocess.run(
        [exe("trial"), "--tree", text, "--bag", str(tmp_path / "t.bag")], capture_output=True, text=True
    )
    assert done.returncode == 2
    line = one_line_error(done.stderr)
    assert line.startswith("trial: ") and "no_such_leaf" in line
    assert not (tmp_path / "t.bag").exists()


# 4. A run directory appears whole or not at all -----------------------------------------------------------
def test_a_start_killed_before_its_first_checkpoint_leaves_nothing_in_the_way(tmp_path):
    out = tmp_path / "run"
    child = python_child(
        tmp_path,
        f"""
        import os, signal
        from pathlib import Path
        from evolution_manager.evolution.run_config import RunConfig
        from evolution_manager.evolution.run import Run
        Run.checkpoint = lambda self: os.kill(os.getpid(), signal.SIGKILL)  # die just before the checkpoint
        Run.start(RunConfig.make("qd", "food", 100, 3), Path({str(out)!r}), None)
        """,
    )
    child.wait()
    assert child.returncode == -signal.SIGKILL
    done = subprocess.run(
        [exe("evolve"), *QD, "--evaluations", "100", "--seed", "3", "--out", str(out), *QUIET],
        capture_output=True,
        text=True,
    )
    assert done.returncode == 0, done.stderr
    assert (out / "summary.json").exists()
    assert not list(tmp_path.glob(".run.*")), "the killed start's leftovers are still there"


# 5. Run bags survive a manager kill; recover fails when it recovers nothing -------------------------------
def test_a_killed_managers_bag_keeps_its_flushed_part_and_the_bags_hold_every_evaluation_once(tmp_path):
    out, budget, seed = tmp_path / "run", 1500, 4
    # fresh scenarios: every evaluation is simulated and recorded (fixed ones answer repeats from a cache)
    options = [
        *QD,
        "--evaluations",
        str(budget),
        "--seed",
        str(seed),
        "--out",
        str(out),
        "--scenarios",
        "fresh",
    ]
    options += QUIET
    with reserved_domain() as domain:
        env = domain_environment(domain)
        manager = subprocess.Popen(
            [exe("manager"), *options, "--evaluators", "1", "--checkpoint-every", "1"],
            env=env,
            stdout=subprocess.PIPE,
            stderr=subprocess.STDOUT,
            text=True,
        )
        wait_for(lambda: progress_rows(out) >= 8, "eight batches", process=manager)
        time.sleep(1.5)  # past a flush of the bag
        manager.kill()
        manager.wait()
        recovered = subprocess.run(
            [exe("recover"), str(out / "run.bag"), str(tmp_path / "recovered")],
            capture_output=True,
            text=True,
        )
        assert recovered.returncode == 0, recovered.stderr
        assert sum(m.topic == "/evaluations" for m in read_bag(tmp_path / "recovered")) >= 100
        done = subprocess.run(
            [exe("manager"), "--out", str(out), "--resume", "--evaluators", "1", *QUIET],
            env=env,
            capture_output=True,
            text=True,
            timeout=900,
        )
    assert done.returncode == 0, done.stderr[-3000:]
    assert bag_evaluations(out) == [evaluation_seed(seed, i) for i in range(evaluation_rows(out))]


def test_recover_fails_in_one_line_when_it_recovers_nothing_from_a_non_empty_file(tmp_path):
    damaged_files = (("garbage", b"not an mcap file at all" * 100), ("truncated", b"\x89MCAP0\r\n\x01\x00"))
    for name, content in damaged_files:
        damaged = tmp_path / name
        damaged.mkdir()
        (damaged / f"{name}.mcap").write_bytes(content)
        done = subprocess.run(
            [exe("recover"), str(damaged), str(tmp_path / f"{name}.new")], capture_output=True, text=True
        )
        assert done.returncode == 2, done.stdout
        assert "nothing could be recovered" in one_line_error(done.stderr)


# 6. One-line errors ---------------------------------------------------------------------------------------
@pytest.fixture(scope="module")
def small_run(tmp_path_factory):
    """A run of 400 evaluations stopped after 200 (its checkpoint holds a full archive)."""
    out = tmp_path_factory.mktemp("small") / "run"
    script = out.parent / "start.py"
    script.write_text(
        textwrap.dedent(f"""
        from pathlib import Path
        from evolution_manager.evolution.run_config import RunConfig
        from evolution_manager.evolution.run import Run
        from swarm_sim.evaluation import BatchEvaluator
        run = Run.start(RunConfig.make("qd", "food", 400, 2), Path({str(out)!r}), BatchEvaluator())
        run.execute(checkpoint_interval=0, stop_after=200)
        """)
    )
    done = subprocess.run([sys.executable, str(script)], capture_output=True, text=True)
    assert done.returncode == 0, done.stderr
    return out


def _damage(checkpoint: Path, how: str) -> None:
    state = json.loads(checkpoint.read_text())
    if how == "format only":
        state = {"format": 1}
    elif how == "unknown algorithm":
        state["algorithm"]["algorithm"] = "annealing"
    elif how == "unknown node in the archive":
        bins = state["algorithm"]["archive"]["bins"]
        bins[-1]["items"][0]["tree"] = "sel(seq(on_food, teleport), forward)"
    checkpoint.write_text(json.dumps(state))


@pytest.mark.parametrize("how", ["format only", "unknown algorithm", "unknown node in the archive"])
def test_a_checkpoint_wrong_inside_is_refused_in_one_line_before_anything_changes(tmp_path, small_run, how):
    out = tmp_path / "run"
    shutil.copytree(small_run, out)
    _damage(out / "checkpoint.json", how)
    with open(out / "evaluations.csv", "a") as log:
        log.write("999,1,a row past the checkpoint\n")
    before = {p.name: p.read_bytes() for p in out.iterdir() if p.is_file()}
    done = subprocess.run(
        [exe("evolve"), "--out", str(out), "--resume", *QUIET],
        capture_output=True,
        text=True,
    )
    assert done.returncode == 2, done.stdout
    assert "checkpoint.json" in one_line_error(done.stderr)
    after = {p.name: p.read_bytes() for p in out.iterdir() if p.is_file() and p.name != ".lock"}
    assert after == {k: v for k, v in before.items() if k != ".lock"}


def _small_trial_bag(path: Path) -> None:
    types = swarm_typestore().types
    with BagRecorder(path) as bag:
        for step in range(3000):
            stamp = types["builtin_interfaces/msg/Time"](sec=step, nanosec=0)
            msg = bag.message(
                "swarm_msgs/msg/TrialStart",
                header=types["std_msgs/msg/Header"](stamp=stamp, frame_id=""),
                seed=step,
                trial=0,
                arena_configuration=0,
                robots=9,
                tree_keys=np.arange(9, dtype=np.uint64),
                ticks=40,
                world="",
            )
            bag.write("/trial_start", msg, step + 1)


@pytest.mark.parametrize("damage", ["truncated mcap", "empty mcap", "empty metadata.yaml"])
@pytest.mark.parametrize("verify", [False, True])
def test_replay_of_a_damaged_bag_is_one_line(tmp_path, damage, verify):
    bag = tmp_path / "bag"
    _small_trial_bag(bag)
    (mcap,) = bag.glob("*.mcap")
    if damage == "truncated mcap":
        mcap.write_bytes(mcap.read_bytes()[: mcap.stat().st_size // 2])
    elif damage == "empty mcap":
        mcap.write_bytes(b"")
    else:
        (bag / "metadata.yaml").write_text("")
    command = [exe("replay"), str(bag), *(["--verify"] if verify else ["--rate", "0", "--delay", "0"])]
    done = subprocess.run(command, capture_output=True, text=True, timeout=120)
    assert done.returncode == 2, done.stdout
    assert one_line_error(done.stderr).startswith("replay: ")


def test_trial_with_a_bag_in_an_unusable_place_is_one_line(tmp_path):
    (tmp_path / "a_file").write_text("")
    done = subprocess.run(
        [exe("trial"), "--tree", "forward", "--bag", str(tmp_path / "a_file" / "t.bag")],
        capture_output=True,
        text=True,
        timeout=300,
    )
    assert done.returncode == 2
    assert "a_file" in one_line_error(done.stderr)


# 7. Temporary files of a killed writer are removed on resume ----------------------------------------------
def test_a_checkpoint_write_killed_half_way_leaves_no_temporary_file_after_resume(tmp_path):
    out = tmp_path / "run"
    child = python_child(
        tmp_path,
        f"""
        import os, signal
        from pathlib import Path
        from evolution_manager.evolution.run_config import RunConfig
        from evolution_manager.evolution.run import Run
        run = Run.start(RunConfig.make("qd", "food", 100, 3), Path({str(out)!r}), None)
        os.replace = lambda *args: os.kill(os.getpid(), signal.SIGKILL)  # die before the rename
        run.checkpoint()
        """,
    )
    child.wait()
    assert child.returncode == -signal.SIGKILL
    assert list(out.glob(".checkpoint.json.*.tmp")), "the kill did not leave the temporary file"
    resume = [exe("evolve"), "--out", str(out), "--resume", *QUIET]
    done = subprocess.run(resume, capture_output=True, text=True)
    assert done.returncode == 0, done.stderr
    assert not list(out.rglob("*.tmp"))


# 8. ws/setup repairs instead of deleting ------------------------------------------------------------------
def test_setup_does_not_delete_an_environment_whose_interpreter_fails(tmp_path):
    ws = tmp_path / "ws"
    ws.mkdir()
    for name in ("setup", "requirements.txt", "check_venv.py"):
        shutil.copy2(ROOT / "ws" / name, ws / name)
    venv_bin = ws / ".venv" / "bin"
    venv_bin.mkdir(parents=True)
    (ws / ".venv" / "precious").write_text("installed packages")
    (venv_bin / "python").write_text("#!/bin/sh\nexit 1\n")  # runs, but fails (a transient failure)
    (venv_bin / "python").chmod(0o755)
    fake = tmp_path / "python3"  # answers the version check, but cannot make environments
    fake.write_text(f'#!/bin/sh\nif [ "$1" = "-m" ]; then exit 1; fi\nexec {sys.executable} "$@"\n')
    fake.chmod(0o755)
    env = {k: v for k, v in os.environ.items() if k not in ("VIRTUAL_ENV",)} | {"PYTHON": str(fake)}
    done = subprocess.run(["bash", str(ws / "setup")], capture_output=True, text=True, env=env, timeout=120)
    assert done.returncode == 1
    assert (ws / ".venv" / "precious").read_text() == "installed packages"
    assert "nothing was deleted" in done.stderr


# 9. Signals end the main job with 130 / 143, and it can be continued --------------------------------------
def test_the_manager_ends_with_143_on_sigterm_and_stops_its_evaluators(tmp_path):
    with reserved_domain() as domain:
        manager = subprocess.Popen(
            [exe("manager"), *QD, "--evaluations", "100000", "--out", str(tmp_path / "m"), *TWO_EVALUATORS],
            env=domain_environment(domain),
            stdout=subprocess.PIPE,
            stderr=subprocess.STDOUT,
            text=True,
        )
        wait_for(lambda: progress_rows(tmp_path / "m") >= 2, "two batches", process=manager)
        evaluators = descendants(manager.pid)
        manager.send_signal(signal.SIGTERM)
        output, _ = manager.communicate(timeout=120)
    assert manager.returncode == 143, output
    assert "Traceback" not in output and "RCLError" not in output
    assert "continue with" in output
    assert gone_soon(evaluators, timeout=1.0) == set()


def test_the_main_job_ends_with_130_on_sigint_to_its_pid_and_continues_with_resume(tmp_path):
    out = tmp_path / "job"
    main = subprocess.Popen(
        [exe("main"), "--evaluations", "300", "--evaluators", "1", "--out", str(out)],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )
    wait_for(lambda: progress_rows(out) >= 1, "the first batch", timeout=600, process=main)
    below = descendants(main.pid)
    main.send_signal(signal.SIGINT)  # to its PID alone, as `kill -INT PID` does
    _, stderr = main.communicate(timeout=120)
    assert main.returncode == 130, stderr
    assert f"ws/run --resume --out {out}" in stderr.strip().splitlines()[-1]
    assert "Traceback" not in stderr
    assert gone_soon(below, timeout=1.0) == set()

    done = subprocess.run(
        [exe("main"), "--resume", "--evaluators", "1", "--evaluations", "300", "--out", str(out)],
        capture_output=True,
        text=True,
        timeout=900,
    )
    assert done.returncode == 0, done.stderr[-3000:]
    assert (out / "best_trial.bag" / "metadata.yaml").exists()
    # The bags, segment after segment, hold every evaluation of evaluations.csv once and in order, those
    # answered from the fixed scenario's cache marked; the others are the run's simulations.
    segments = sorted(out.glob("run*.bag"), key=lambda p: (p.name != "run.bag", len(p.name), p.name))
    recorded = [m.message for s in segments for m in read_bag(s) if m.topic == "/evaluations"]
    with open(out / "evaluations.csv", newline="") as handle:
        evaluated = [row["tree"] for row in csv.DictReader(handle)]
    assert [m.tree for m in recorded] == evaluated
    summary = json.loads((out / "summary.json").read_text())
    assert sum(not m.cached for m in recorded) == summary["simulations"] > 0


# 10. A killed evaluator is noticed at once ----------------------------------------------------------------
def test_a_chunk_of_a_measured_evaluator_is_re_sent_within_seconds():
    dispatcher = Dispatcher(max_chunk=10, timeouts=Timeouts())
    dispatcher.appeared("a")
    dispatcher.start_batch([1] * 10, [10] * 10)
    (first,) = dispatcher.assign(0.0)
    dispatcher.answered(first, ["result"] * 10, 0.2)  # a chunk takes 0.2 s
    dispatcher.start_batch([1] * 10, [10] * 10)
    (second,) = dispatcher.assign(1.0)
    assert second.deadline - second.sent <= 5.0


def test_an_evaluator_process_the_manager_started_is_replaced_when_killed(tmp_path):
    out, budget, seed = tmp_path / "run", 1000, 6
    with reserved_domain() as domain:
        manager = subprocess.Popen(
            [
                exe("manager"),
                *QD,
                "--evaluations",
                str(budget),
                "--seed",
                str(seed),
                "--out",
                str(out),
                "--scenarios",  # fresh: every evaluation simulated and recorded (fixed ones cache repeats)
                "fresh",
                *TWO_EVALUATORS,
                *QUIET,
            ],
            env=domain_environment(domain),
            stdout=subprocess.PIPE,
            stderr=subprocess.STDOUT,
            text=True,
        )
        wait_for(lambda: progress_rows(out) >= 2, "two batches", process=manager)
        victim = min(descendants(manager.pid))
        os.kill(victim, signal.SIGKILL)
        output, _ = manager.communicate(timeout=600)
    assert manager.returncode == 0, output
    assert "exited (code -9)" in output and " died" in output
    assert "did not answer within" not in output
    assert bag_evaluations(out) == [evaluation_seed(seed, i) for i in range(evaluation_rows(out))]
