"""One rule for every command's output file (``swarm_ros.safe_paths.check_output``): an output that exists
is refused in one line unless ``--force``; a symbolic link is refused always, and never written through; a
folder is refused (``snapshot --out DIR`` wrote ``DIR.png``); a read-only or full place is one line, not a
traceback (issue 41)."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import pytest
from marker_bags import write_snapshot_markers

from evolution_manager.recording.bags import BagRecorder
from evolution_manager.viewing import animate, snapshot

TREE = ["--tree", "forward", "--seed", "1", "--every", "50"]  # a few frames: seconds


@pytest.fixture(scope="module")
def bag(tmp_path_factory) -> Path:
    """A trial bag as ``snapshot`` reads it: an arena's outline and one robot (the markers topics)."""
    path = tmp_path_factory.mktemp("bag") / "trial.bag"
    with BagRecorder(path) as recorder:
        write_snapshot_markers(recorder)
    return path


def _commands(bag: Path) -> dict[str, tuple]:
    """Each command: its main, its arguments but the output, and the output's suffix."""
    return {
        "animate": (animate.main, TREE, ".gif"),
        "snapshot": (snapshot.main, [str(bag)], ".png"),
    }


@pytest.mark.parametrize("command", ["animate", "snapshot"])
def test_an_output_that_exists_is_refused_unless_forced(bag, tmp_path, capsys, command):
    main, args, suffix = _commands(bag)[command]
    out = tmp_path / f"out{suffix}"
    out.write_bytes(b"mine")
    assert main([*args, "--out", str(out)]) == 2
    error = capsys.readouterr().err.strip()
    assert "\n" not in error and "already exists: add --force" in error, error
    assert out.read_bytes() == b"mine"
    assert main([*args, "--out", str(out), "--force"]) == 0
    assert out.read_bytes() != b"mine" and out.stat().st_size > 100


@pytest.mark.parametrize("command", ["animate", "snapshot"])
@pytest.mark.parametrize("dangling", [False, True])
def test_a_link_as_output_is_refused_even_with_force(bag, tmp_path, capsys, command, dangling):
    main, args, suffix = _commands(bag)[command]
    target = tmp_path / "precious"
    if not dangling:
        target.write_text("keep me\n")
    out = tmp_path / f"out{suffix}"
    out.symlink_to(target)
    for force in ([], ["--force"]):
        assert main([*args, "--out", str(out), *force]) == 2
        error = capsys.readouterr().err.strip()
        assert "\n" not in error and "is a symbolic link" in error, error
    assert (target.read_text() if not dangling else target.exists()) == (
        "keep me\n" if not dangling else False
    )
    assert out.is_symlink()


@pytest.mark.parametrize("command", ["animate", "snapshot"])
def test_a_folder_as_output_is_refused_and_nothing_written_beside_it(bag, tmp_path, capsys, command):
    main, args, _ = _commands(bag)[command]
    folder = tmp_path / "pictures"
    folder.mkdir()
    assert main([*args, "--out", str(folder), "--force"]) == 2
    error = capsys.readouterr().err.strip()
    assert "\n" not in error and "is a folder" in error and "wrote" not in error, error
    assert sorted(p.name for p in tmp_path.iterdir()) == ["pictures"]  # no pictures.png
    assert not any(folder.iterdir())


@pytest.mark.parametrize("command", ["animate", "snapshot"])
def test_a_place_under_a_file_is_named_as_such(bag, tmp_path, capsys, command):
    main, args, suffix = _commands(bag)[command]
    (tmp_path / "file").write_text("")
    assert main([*args, "--out", str(tmp_path / "file" / f"x{suffix}")]) == 2
    error = capsys.readouterr().err.strip()
    assert "\n" not in error and "file is a file, not a folder" in error, error


@pytest.mark.parametrize("command", ["animate", "snapshot"])
@pytest.mark.parametrize("place", ["full", "read-only"])
def test_a_full_or_read_only_place_is_one_line(bag, tmp_path, command, place):
    """A real tmpfs (8 KB, or read-only) in a mount namespace of the test's own."""
    _, args, suffix = _commands(bag)[command]
    disk = tmp_path / "disk"
    disk.mkdir()
    mount = f"mount -t tmpfs -o size=8k tmpfs {disk}"
    if place == "read-only":
        mount += f" && mount -o remount,ro {disk}"
    code = f"import sys; from evolution_manager.viewing.{command} import main; sys.exit(main(sys.argv[1:]))"
    script = f'{mount} || exit 99; exec "$@"'
    out = disk / f"out{suffix}"
    namespace = ["unshare", "--user", "--map-root-user", "--mount", "bash", "-c", script, "-"]
    done = subprocess.run(
        [*namespace, sys.executable, "-c", code, *args, "--out", str(out)],
        capture_output=True,
        text=True,
        timeout=300,
    )
    assert done.returncode == 2, done.stderr
    error = done.stderr.strip()
    assert "\n" not in error and "Traceback" not in error, error
    reason = "No space left on device" if place == "full" else "Read-only file system"
    assert reason in error and str(out) in error, error


def test_a_place_under_a_file_is_named_as_such_by_evolve_trial_and_bags(tmp_path, capsys):
    """It was "File exists" (the EEXIST of making a folder where a file is) or a traceback."""
    from evolution_manager.errors import BagError
    from evolution_manager.graph.nodes import trial
    from evolution_manager.studies.evolve import evolve

    (tmp_path / "file").write_text("")
    run = ["--algorithm", "qd", "--objective", "food", "--evaluations", "10", "--no-progress"]
    for main, argv in (
        (evolve, [*run, "--out", str(tmp_path / "file" / "run")]),
        (evolve, [*run, "--out", str(tmp_path / "file" / "deeper" / "run")]),
        (trial.main, ["--tree", "forward", "--seed", "1", "--bag", str(tmp_path / "file" / "x.bag")]),
    ):
        assert main(argv) == 2
        error = capsys.readouterr().err.strip()
        assert "\n" not in error and "file is a file, not a folder" in error and "File exists" not in error
    with (
        pytest.raises(BagError, match="file is a file, not a folder"),
        BagRecorder(tmp_path / "file" / "b.bag"),
    ):
        pass


def test_measure_json_follows_the_same_rule(tmp_path, capsys):
    """``measure --json`` and ``measure-services --json`` (refused before the graph starts)."""
    from evolution_manager.graph.nodes import measure_services
    from evolution_manager.studies.measure import measure

    out = tmp_path / "m.json"
    out.write_text("mine")
    precious = tmp_path / "precious"
    precious.write_text("keep me\n")
    link = tmp_path / "link.json"
    link.symlink_to(precious)
    quick = ["--evaluations", "1", "--algorithms", "qd"]
    for main, args in ((measure, quick), (measure_services.main, [])):
        for path, force, says in (
            (out, [], "already exists: add --force"),
            (link, ["--force"], "symbolic link"),
        ):
            assert main([*args, "--json", str(path), *force]) == 2
            error = capsys.readouterr().err.strip()
            assert "\n" not in error and says in error, error
    assert out.read_text() == "mine" and precious.read_text() == "keep me\n"
    assert measure([*quick, "--json", str(out), "--force"]) == 0
    assert json.loads(out.read_text())[0]["evaluations"] > 0


def test_a_new_bag_is_never_a_link_not_even_a_dangling_one(tmp_path):
    """``trial --bag`` and ``record --bag`` took a dangling link for a new bag and started their graph."""
    from evolution_manager.errors import BagError
    from evolution_manager.recording.bags import check_new_bag

    (tmp_path / "bag").symlink_to(tmp_path / "made")
    with pytest.raises(BagError, match="is a symbolic link"):
        check_new_bag(tmp_path / "bag")
    (tmp_path / "file").write_text("")
    with pytest.raises(BagError, match="file is a file, not a folder"):
        check_new_bag(tmp_path / "file" / "bag")
    assert not (tmp_path / "made").exists()


def test_a_bag_error_is_one_line_whatever_it_carries():
    """A YAML parser's error (a damaged metadata.yaml) runs over many lines and quotes the file."""
    from evolution_manager.errors import BagError

    error = BagError("not a readable bag (ReaderError: while constructing\n  a mapping\n" + "x" * 1000)
    assert "\n" not in str(error) and str(error).startswith("not a readable bag (ReaderError: while")
    assert len(str(error)) <= BagError.LIMIT and str(error).endswith(" ...")
