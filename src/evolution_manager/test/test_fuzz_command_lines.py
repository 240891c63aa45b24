"""The graph commands' command lines, fuzzed (hypothesis, derandomized as every test here): ``trial``,
``replay``, ``recover``, ``record``, ``snapshot``, ``explorer`` and ``animate``.

Each case is a command line that would run (it reaches the point where the command starts its ROS graph,
simulates, or writes its output) with one thing made hostile: an unknown option, a missing value, text that
is not UTF-8 (the surrogates Python gives for such bytes), NaN, an infinity, a negative or zero count, a
path that is a symbolic link, a dangling link, a folder, a place under a file, a file that is missing, not
UTF-8, truncated, with a key given twice or NaN inside. The command must refuse it at the parsing and
checking stage: exit status 2, exactly one line on standard error naming the problem, no traceback, nothing
written. No case starts a graph: the place where each command would start one (or simulate, or write) is
replaced by a guard that fails the case if it is reached.

The streams are those of a real run: standard output strict UTF-8, standard error with backslashes for
what cannot be encoded (Python's defaults), so a command that prints an undecodable name to standard output
fails here as it would there.
"""

from __future__ import annotations

import io
import json
import os
import re
import shutil
import sys
import tempfile
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from dataclasses import dataclass
from pathlib import Path

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from marker_bags import write_snapshot_markers
from rclpy.serialization import serialize_message

from evolution_manager.graph.nodes import recorder, replay, trial
from evolution_manager.recording.bags import BagRecorder
from evolution_manager.viewing import animate, explorer, snapshot
from swarm_msgs.msg import RobotPose, SwarmState, TrialStart
from swarm_sim.model import DEFAULT

FUZZ = settings(
    max_examples=40,
    derandomize=True,
    deadline=None,
    suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.too_slow],
)
SOURCE = {
    "run": "elsewhere",
    "objective": "food",
    "blocks": 1,
    "block": [0, 0, 0],
    "bin": [3, 4, 2],
    "fitness": 0.5,
}
LIBRARY = {
    "format": 1,
    "primitives": [{"name": "gotoFood1", "tree": "sel(on_food, forward)", "source": SOURCE}],
}
NOT_UTF8 = "\udcff\udcfe"  # the bytes ff fe on a command line, as Python decodes them (surrogateescape)


class Started(BaseException):
    """Raised by a guard: the command got past its checks to where it would start a graph, simulate, or
    write its output. A BaseException, so that no ``except Exception`` of the command takes it."""


def _guard(*_: object, **__: object) -> None:
    raise Started


# --- the world a case runs in --------------------------------------------------------------------------


@pytest.fixture(scope="module")
def shared(tmp_path_factory) -> Path:
    """What every case reads and none may change: a trial bag of markers, a small finished run, a library
    of the library command's form, a swarm layout, a ROS parameter file and a saved file."""
    from evolution_manager.studies.evolve import evolve

    root = tmp_path_factory.mktemp("shared")
    start = TrialStart(seed=1, trial=0, robots=9, ticks=DEFAULT.ticks, world=json.dumps(DEFAULT.as_dict()))
    poses = [RobotPose(x=0.1 * k, y=0.0, theta=0.0) for k in range(9)]
    with BagRecorder(root / "trial.bag") as bag:
        write_snapshot_markers(bag)
        bag.write_cdr("/trial_start", "swarm_msgs/msg/TrialStart", 1, serialize_message(start))
        for step in (0, 1):
            state = SwarmState(seed=1, trial=0, step=step, poses=poses)
            bag.write_cdr("/swarm_state", "swarm_msgs/msg/SwarmState", 2 + step, serialize_message(state))
    options = ["--algorithm", "qd", "--objective", "food", "--evaluations", "2", "--seed", "1"]
    quiet = ["--no-figures", "--no-progress", "--checkpoint-every", "0"]
    assert evolve([*options, "--out", str(root / "run"), *quiet]) == 0
    (root / "run" / ".lock").unlink()  # a finished run, as shared: no lock left
    (root / "library.json").write_text(json.dumps(LIBRARY))
    (root / "swarm.json").write_text(json.dumps({"trees": ["forward"] * 9}))
    (root / "params.yaml").write_text("/**:\n  ros__parameters:\n    answer_timeout: 30.0\n")
    (root / "precious.txt").write_text("keep me\n")
    return root


def _state(folder: Path) -> dict[str, object]:
    """Every entry under ``folder``: a link's target, a file's bytes, or None for a folder."""
    state: dict[str, object] = {}
    for path in sorted(folder.rglob("*")):
        name = str(path.relative_to(folder))
        if path.is_symlink():
            state[name] = ("link", os.readlink(path))
        elif path.is_file():
            state[name] = path.read_bytes()
        else:
            state[name] = None
    return state


class Place:
    """One case's own folder, with the hostile things a case plants in it."""

    def __init__(self, shared: Path, folder: Path) -> None:
        self.shared = shared
        self.folder = folder
        self.count = 0

    def name(self, suffix: str = "") -> Path:
        self.count += 1
        return self.folder / f"p{self.count}{suffix}"

    def file(self, data: bytes, suffix: str = "") -> str:
        path = self.name(suffix)
        path.write_bytes(data)
        return str(path)

    def link(self, target: Path, suffix: str = "") -> str:
        path = self.name(suffix)
        path.symlink_to(target)
        return str(path)

    def folder_(self, suffix: str = "") -> str:
        path = self.name(suffix)
        path.mkdir()
        return str(path)

    def under_a_file(self, suffix: str = "") -> str:
        return str(Path(self.file(b"a file\n")) / f"x{suffix}")

    def copy(self, name: str) -> Path:
        path = self.name()
        source = self.shared / name
        if source.is_dir():
            shutil.copytree(source, path, symlinks=True)
        else:
            shutil.copyfile(source, path)
        return path


# --- hostile values by kind -----------------------------------------------------------------------------

Hostile = Callable[[Place], str]


def _text(values: list[str]) -> list[Hostile]:
    return [lambda _, v=v: v for v in values]


def _paths_that_are_not_files(suffix: str) -> list[Hostile]:
    """A path that is not a readable file of its kind: missing, a folder, a dangling link, under a file."""
    return [
        lambda p: str(p.name(suffix)),
        lambda p: p.folder_(suffix),
        lambda p: p.link(p.folder / "nowhere", suffix),
        lambda p: p.under_a_file(suffix),
    ]


def _damaged_json(document: object, text_value: str, number: str | None = None) -> list[Hostile]:
    """``document``'s file damaged: empty, truncated, not UTF-8, a key twice, NaN for the string
    ``text_value``, Infinity for the number ``number``, a number beyond a float, the user's own file, and
    paths that are not files."""
    text = json.dumps(document)
    first = next(iter(document)) if isinstance(document, dict) else "x"
    infinite = (
        text.replace(number, "Infinity", 1) if number else text.replace(json.dumps(text_value), "1e400")
    )
    return [
        lambda p: p.file(b"", ".json"),
        lambda p: p.file(text.encode()[: len(text) // 2], ".json"),  # truncated
        lambda p: p.file(text.encode() + b"\xff\xfe", ".json"),  # not UTF-8
        lambda p: p.file((text[:-1] + f", {json.dumps(first)}: 1}}").encode(), ".json"),  # a key twice
        lambda p: p.file(text.replace(json.dumps(text_value), "NaN", 1).encode(), ".json"),
        lambda p: p.file(infinite.encode(), ".json"),
        lambda p: p.file(b"[1e400]", ".json"),
        lambda p: p.link(p.shared / "precious.txt", ".json"),  # the user's own file, not a library
        *_paths_that_are_not_files(".json"),
    ]


def _damaged_yaml(text: str, number: str) -> list[Hostile]:
    """``text``'s file damaged: truncated, not UTF-8, its first key twice, NaN and -infinity for ``number``,
    not a mapping, the user's own file, and paths that are not files."""
    first = text.split("\n", 1)[0]
    assert number in text
    return [
        lambda p: p.file(text.encode()[: len(text) // 2], ".yaml"),
        lambda p: p.file(text.encode() + b"\xff\xfe\n", ".yaml"),
        lambda p: p.file((text + first + "\n").encode(), ".yaml"),  # the first key twice
        lambda p: p.file(text.replace(number, ".nan").encode(), ".yaml"),
        lambda p: p.file(text.replace(number, "-.inf").encode(), ".yaml"),
        lambda p: p.file(b"- a list\n", ".yaml"),
        lambda p: p.link(p.shared / "precious.txt", ".yaml"),
        *_paths_that_are_not_files(".yaml"),
    ]


def _damaged_bags() -> list[Hostile]:
    def metadata(data: Callable[[bytes], bytes]) -> Hostile:
        def make(p: Place) -> str:
            bag = p.copy("trial.bag")
            path = bag / "metadata.yaml"
            path.write_bytes(data(path.read_bytes()))
            return str(bag)

        return make

    def mcap(data: Callable[[bytes], bytes]) -> Hostile:
        def make(p: Place) -> str:
            bag = p.copy("trial.bag")
            (path,) = bag.glob("*.mcap")
            path.write_bytes(data(path.read_bytes()))
            return str(bag)

        return make

    return [
        metadata(lambda b: b[: len(b) // 2]),
        metadata(lambda b: b + b"\xff\xfe\n"),
        metadata(
            lambda b: b.replace(b"rosbag2_bagfile_information:", b"rosbag2_bagfile_information: 1\nx:", 1)
        ),
        metadata(lambda b: b + b"rosbag2_bagfile_information: {}\n"),  # the key twice
        metadata(lambda b: re.sub(rb"[a-z_]+/msg/[A-Za-z]+", b"os/msg/System", b)),  # a type to import
        mcap(lambda b: b[: len(b) // 2]),
        mcap(lambda b: b[:100] + bytes([b[100] ^ 0xFF]) + b[101:]),  # a flipped byte
        lambda p: p.folder_(),  # no metadata.yaml
        lambda p: p.link(p.shared / "precious.txt"),
        lambda p: str(p.name()),
        lambda p: p.under_a_file(),
        lambda p: p.file(b"not a bag\n"),
    ]


def _new_paths(suffix: str, exists_is_hostile: bool = True) -> list[Hostile]:
    """An output that must not be written: a link (to a saved file, dangling, to a folder), a folder, a
    place under a file, and (without --force) a file that exists."""
    hostile = [
        lambda p: p.link(p.shared / "precious.txt", suffix),
        lambda p: p.link(p.folder / "nowhere", suffix),
        lambda p: p.link(p.folder, suffix),
        lambda p: p.folder_(suffix),
        lambda p: p.under_a_file(suffix),
        lambda p: p.under_a_file("") + "/deeper" + suffix,
    ]
    if exists_is_hostile:
        hostile.append(lambda p: p.file(b"saved\n", suffix))
    return hostile


def _new_folders() -> list[Hostile]:
    """A folder to write in that is a link (to a saved file, dangling, a folder), a file, under a file."""
    return [
        lambda p: p.link(p.shared / "precious.txt"),
        lambda p: p.link(p.folder / "nowhere"),
        lambda p: p.link(p.shared),
        lambda p: p.file(b"saved\n"),
        lambda p: p.under_a_file(),
    ]


COUNTS = _text(["0", "-1", "-3", "nan", "inf", "1.5", "", "x", "1e400", NOT_UTF8])
HUGE = _text(["9" * 40])
INDICES = _text(["-1", "nan", "inf", "x", "", "1.5", NOT_UTF8])
SEEDS = _text(["-1", str(2**64), "nan", "1.5", "x", "", NOT_UTF8])
SECONDS = _text(["nan", "inf", "-inf", "-1", "x", "", "1e400", NOT_UTF8])
NAMES = _text(["bad name", "/1x", "/a//b", "a b/c", NOT_UTF8, "/a\nb"])
TREES = [
    *_text(["sel(", "", "flying", "sel(forward", "forward)", NOT_UTF8, "sel(forward, " * 3000]),
    lambda p: p.file(b"sel(forward, \xff\xfe)\n"),
]


@dataclass(frozen=True)
class Slot:
    """An option of a command line (``""``: a positional), its valid value (``{shared}`` for the shared
    folder, ``{new}`` for a new path in the case's folder) and the hostile values that must be refused."""

    option: str
    value: str
    hostile: tuple[Hostile, ...]


@dataclass(frozen=True)
class Command:
    main: Callable[[list[str]], int]
    slots: tuple[Slot, ...]
    flags: tuple[str, ...]  # valid flags the line ends with
    guards: tuple[tuple[object, str], ...]  # (module, attribute) replaced by a guard


def _commands() -> dict[str, Command]:
    source = {"run": "elsewhere", "objective": "food", "blocks": 1, "block": [0, 0, 0], "bin": [3, 4, 2]}
    primitive = {"name": "gotoFood1", "tree": "sel(on_food, forward)", "source": {**source, "fitness": 0.5}}
    library_json = {"format": 1, "primitives": [primitive]}
    swarm_json = {"trees": ["forward"] * 9}
    params = "/**:\n  ros__parameters:\n    answer_timeout: 30.0\n"
    task = "name: mine\ntrials:\n  ticks: 40\n"
    bag = Slot("", "{shared}/trial.bag", tuple(_damaged_bags()))
    library = _damaged_json(library_json, "sel(on_food, forward)", "0.5")
    tasks = [*_text(["nope", NOT_UTF8]), *_damaged_yaml(task, "40")]
    return {
        "trial": Command(
            trial.main,
            (
                Slot("--tree", "sel(seq(in_nest, stop), forward)", tuple(TREES)),
                Slot("--seed", "1", tuple(SEEDS)),
                Slot("--trial", "0", tuple(INDICES)),
                Slot("--bag", "{new}/trial.bag", tuple(_new_paths(".bag"))),
                Slot("--timeout", "60", tuple(SECONDS + _text(["0"]))),
                Slot("--domain", "7", tuple(_text(["-1", "233", "nan", "x", NOT_UTF8]))),
                Slot("--namespace", "/swarm_a", tuple(NAMES)),
                Slot("--clock", "/swarm_a/clock", tuple([*NAMES, *_text(["", "/"])])),
                Slot("--params-file", "{shared}/params.yaml", tuple(_damaged_yaml(params, "30.0"))),
                Slot("--library", "{shared}/library.json", tuple(library)),
                Slot("--logs", "{new}/logs", tuple(_new_folders())),
                Slot("--profile", "paper", tuple(_text(["nope", "", NOT_UTF8]))),
                Slot("--task", "primitives", tuple(tasks)),
            ),
            (),
            ((trial, "run_recorded_trial"),),
        ),
        "replay": Command(
            replay.main,
            (
                bag,
                Slot("--rate", "0", tuple(SECONDS)),
                Slot("--delay", "0", tuple(SECONDS)),
                Slot("--wait-for", "/swarm_state", tuple(_text(["/nothing", "", NOT_UTF8]))),
                Slot("--wait-timeout", "0", tuple(SECONDS)),
            ),
            (),
            ((replay.rclpy, "init"),),
        ),
        "recover": Command(
            replay.recover_main,
            (
                Slot("", "{shared}/trial.bag", tuple(_damaged_bags()[-5:])),  # the rest it recovers
                Slot("", "{new}/new.bag", tuple(_new_paths(".bag"))),
            ),
            (),
            (),  # files only, and fast: it runs
        ),
        "record": Command(
            recorder.main,
            (
                Slot("--bag", "{new}/record.bag", tuple(_new_paths(".bag"))),
                Slot("--robots", "9", tuple(COUNTS + HUGE)),
                Slot("--namespace", "/swarm_a", tuple(NAMES)),
                Slot("--clock", "/clock", tuple([*NAMES, *_text(["", "/"])])),
            ),
            (),
            ((recorder.rclpy, "init"),),
        ),
        "snapshot": Command(
            snapshot.main,
            (
                bag,
                Slot("--step", "0", tuple(_text(["nan", "1.5", "x", "", "99", "-99", NOT_UTF8]))),
                Slot("--out", "{new}/step.png", tuple([*_new_paths(".png"), *_text(["{new}/a.xyz"])])),
            ),
            (),
            ((snapshot, "draw"),),
        ),
        "explorer": Command(
            explorer.main,
            (
                Slot("", "{shared}/run", tuple(_damaged_runs())),
                Slot("--library", "{shared}/library.json", tuple(library)),
            ),
            ("--no-animations",),
            ((explorer, "write_atomic"),),
        ),
        "animate": Command(
            animate.main,
            (
                Slot("--tree", "sel(seq(in_nest, stop), forward)", tuple(TREES)),
                Slot("--seed", "1", tuple(SEEDS)),
                Slot("--trial", "0", tuple(INDICES)),
                Slot("--out", "{new}/trial.gif", tuple([*_new_paths(".gif"), *_text(["{new}/a.xyz"])])),
                Slot("--fps", "16", tuple(COUNTS + HUGE)),
                Slot("--every", "4", tuple(COUNTS)),
                Slot("--profile", "paper", tuple(_text(["nope", "", NOT_UTF8]))),
            ),
            (),
            ((animate, "frames_from_tree"), (animate, "write_animation")),
        ),
        "animate --swarm": Command(
            animate.main,
            (
                Slot("--swarm", "{shared}/swarm.json", tuple(_damaged_json(swarm_json, "forward"))),
                Slot("--seed", "1", tuple(SEEDS)),
                Slot("--library", "{shared}/library.json", tuple(library)),
                Slot("--task", "foraging", tuple(tasks)),
                Slot("--out", "{new}/swarm.gif", tuple(_new_paths(".gif"))),
            ),
            (),
            ((animate, "frames_from_tree"), (animate, "write_animation")),
        ),
        "animate --bag": Command(
            animate.main,
            (
                Slot("--bag", bag.value, bag.hostile),
                Slot("--out", "{new}/bag.gif", tuple(_new_paths(".gif"))),
            ),
            (),
            ((animate, "write_animation"),),
        ),
    }


def _damaged_runs() -> list[Hostile]:
    def damaged(name: str, data: Callable[[bytes], bytes]) -> Hostile:
        def make(p: Place) -> str:
            run = p.copy("run")
            path = run / name
            path.write_bytes(data(path.read_bytes()))
            return str(run)

        return make

    def planted(name: str) -> Hostile:
        def make(p: Place) -> str:
            run = p.copy("run")
            (run / name).unlink(missing_ok=True)
            (run / name).symlink_to(p.shared / "precious.txt")
            return str(run)

        return make

    return [
        damaged("repertoire_food.json", lambda b: b[: len(b) // 2]),
        damaged("repertoire_food.json", lambda b: b + b"\xff"),
        damaged("repertoire_food.json", lambda b: b.replace(b'"fitness": ', b'"fitness": NaN, "x": ', 1)),
        damaged("repertoire_food.json", lambda b: b[:-1] + b', "objective": "food"}'),
        damaged("repertoire_food.json", lambda b: b.replace(b"(", b"((", 1)),  # a tree that does not parse
        damaged("config.json", lambda b: b + b"\xff"),
        planted("explorer.html"),
        lambda p: p.folder_(),
        lambda p: p.link(p.shared / "precious.txt"),
        lambda p: str(p.name()),
        lambda p: p.under_a_file(),
    ]


# --- running a case ---------------------------------------------------------------------------------------


@contextmanager
def _real_streams() -> Iterator[tuple[io.BytesIO, io.BytesIO]]:
    out, err = io.BytesIO(), io.BytesIO()
    saved = sys.stdout, sys.stderr
    sys.stdout = io.TextIOWrapper(out, encoding="utf-8", errors="strict", write_through=True)
    sys.stderr = io.TextIOWrapper(err, encoding="utf-8", errors="backslashreplace", write_through=True)
    try:
        yield out, err
    finally:
        for stream in (sys.stdout, sys.stderr):
            stream.flush()
            stream.detach()  # the bytes stay readable
        sys.stdout, sys.stderr = saved


def _run(command: Command, argv: list[str]) -> tuple[int | str | None, str]:
    """The exit status of ``command`` on ``argv`` ("started" when a guard was reached) and its stderr."""
    with _real_streams() as (_, err):
        try:
            status: int | str | None = command.main(argv)
        except SystemExit as stop:
            status = stop.code
        except Started:
            status = "started"
    return status, err.getvalue().decode()


@pytest.fixture
def guarded(monkeypatch):
    for command in _commands().values():
        for module, attribute in command.guards:
            monkeypatch.setattr(module, attribute, _guard)


def _argv(command: Command, place: Place, values: dict[int, str]) -> list[str]:
    argv: list[str] = []
    for index, slot in enumerate(command.slots):
        value = values.get(index, slot.value.format(shared=place.shared, new=place.folder))
        argv += [slot.option, value] if slot.option else [value]
    return [*argv, *command.flags]


def _check_refused(name: str, argv: list[str], status: int | str | None, err: str) -> None:
    program = name.split()[0]
    assert status == 2, (argv, status, err)
    assert err.count("\n") == 1 and err.endswith("\n"), (argv, err)
    assert err.startswith(f"{program}: "), (argv, err)
    assert "Traceback" not in err, (argv, err)


@pytest.mark.parametrize("name", sorted(_commands()))
def test_a_whole_command_line_gets_past_the_checks(name, shared, guarded, tmp_path):
    """The base of every case: the command line with every slot valid reaches the guard (a case's refusal
    is then the hostile value's doing), and writes nothing before it."""
    command = _commands()[name]
    place = Place(shared, tmp_path)
    before = _state(shared)
    status, err = _run(command, _argv(command, place, {}))
    assert status == "started" or (name == "recover" and status == 0), (status, err)
    assert _state(shared) == before


@pytest.mark.parametrize("name", sorted(_commands()))
def test_a_hostile_value_is_refused_in_one_line_before_anything_starts(name, shared, guarded, tmp_path):
    command = _commands()[name]
    cases = [(index, hostile) for index, slot in enumerate(command.slots) for hostile in slot.hostile]
    before_shared = _state(shared)

    seen: set[int] = set()

    @settings(FUZZ, max_examples=4 * len(cases))  # the cases are few: every one is drawn
    @given(st.sampled_from(range(len(cases))))
    def check(case: int) -> None:
        seen.add(case)
        index, hostile = cases[case]
        place = Place(shared, Path(tempfile.mkdtemp(dir=tmp_path)))
        value = hostile(place).format(new=place.folder)
        argv = _argv(command, place, {index: value})
        before = _state(place.folder)
        status, err = _run(command, argv)
        _check_refused(name, argv, status, err)
        assert _state(place.folder) == before, (argv, err)  # nothing written, nothing planted followed
        assert _state(shared) == before_shared, (argv, err)

    check()
    assert len(seen) == len(cases)


@pytest.mark.parametrize("name", sorted(_commands()))
def test_an_unknown_option_or_a_missing_value_is_one_line(name, shared, guarded, tmp_path):
    command = _commands()[name]
    place = Place(shared, tmp_path)
    whole = _argv(command, place, {})
    options = [k for k, token in enumerate(whole) if token.startswith("--") and token not in command.flags]

    @FUZZ
    @given(st.data())
    def check(data: st.DataObject) -> None:
        if options and data.draw(st.booleans()):  # the line cut after an option that takes a value
            argv = whole[: data.draw(st.sampled_from(options)) + 1]
        else:
            unknown = data.draw(st.sampled_from(["--no-such-option", "--" + NOT_UTF8, "-x", "-"]))
            argv = list(whole)
            argv.insert(data.draw(st.integers(0, len(argv))), unknown)
        status, err = _run(command, argv)
        _check_refused(name, argv, status, err)
        assert not any(place.folder.iterdir()), argv

    check()


TOKENS = st.lists(
    st.sampled_from(["--tree", "--seed", "--trial", "--bag", "--out", "--rate", "--delay", "--verify",
                     "--robots", "--step", "--force", "--library", "--swarm", "--every", "--fps", "--logs",
                     "--namespace", "--clock", "--timeout", "--domain", "--no-animations", "forward"])
    | st.sampled_from(["-1", "0", "nan", "inf", "1e400", NOT_UTF8, "", "-"])
    | st.text(max_size=6),
    max_size=7,
)  # fmt: skip


@pytest.mark.parametrize("name", sorted(_commands()))
def test_any_command_line_is_refused_in_one_line_or_gets_past_the_checks(name, shared, guarded, tmp_path):
    """Random lines (relative paths land in the case's folder): never a traceback; a refusal is one line
    with status 2 and leaves nothing behind."""
    command = _commands()[name]
    cwd = os.getcwd()

    @FUZZ
    @given(TOKENS)
    def check(argv: list[str]) -> None:
        folder = Path(tempfile.mkdtemp(dir=tmp_path))
        os.chdir(folder)
        try:
            status, err = _run(command, argv)
        finally:
            os.chdir(cwd)
        if status in ("started", 0) and "Traceback" not in err:
            return  # a valid line (--help, or a recover of a bag it was given)
        _check_refused(name, argv, status, err)
        assert not any(folder.iterdir()), (argv, err)

    check()
