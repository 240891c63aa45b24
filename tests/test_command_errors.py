"""Command errors as a user meets them (issue 25's defects that live in the commands), each probed (real
processes, a real full disk, real signals, real bags). Every refusal is one line and exit status 2 (74 for a
failed write), and nothing already saved changes."""

from __future__ import annotations

import csv
import json
import shutil
import signal
import subprocess
import time
from pathlib import Path

import pytest
from ament_index_python.packages import get_package_prefix

from swarm_sim.evaluation import named_values

QUIET = ["--no-figures", "--no-progress"]
QD_FOOD = ["--algorithm", "qd", "--objective", "food"]
EVERY_BATCH = ["--checkpoint-every", "0", *QUIET]
DAMAGE = ["--condition", "dead-robots=2", "--budget", "2"]
EX_IOERR = 74


def exe(name: str, package: str = "evolution_manager") -> str:
    return str(Path(get_package_prefix(package)) / "lib" / package / name)


def one_line_error(stderr: str) -> str:
    lines = [line for line in stderr.strip().splitlines() if line.strip()]
    assert "Traceback" not in stderr, stderr
    assert len(lines) == 1, stderr
    return lines[0]


def saved(root: Path) -> dict[str, bytes]:
    """Every file of a run directory (its lock aside), by name."""
    return {
        str(p.relative_to(root)): p.read_bytes() for p in root.rglob("*") if p.is_file() and p.name != ".lock"
    }


@pytest.fixture(scope="module")
def finished_run(tmp_path_factory):
    out = tmp_path_factory.mktemp("finished") / "run"
    done = subprocess.run(
        [exe("evolve"), *QD_FOOD, "--evaluations", "150", "--seed", "3", "--out", str(out), *EVERY_BATCH],
        capture_output=True,
        text=True,
    )
    assert done.returncode == 0, done.stderr
    return out


def _edit_json(path: Path, change, literal: str | None = None) -> None:
    """Apply ``change`` to the JSON document at ``path``; a ``"<LITERAL>"`` it leaves becomes ``literal`` (a
    number JSON allows but Python cannot hold, such as 1e400)."""
    document = json.loads(path.read_text())
    change(document)
    text = json.dumps(document)
    path.write_text(text.replace('"<LITERAL>"', literal) if literal else text)


def _set(*keys: str, value: object):
    def change(document: dict) -> None:
        for key in keys[:-1]:
            document = document[key]
        document[keys[-1]] = value

    return change


@pytest.mark.parametrize(
    ("file", "change", "literal", "says"),
    [
        ("config.json", _set("evaluations", value="<LITERAL>"), "1e400", "1e400"),
        ("checkpoint.json", _set("config", "evaluations", value="<LITERAL>"), "1e400", "1e400"),
        ("config.json", _set("evaluations", value=2.5), None, "evaluations"),
        ("checkpoint.json", _set("offsets", "evaluations", value=-5), None, "offsets"),
        ("checkpoint.json", _set("offsets", "progress", value=10**30), None, "progress"),
        ("checkpoint.json", _set("evaluations", value=True), None, "evaluations"),
    ],
)
def test_a_damaged_number_in_a_run_is_refused_in_one_line_naming_the_file(
    tmp_path, finished_run, file, change, literal, says
):
    out = tmp_path / "run"
    shutil.copytree(finished_run, out)
    _edit_json(out / file, change, literal)
    before = saved(out)
    done = subprocess.run(
        [exe("evolve"), "--out", str(out), "--resume", *QUIET], capture_output=True, text=True
    )
    assert done.returncode == 2, done.stderr
    line = one_line_error(done.stderr)
    assert file in line and says in line, line
    assert saved(out) == before


def test_a_full_disk_is_one_line_and_the_run_continues_when_space_is_freed(tmp_path, finished_run):
    """``evolve --out`` on a 160 KB file system (a real tmpfs, mounted in a mount namespace of the test's
    own): exit 74, one line naming the file and the error, and after the space is freed ``--resume`` ends
    with exactly the files of a run that never ran out of space."""
    disk = tmp_path / "disk"
    disk.mkdir()
    options = ["--algorithm", "qd", "--objective", "food", "--evaluations", "1500", "--seed", "3"]
    script = f"""
        mount -t tmpfs -o size=160k tmpfs {disk} || exit 99
        {exe("evolve")} {" ".join(options)} --out {disk}/run --checkpoint-every 0 {" ".join(QUIET)} \\
            2> {tmp_path}/full.err; echo $? > {tmp_path}/full.rc
        cp -r {disk}/run {tmp_path}/at_full 2> /dev/null
        mount -o remount,size=64m {disk}
        {exe("evolve")} --out {disk}/run --resume {" ".join(QUIET)} 2> {tmp_path}/resume.err
        echo $? > {tmp_path}/resume.rc
        cp -r {disk}/run {tmp_path}/resumed
    """
    done = subprocess.run(
        ["unshare", "--user", "--map-root-user", "--mount", "bash", "-c", script], timeout=900
    )
    assert done.returncode == 0, "could not mount a tmpfs in a mount namespace of the test's own"
    assert int((tmp_path / "full.rc").read_text()) == EX_IOERR, (tmp_path / "full.err").read_text()
    line = one_line_error((tmp_path / "full.err").read_text())
    assert "No space left on device" in line and str(disk) in line, line
    assert "evolve --out" in line and "--resume" in line  # how to continue
    assert int((tmp_path / "resume.rc").read_text()) == 0, (tmp_path / "resume.err").read_text()
    straight = tmp_path / "straight"
    subprocess.run(
        [exe("evolve"), *options, "--out", str(straight), "--checkpoint-every", "0", *QUIET], check=True
    )
    for name in ("evaluations.csv", "progress.csv", "repertoire_food.json", "summary.json", "archive.json"):
        assert (tmp_path / "resumed" / name).read_bytes() == (straight / name).read_bytes(), name


def test_sigterm_of_evolve_says_how_to_continue(tmp_path):
    out = tmp_path / "run"
    process = subprocess.Popen(
        [
            exe("evolve"),
            "--algorithm",
            "gp",
            "--objective",
            "nest",
            "--evaluations",
            "20000",
            "--out",
            str(out),
            *QUIET,
        ],
        stderr=subprocess.PIPE,
        text=True,
    )
    deadline = time.monotonic() + 300
    while not (out / "progress.csv").exists() and time.monotonic() < deadline and process.poll() is None:
        time.sleep(0.1)
    process.send_signal(signal.SIGTERM)
    _, stderr = process.communicate(timeout=120)
    assert process.returncode == 143, stderr
    assert f"continue with: evolve --out {out} --resume" in one_line_error(stderr)


def test_adapt_refuses_a_repertoire_item_outside_the_grid(tmp_path, finished_run):
    run = tmp_path / "run"
    shutil.copytree(finished_run, run)
    _edit_json(run / "repertoire_food.json", lambda d: d["items"][0].update(bin=[9, 42, -3]))
    done = subprocess.run(
        [
            exe("adapt"),
            "--repertoire",
            str(run),
            "--objective",
            "food",
            "--out",
            str(tmp_path / "adapt"),
            *DAMAGE,
        ],
        capture_output=True,
        text=True,
    )
    assert done.returncode == 2, done.stderr
    line = one_line_error(done.stderr)
    assert "repertoire_food.json" in line and "[9, 42, -3]" in line, line
    assert not (tmp_path / "adapt").exists()


def test_a_killed_recorder_leaves_nothing_in_its_bag_folder_but_the_bag(tmp_path, workspace):
    bag = tmp_path / "killed.bag"
    recorder = subprocess.Popen(
        [exe("record"), "--bag", str(bag)],
        env=workspace.env,
        stdout=subprocess.PIPE,
        stderr=subprocess.STDOUT,
    )
    deadline = time.monotonic() + 120
    while not any(bag.glob("*.mcap")) and time.monotonic() < deadline and recorder.poll() is None:
        time.sleep(0.1)
    assert recorder.poll() is None, recorder.stdout.read()
    recorder.kill()
    recorder.wait()
    assert sorted(p.name for p in bag.iterdir()) == ["killed.bag.mcap"]


def test_the_run_bag_holds_every_evaluation_once_in_order_cached_ones_marked(tmp_path, workspace):
    """Under fixed scenarios a tree asked again (under ``paper``: a tree whose simplified form an earlier
    batch evaluated) is answered from the run's cache: still an evaluation, so the bag has its message too,
    marked ``cached``."""
    from evolution_manager.evolution.archive import SimplifiedForms
    from evolution_manager.evolution.run import SIMULATED, Run
    from evolution_manager.recording.bags import read_bag

    out = tmp_path / "run"
    done = subprocess.run(
        [
            exe("manager"),
            *QD_FOOD,
            "--evaluations",
            "300",
            "--seed",
            "4",
            "--evaluators",
            "1",
            "--out",
            str(out),
            *QUIET,
        ],
        env=workspace.env,
        capture_output=True,
        text=True,
        timeout=600,
    )
    assert done.returncode == 0, done.stderr
    with open(out / "evaluations.csv", newline="") as handle:
        rows = list(csv.DictReader(handle))
    messages = [m.message for m in read_bag(out / "run.bag") if m.topic == "/evaluations"]
    assert [(m.tree, m.seed) for m in messages] == [(r["tree"], int(r["seed"])) for r in rows]
    assert [named_values(m)["food"] for m in messages if m.ok] == [
        float(r["food"]) for r in rows if not r["error"]
    ]
    summary = json.loads((out / "summary.json").read_text())
    assert sum(m.cached for m in messages) == summary["simulations_saved"] > 0
    # exactly those the run answered without simulating, as its files replayed say
    answers = Run.resume(out, None, cut=False).answers
    assert [m.cached for m in messages] == [a != SIMULATED for a in answers]
    forms = SimplifiedForms()
    simulated: dict[str, set] = {}
    for m in messages:  # a cached answer: the values of an earlier simulation of its tree, or (paper) of a
        values = tuple(
            named_values(m)[name]
            for name in ("density", "nest", "food", "movement", "rotation", "conditionality")
        )  # simplified clone
        if m.cached:
            assert values in simulated[forms(m.tree)]
        else:
            simulated.setdefault(forms(m.tree), set()).add(values)


@pytest.mark.parametrize(
    ("parameters", "says"),
    [
        (
            '/**:\n  ros__parameters:\n    wheel_speed: "fast"\n',
            "parameter wheel_speed: 'fast': expected a floating",
        ),
        ("/**:\n  ros__parameters:\n    wheel_speed: 50\n", "(write 80.0, not 80)"),
        (
            "/**:\n  ros__parameters:\n    gain_low: 50.0\n",
            "gain_low: 50.0: expected a number in [0.0, 10.0]",
        ),
        ("/**:\n  ros__parameters:\n    arena_half: -5.0\n", "arena_half must be positive"),
        ("/**:\n  ros__parameters:\n    wheel_sped: 50.0\n", "did you mean wheel_speed?"),
        ("/simulator:\n  ros__parameters:\n    answer_timeout: 0.0\n", "answer_timeout: 0.0: expected"),
        ("/**:\n  ros__parameters:\n    n_robots: -3\n", "n_robots -3"),
        ("/**:\n  ros__parameters:\n    wheel_speed: [50.0\n", "line"),
    ],
)
def test_trial_refuses_a_mistyped_parameter_before_the_graph_starts(tmp_path, workspace, parameters, says):
    """Issue 41, item 18: a mistyped value in --params-file was refused only once the graph was up (32 s
    cold); the trial command now checks the simulator's values first: one line, status 2, no node started
    (no node logs), no bag."""
    params = tmp_path / "params.yaml"
    params.write_text(parameters)
    where = ["--bag", str(tmp_path / "t.bag"), "--domain", str(workspace.domain)]
    done = subprocess.run(
        [exe("trial"), "--tree", "forward", "--seed", "1", *where, "--params-file", str(params)],
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert done.returncode == 2, done.stdout + done.stderr
    line = one_line_error(done.stderr)
    assert says in line and str(params) in line, line
    assert "graph in ROS domain" not in done.stderr
    assert not (tmp_path / "t.bag.logs").exists() and not (tmp_path / "t.bag").exists()
