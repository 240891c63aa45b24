"""The hostile-files probe (``ws/probe-hostile``, ``docs/security.md``): every command of ``ws/run`` against
hostile and careless inputs, each case classified by what it did.

A case (``hostile_cases.CASES``) is a command line with placeholders, the things planted in the case's own
folder before it runs (copies of the probe's fixtures, symbolic links to a saved file or to nothing,
folders where a file is expected, files under a file, damaged files) and what the command must do with it:
refuse (exit status 2, or 74 for an output it cannot write), succeed, or either. Each case runs as a
process of its own, in its own folder, through the command's installed entry point (the one ``ws/run PACKAGE
EXECUTABLE`` starts) with the tree under test's ``src/`` first on ``PYTHONPATH``. No case starts a ROS graph:
``rclpy.init``, the graph's start (``evolution_manager.graph.startup.Graph``) and the main job's manager
process (not its ``evolve`` on a cluster, which starts no ROS) are replaced by a guard that ends the process
with a line saying the command got past its checks (``GUARD_STATUS``).

Verdicts, in the order they are given (the first that applies):

- ``LOST``: something saved changed or was deleted (a file of the case's folder the case does not name as an
  output, or the saved file outside that links point to; a lock file, which holds its holder's process id,
  is not saved data), something was written outside the case's folder (through a link: the outside folder
  gained an entry), or a refused command left something behind;
- ``TRACEBACK``: a Python traceback, a crash by signal, a hang past the case's time limit, or any other ending
  that is neither a clean refusal nor a success: a refusal in several lines or with another exit status, a
  valid input refused;
- ``SILENT``: bad input accepted (exit status 0, or the command got past its checks to the guard), or refused
  without a word;
- ``OK``: a clean refusal (the expected status, exactly one line on standard error, nothing written) or a
  correct success (status 0, or the guard reached where the case expects the command to get that far, and
  the outputs the case names made).
"""

from __future__ import annotations

import argparse
import contextlib
import hashlib
import json
import os
import re
import shutil
import signal
import subprocess
import sys
import tempfile
import time
from collections import Counter
from collections.abc import Callable, Iterable, Sequence
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass, field
from pathlib import Path

OK, TRACEBACK, SILENT, LOST = "OK", "TRACEBACK", "SILENT", "LOST"
VERDICTS = (OK, TRACEBACK, SILENT, LOST)
CASE_ERROR = "CASE-ERROR"
"""Not a verdict: a case the probe could not set up (its planting failed), listed apart."""
REFUSE, SUCCEED, EITHER = "refuse", "succeed", "either"
GUARD_STATUS = 97
"""The exit status of a command stopped by the probe's guard, where it would have started ROS."""
GUARD_LINE = "hostile-probe: past the checks: the command would start ROS here"
REFUSALS = (2, 74)
"""Exit statuses of a refusal: usage (2) and a result that cannot be written (74, sysexits' EX_IOERR)."""
SAVED_TEXT = b"keep me\n"


# --- what a case plants ------------------------------------------------------------------------------------


@dataclass(frozen=True)
class Copy:
    """A copy of the probe's fixture ``fixture`` at ``path`` in the case's folder (links copied as links)."""

    fixture: str
    path: str


@dataclass(frozen=True)
class Link:
    """A symbolic link at ``path`` to ``target`` (placeholders allowed: ``{saved}``, ``{outside}``)."""

    path: str
    target: str


@dataclass(frozen=True)
class Write:
    """A file at ``path`` holding ``data``."""

    path: str
    data: bytes


@dataclass(frozen=True)
class Folder:
    """An empty folder at ``path``."""

    path: str


@dataclass(frozen=True)
class Edit:
    """The file at ``path`` (a fixture copied before) changed by ``how`` (bytes to bytes), e.g. truncated."""

    path: str
    how: Callable[[bytes], bytes]


@dataclass(frozen=True)
class Remove:
    """The file or link at ``path`` removed (to plant a link where a run keeps a file)."""

    path: str


Step = Copy | Link | Write | Folder | Edit | Remove


@dataclass(frozen=True)
class Case:
    """One command line against one hostile (or careless) input.

    ``command``: ``PACKAGE EXECUTABLE`` as for ``ws/run``. ``args``: its arguments, with ``{case}`` (the
    case's folder, also the working directory), ``{saved}`` (a saved file outside it), ``{outside}`` (the
    folder links point into) and ``{fixture}`` for each fixture (``run``, ``bag``, ...: a copy in the case's
    folder).
    ``expect``: ``refuse``, ``succeed`` or ``either``. ``writes``: glob patterns (relative to the case's
    folder) of what a success may change; ``makes``: files a success must leave. ``guard``: whether getting
    to the guard (where ROS would start) is the success this case expects."""

    name: str
    command: str
    args: tuple[str, ...]
    plant: tuple[Step, ...] = ()
    expect: str = REFUSE
    writes: tuple[str, ...] = ()
    makes: tuple[str, ...] = ()
    guard: bool = False
    timeout: float = 60.0
    statuses: tuple[int, ...] = REFUSALS


@dataclass
class Outcome:
    """What running a case did."""

    status: int | None  # None: killed at the time limit
    stdout: str
    stderr: str
    changed: list[str] = field(default_factory=list)  # saved entries changed or removed, entries outside
    left: list[str] = field(default_factory=list)  # new entries in the case's folder
    missing: list[str] = field(default_factory=list)  # outputs the case names that are not there
    seconds: float = 0.0


# --- classifying --------------------------------------------------------------------------------------------


def _lines(text: str) -> list[str]:
    return [line for line in text.splitlines() if line.strip()]


def classify(case: Case, outcome: Outcome) -> tuple[str, str]:
    """The verdict of ``outcome`` for ``case`` and a short reason (the module docstring's rules)."""
    err = _lines(outcome.stderr)
    guarded = outcome.status == GUARD_STATUS and GUARD_LINE in outcome.stderr
    if outcome.changed:
        return LOST, "changed: " + ", ".join(outcome.changed[:4])
    text = outcome.stdout + outcome.stderr
    if "Traceback (most recent call last)" in text:
        last = [line for line in _lines(text) if not line.startswith(" ")][-1:]
        return TRACEBACK, "traceback: " + (last[0] if last else "")
    if outcome.status is None:
        return TRACEBACK, "hung: killed at its time limit"
    if outcome.status < 0:
        return TRACEBACK, f"killed by signal {-outcome.status}"
    succeeded = outcome.status == 0 or (guarded and case.guard)
    refused = outcome.status in case.statuses and not guarded
    if case.expect == REFUSE and (outcome.status == 0 or guarded):
        how = "got past its checks to the guard" if guarded else "exit status 0"
        return SILENT, f"accepted: {how}" + (f" ({err[-1]})" if err and not guarded else "")
    if refused and case.expect in (REFUSE, EITHER):
        if not err:
            return SILENT, f"exit status {outcome.status} without a word"
        if outcome.left:
            return LOST, "refused but left: " + ", ".join(outcome.left[:4])
        if len(err) != 1:
            return TRACEBACK, f"refused in {len(err)} lines: {err[0]}"
        return OK, err[0]
    if succeeded and case.expect in (SUCCEED, EITHER):
        if outcome.missing:
            return TRACEBACK, "succeeded without making " + ", ".join(outcome.missing)
        return OK, "succeeded" + (" (got to the guard)" if guarded else "") + (f": {err[-1]}" if err else "")
    if case.expect == SUCCEED and refused:
        return TRACEBACK, f"a valid input refused: {err[-1] if err else outcome.status}"
    return TRACEBACK, f"exit status {outcome.status}: {err[-1] if err else 'no line'}"


# --- the world a case runs in -------------------------------------------------------------------------------


def _fingerprint(folder: Path) -> dict[str, str]:
    """Every entry under ``folder`` (links not followed): a link's target, a file's digest, or a folder."""
    found: dict[str, str] = {}
    if not folder.exists():
        return found
    for root, folders, files in os.walk(folder):
        for name in folders + files:
            path = Path(root) / name
            key = str(path.relative_to(folder))
            if path.is_symlink():
                found[key] = "link:" + os.readlink(path)
            elif path.is_file():
                found[key] = "file:" + hashlib.sha1(path.read_bytes()).hexdigest()
            else:
                found[key] = "folder"
        folders[:] = [name for name in folders if not (Path(root) / name).is_symlink()]
    return found


def _matches(name: str, patterns: Iterable[str]) -> bool:
    from fnmatch import fnmatch

    return any(name == p or fnmatch(name, p) or name.startswith(p.rstrip("*/") + "/") for p in patterns)


def _is_lock(name: str) -> bool:
    """A lock file holds its holder's process id, rewritten by every command that takes it: not saved data
    (a link planted at one is still watched: what it points to is outside, and that must not change)."""
    return Path(name).name == ".lock" or name.endswith(".lock")


def _expand(text: str, values: dict[str, str]) -> str:
    return re.sub(r"\{(\w+)\}", lambda m: values.get(m.group(1), m.group(0)), text)


def _fixtures_named(case: Case, fixtures: dict[str, Path]) -> list[str]:
    texts = [*case.args, *(getattr(step, "target", "") for step in case.plant)]
    return [name for name in fixtures if any(f"{{{name}}}" in text for text in texts)]


def prepare(case: Case, folder: Path, fixtures: dict[str, Path]) -> dict[str, str]:
    """Make the case's folder (``folder/case``) and the outside folder (``folder/outside``, with the saved
    file), copy the fixtures it names and plant its steps; return the placeholders' values."""
    here, outside = folder / "case", folder / "outside"
    here.mkdir(parents=True)
    outside.mkdir()
    (outside / "saved.txt").write_bytes(SAVED_TEXT)
    values = {"case": str(here), "outside": str(outside), "saved": str(outside / "saved.txt")}
    for name in _fixtures_named(case, fixtures):
        values[name] = str(_copy(fixtures[name], here / name))
    for step in case.plant:
        path = here / _expand(getattr(step, "path", ""), values)
        if isinstance(step, Copy):
            _copy(fixtures[step.fixture], path)
        elif isinstance(step, Link):
            path.parent.mkdir(parents=True, exist_ok=True)
            path.symlink_to(_expand(step.target, values))
        elif isinstance(step, Write):
            path.parent.mkdir(parents=True, exist_ok=True)
            path.write_bytes(step.data)
        elif isinstance(step, Folder):
            path.mkdir(parents=True, exist_ok=True)
        elif isinstance(step, Edit):  # a pattern (bag/*.mcap) edits every file it names
            for each in sorted(path.parent.glob(path.name)) if "*" in path.name else [path]:
                each.write_bytes(step.how(each.read_bytes()))
        elif isinstance(step, Remove):
            if path.is_dir() and not path.is_symlink():
                shutil.rmtree(path)
            else:
                path.unlink()
    return values


def _copy(source: Path, destination: Path) -> Path:
    destination.parent.mkdir(parents=True, exist_ok=True)
    if source.is_dir():
        shutil.copytree(source, destination, symlinks=True)
    else:
        shutil.copyfile(source, destination)
    return destination


def run_case(case: Case, folder: Path, fixtures: dict[str, Path], environment: dict[str, str]) -> Outcome:
    """Run ``case`` in ``folder`` (made here): its planted world, the command, and what changed."""
    values = prepare(case, folder, fixtures)
    here, outside = Path(values["case"]), Path(values["outside"])
    before_here, before_outside = _fingerprint(here), _fingerprint(outside)
    package, executable = case.command.split()
    argv = [_expand(arg, values) for arg in case.args]
    command = [sys.executable, str(Path(__file__).resolve()), "--launch", package, executable, "--", *argv]
    started = time.monotonic()
    with subprocess.Popen(
        command,
        cwd=here,
        env=environment,
        stdin=subprocess.DEVNULL,
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        start_new_session=True,  # its own process group: a hung case is killed with whatever it started
    ) as process:
        try:
            out, err = process.communicate(timeout=case.timeout)
            status: int | None = process.returncode
        except subprocess.TimeoutExpired:
            with contextlib.suppress(ProcessLookupError):
                os.killpg(process.pid, signal.SIGKILL)
            out, err = process.communicate()
            status = None
    seconds = time.monotonic() - started
    after_here, after_outside = _fingerprint(here), _fingerprint(outside)
    changed = [
        name
        for name, digest in before_here.items()
        if after_here.get(name) != digest and not _matches(name, case.writes) and not _is_lock(name)
    ]
    changed += [f"outside/{name}" for name in sorted(set(after_outside) | set(before_outside))
                if after_outside.get(name) != before_outside.get(name)]  # fmt: skip
    left = [name for name in after_here if name not in before_here]
    return Outcome(
        status,
        out.decode(errors="backslashreplace"),
        err.decode(errors="backslashreplace"),
        changed,
        left if status != 0 else [],
        [name for name in case.makes if not (here / _expand(name, values)).exists()],
        seconds,
    )


# --- the fixtures -------------------------------------------------------------------------------------------


def _existing(folder: Path) -> dict[str, Path]:
    """The fixtures already made in ``folder`` (a ``--fixtures`` folder of an earlier run)."""
    if not folder.is_dir():
        return {}
    found = {}
    for name in FIXTURES:
        path = folder / FIXTURE_FILES.get(name, name)
        if path.exists():
            found[name] = path
    return found


def fixtures_needed(cases: Iterable[Case]) -> set[str]:
    """The fixtures ``cases`` name (placeholders and ``Copy`` steps)."""
    needed: set[str] = set()
    for case in cases:
        texts = [*case.args, *(getattr(step, "target", "") for step in case.plant)]
        needed |= {name for name in FIXTURES if any(f"{{{name}}}" in text for text in texts)}
        needed |= {step.fixture for step in case.plant if isinstance(step, Copy)}
    return needed


def make_fixtures(folder: Path, needed: Iterable[str] | None = None) -> dict[str, Path]:
    """The files cases start from (``needed``, default all of ``FIXTURES``), made with the tree under test's
    own code in this process: a small finished run, a run stopped after its first batch, a trial bag, a
    library, a swarm layout, a ROS parameter file, a task file, cluster settings, a validation reference."""
    folder.mkdir(parents=True, exist_ok=True)
    return {name: FIXTURES[name](folder) for name in sorted(set(FIXTURES if needed is None else needed))}


def _finished_run(folder: Path) -> Path:
    from evolution_manager.studies.evolve import evolve

    run = folder / "run"
    options = ["--algorithm", "qd", "--objective", "food", "--evaluations", "2", "--seed", "1"]
    quiet = ["--no-figures", "--no-progress", "--checkpoint-every", "0"]
    with contextlib.redirect_stdout(sys.stderr):
        if evolve([*options, "--out", str(run), *quiet]) != 0:
            raise SystemExit("hostile-probe: the fixture run could not be made")
    (run / ".lock").unlink(missing_ok=True)  # a finished run as shared: no lock left
    return run


def _unfinished_run(folder: Path) -> Path:
    from evolution_manager.evolution.run import Run
    from evolution_manager.evolution.run_config import RunConfig
    from swarm_sim.evaluation import BatchEvaluator

    unfinished = folder / "unfinished"
    config = RunConfig.make("qd", "food", 60, 5, trials=1)
    stopped = Run.start(config, unfinished, BatchEvaluator(config.world(), threads=1))
    stopped.execute(checkpoint_interval=0, stop_after=1)
    if stopped.lock is not None:
        stopped.lock.release()
    return unfinished


def _text_file(name: str, text: Callable[[], str]) -> Callable[[Path], Path]:
    def make(folder: Path) -> Path:
        (folder / name).write_text(text())
        return folder / name

    return make


def _library() -> str:
    source = {"run": "elsewhere", "objective": "food", "blocks": 1, "block": [0, 0, 0], "bin": [3, 4, 2]}
    primitive = {"name": "gotoFood1", "tree": "sel(on_food, forward)", "source": {**source, "fitness": 0.5}}
    return json.dumps({"format": 1, "primitives": [primitive]})


def _task() -> str:
    import yaml

    from swarm_sim.tasks import FORAGING, task_to_mapping

    return yaml.safe_dump(task_to_mapping(FORAGING), sort_keys=False)


def _reference() -> str:
    quantities = ("density", "nest", "food", "movement", "rotation", "conditionality")
    header = "tree\t" + "\t".join(f"{q}_mean\t{q}_sem" for q in quantities) + "\tn_seeds\n"
    return header + "stop\t" + "\t".join(["0.5\t0.01"] * 3 + ["0.0\t0.0"] * 3) + "\t20\n"


def _trial_bag(path: Path) -> Path:
    """A bag as ``trial --bag`` writes one, cut down: the arena's and robots' markers, ``/trial_start`` and
    two ``/swarm_state`` steps (what ``snapshot``, ``animate --bag`` and ``recover`` read)."""
    from geometry_msgs.msg import Point
    from rclpy.serialization import serialize_message
    from visualization_msgs.msg import Marker, MarkerArray

    from evolution_manager.recording.bags import BagRecorder
    from swarm_msgs.msg import RobotPose, SwarmState, TrialStart
    from swarm_sim.model import DEFAULT

    array = "visualization_msgs/msg/MarkerArray"
    corners = ((-1.0, -1.0), (1.0, -1.0), (1.0, 1.0), (-1.0, 1.0), (-1.0, -1.0))
    arena = Marker(type=Marker.LINE_STRIP, points=[Point(x=x, y=y) for x, y in corners])
    arena.color.a = 1.0
    robot = Marker(type=Marker.CYLINDER)
    robot.scale.x = 0.17
    robot.color.r = robot.color.a = 1.0
    start = TrialStart(seed=1, trial=0, robots=9, ticks=DEFAULT.ticks, world=json.dumps(DEFAULT.as_dict()))
    poses = [RobotPose(x=0.1 * k, y=0.0, theta=0.0) for k in range(9)]
    with BagRecorder(path) as bag:
        bag.write_cdr("/markers", array, 1, serialize_message(MarkerArray(markers=[arena])))
        bag.write_cdr("/robot_markers", array, 2, serialize_message(MarkerArray(markers=[robot])))
        bag.write_cdr("/trial_start", "swarm_msgs/msg/TrialStart", 1, serialize_message(start))
        for step in (0, 1):
            state = SwarmState(seed=1, trial=0, step=step, poses=poses)
            bag.write_cdr("/swarm_state", "swarm_msgs/msg/SwarmState", 2 + step, serialize_message(state))
    return path


FIXTURES: dict[str, Callable[[Path], Path]] = {
    "run": _finished_run,
    "unfinished": _unfinished_run,
    "bag": lambda folder: _trial_bag(folder / "trial.bag"),
    "library": _text_file("library.json", _library),
    "swarm": _text_file("swarm.json", lambda: json.dumps({"trees": ["forward"] * 9})),
    "params": _text_file("params.yaml", lambda: "/**:\n  ros__parameters:\n    answer_timeout: 30.0\n"),
    "cluster": _text_file("cluster.yaml", lambda: "cores: 1\nmemory: 2GB\nwalltime: '00:10:00'\njobs: 1\n"),
    "reference": _text_file("reference.tsv", lambda: _reference()),
    "task": _text_file("task.yaml", _task),
}
"""Each fixture's maker, by the name cases use (``{run}``, ``Copy("run", ...)``)."""
FIXTURE_FILES = {
    "bag": "trial.bag",
    "library": "library.json",
    "swarm": "swarm.json",
    "params": "params.yaml",
    "cluster": "cluster.yaml",
    "reference": "reference.tsv",
    "task": "task.yaml",
}
"""Each fixture's file or folder name in the fixtures' folder (the name itself when not here)."""


# --- running many -------------------------------------------------------------------------------------------


@dataclass(frozen=True)
class Verdict:
    case: Case
    verdict: str
    reason: str
    seconds: float


def environment(tree: Path | None = None, home: Path | None = None) -> dict[str, str]:
    """The cases' environment: this one, with ``tree``'s packages first on ``PYTHONPATH`` (the code under
    test), ROS discovery on this machine only, and ``home`` as ``HOME`` and ``TMPDIR``."""
    env = dict(os.environ)
    if tree is not None:
        src = [str(tree / "src" / package) for package in PACKAGES]
        env["PYTHONPATH"] = os.pathsep.join([*src, *filter(None, [env.get("PYTHONPATH", "")])])
    env["ROS_AUTOMATIC_DISCOVERY_RANGE"] = "LOCALHOST"
    env.pop("PYTHONDONTWRITEBYTECODE", None)  # every case imports the packages: from bytecode, not source
    if home is not None:
        (home / "tmp").mkdir(parents=True, exist_ok=True)
        env["HOME"] = str(home)
        env["TMPDIR"] = str(home / "tmp")
    return env


PACKAGES = ("bt_controller", "swarm_sim", "evolution_manager", "swarm_ros")


def run_cases(
    cases: Sequence[Case],
    work: Path,
    fixtures: dict[str, Path],
    env: dict[str, str],
    jobs: int = 2,
    progress: Callable[[Verdict], None] | None = None,
) -> list[Verdict]:
    """Every case in a folder of its own under ``work``, ``jobs`` at a time; their verdicts, in order."""

    def one(indexed: tuple[int, Case]) -> Verdict:
        index, case = indexed
        try:
            outcome = run_case(case, work / f"{index:03d}", fixtures, env)
        except Exception as error:  # the case's own planting failed: the probe's fault, said as such
            result = Verdict(
                case, CASE_ERROR, f"the case could not be set up: {type(error).__name__}: {error}", 0
            )
        else:
            verdict, reason = classify(case, outcome)
            result = Verdict(case, verdict, reason, outcome.seconds)
        if progress is not None:
            progress(result)
        return result

    with ThreadPoolExecutor(max_workers=max(1, jobs)) as pool:
        return list(pool.map(one, enumerate(cases)))


def table(verdicts: Sequence[Verdict], width: int = 150) -> str:
    """The verdict table: one line per case, then the counts by verdict."""
    lines = []
    for k, v in enumerate(verdicts):
        reason = " ".join(v.reason.split())
        line = f"{k:3d} {v.verdict:9s} {v.case.command.split()[1]:16s} {v.case.name} -- {reason}"
        lines.append(line if len(line) <= width else line[: width - 3] + "...")
    counts = Counter(v.verdict for v in verdicts)
    lines.append("")
    summary = ", ".join(f"{counts.get(name, 0)} {name}" for name in VERDICTS)
    errors = f"; {counts[CASE_ERROR]} cases could not be set up" if counts.get(CASE_ERROR) else ""
    lines.append(f"{len(verdicts)} cases: {summary}{errors}")
    return "\n".join(lines)


# --- the launcher: one case's process ---------------------------------------------------------------------


def _guard(*_: object, **__: object) -> None:
    sys.stdout.flush()
    print(GUARD_LINE, file=sys.stderr, flush=True)
    os._exit(GUARD_STATUS)


def launch(package: str, executable: str, argv: list[str]) -> None:
    """Run ``executable`` of ``package`` as ``ws/run PACKAGE EXECUTABLE ARGV`` does (its console entry
    point), with the guard where ROS would start."""
    from importlib.metadata import entry_points

    found = [
        e
        for e in entry_points(group="console_scripts", name=executable)
        if e.dist is not None and e.dist.name.replace("-", "_") == package
    ]
    if not found:
        raise SystemExit(f"hostile-probe: no executable {executable!r} in package {package!r}")
    import rclpy

    rclpy.init = _guard  # type: ignore[assignment]  # the probe never starts ROS
    if package == "evolution_manager":
        from evolution_manager.graph import startup
        from evolution_manager.graph.nodes import main_job

        startup.Graph.__enter__ = _guard  # type: ignore[assignment,method-assign]  # nor a node graph
        manager = main_job.run_manager

        def run_manager(command: list[str], env: dict[str, str]) -> tuple[int, int]:
            if Path(command[0]).name == "evolve":  # on a cluster: no ROS, and it checks the settings itself
                return manager(command, env)
            _guard()  # the manager node and its evaluator nodes
            return 0, 0

        main_job.run_manager = run_manager  # nor the main job's manager process
    main = found[0].load()
    sys.argv = [executable, *argv]
    sys.exit(main())


# --- the command ------------------------------------------------------------------------------------------


def main(argv: Sequence[str] | None = None) -> int:
    argv = list(sys.argv[1:] if argv is None else argv)
    if argv[:1] == ["--launch"]:
        package, executable, _, *rest = argv[1:]
        launch(package, executable, rest)
    parser = argparse.ArgumentParser(prog="probe-hostile", description=__doc__.split("\n\n")[0])
    parser.add_argument("--only", help="only the cases whose command or name holds this text")
    parser.add_argument("--jobs", type=int, default=2, help="cases at once (default 2)")
    parser.add_argument("--keep", type=Path, help="keep every case's folder under this new folder")
    parser.add_argument(
        "--fixtures",
        type=Path,
        help="the fixtures' folder: made there if missing, else used as it is (reruns)",
    )
    parser.add_argument("--list", action="store_true", help="list the cases and stop")
    args = parser.parse_args(argv)
    from hostile_cases import CASES

    cases = [c for c in CASES if args.only is None or args.only in f"{c.command} {c.name}"]
    if args.list:
        for k, case in enumerate(cases):
            print(f"{k:3d} {case.expect:8s} {case.command:30s} {case.name}")
        return 0
    if not cases:
        print(f"probe-hostile: no case matches {args.only!r}", file=sys.stderr)
        return 2
    if args.keep is not None and args.keep.exists():
        print(f"probe-hostile: --keep {args.keep} exists: name a new folder", file=sys.stderr)
        return 2
    work = args.keep or Path(tempfile.mkdtemp(prefix="probe-hostile-"))
    work.mkdir(parents=True, exist_ok=True)
    started = time.monotonic()
    try:
        made = args.fixtures or work / "fixtures"
        print(f"probe-hostile: {len(cases)} cases; fixtures in {made}", file=sys.stderr)
        needed = fixtures_needed(cases)
        fixtures = {name: path for name, path in _existing(made).items() if name in needed}
        fixtures |= make_fixtures(made, needed - set(fixtures))
        env = environment(None, work / "home")  # ws/probe-hostile put the tree under test on PYTHONPATH

        def progress(verdict: Verdict) -> None:
            print(f"  {verdict.verdict:9s} {verdict.case.command.split()[1]:16s} {verdict.case.name}",
                  file=sys.stderr, flush=True)  # fmt: skip

        verdicts = run_cases(cases, work / "cases", fixtures, env, args.jobs, progress)
    finally:
        if args.keep is None:
            shutil.rmtree(work, ignore_errors=True)
    print(table(verdicts))
    print(f"({time.monotonic() - started:.0f} s)")
    return 0 if all(v.verdict == OK for v in verdicts) else 1


if __name__ == "__main__":  # as the module hostile_cases imports, not as __main__ (one Case class, not two)
    sys.path.insert(0, str(Path(__file__).resolve().parent))
    import hostile_probe

    sys.exit(hostile_probe.main())
