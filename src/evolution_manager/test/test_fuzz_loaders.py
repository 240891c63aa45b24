"""Every file loader and every command-line parser, fuzzed (hypothesis, derandomized as every test here):
whatever a file or an argument list holds (any JSON or YAML value anywhere, NaN and infinities, a key given
twice, bytes that are not UTF-8, a symbolic link to the file, a dangling link, a folder), the answer is the
loaded value or the loader's own error in one line, never another exception."""

from __future__ import annotations

import argparse
import json
from collections.abc import Callable
from pathlib import Path

import pytest
import yaml
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from bt_controller.language import LibraryError, load_library
from evolution_manager.cluster.settings import ClusterError, parse_cluster
from evolution_manager.errors import UsageError
from swarm_ros.parameters import ParameterError, read_parameter_file
from swarm_sim.model import LayoutError, load_layout
from swarm_sim.tasks import FORAGING, TaskError, read_task_file, task_to_mapping

FUZZ = settings(
    max_examples=60,
    derandomize=True,
    deadline=None,
    suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.too_slow],
)
VALUES = st.recursive(
    st.none()
    | st.booleans()
    | st.integers(min_value=-(2**70), max_value=2**70)
    | st.floats()  # NaN and the infinities too
    | st.text(max_size=10),
    lambda inner: st.lists(inner, max_size=3) | st.dictionaries(st.text(max_size=6), inner, max_size=3),
    max_leaves=5,
)

LIBRARY = {"format": 1, "primitives": [{"name": "gotoNest1", "tree": "sel(in_nest, forward)"}]}
LAYOUT = {"trees": ["forward"] * 9}
CLUSTER = {"cores": 2, "memory": "4GB", "walltime": "01:00:00", "jobs": 2}
PARAMETERS = {"/**": {"ros__parameters": {"wheel_speed": 50.0, "ticks": 40}}}


def _load_library(path: Path) -> object:
    return load_library(path)


def _load_layout(path: Path) -> object:
    return load_layout(path, 9)


def _load_cluster(path: Path) -> object:
    return parse_cluster("slurm", path)


LOADERS: dict[str, tuple[Callable[[Path], object], type[Exception], object, str]] = {
    "library": (_load_library, LibraryError, LIBRARY, "json"),
    "layout": (_load_layout, LayoutError, LAYOUT, "json"),
    "cluster settings": (_load_cluster, ClusterError, CLUSTER, "yaml"),
    "parameter file": (read_parameter_file, ParameterError, PARAMETERS, "yaml"),
    "task file": (read_task_file, TaskError, task_to_mapping(FORAGING), "yaml"),
}


def _paths(value: object, here: tuple = ()) -> list[tuple]:
    found: list[tuple] = []
    if isinstance(value, dict):
        for key, item in value.items():
            found += [(*here, key), *_paths(item, (*here, key))]
    elif isinstance(value, list):
        for index, item in enumerate(value[:3]):
            found += [(*here, index), *_paths(item, (*here, index))]
    return found


@st.composite
def damaged(draw: st.DrawFn, document: object, kind: str) -> bytes:
    """``document`` as its file's bytes, with one value replaced or removed, a key given twice, bytes that
    are not UTF-8, or any text at all."""
    how = draw(st.integers(0, 9))
    if how == 0:
        return draw(st.binary(max_size=60))
    if how == 1:
        return draw(st.text(max_size=60)).encode()
    document = json.loads(json.dumps(document))
    paths = _paths(document)
    path = draw(st.sampled_from(paths)) if paths else ()
    parent = document
    for key in path[:-1]:
        parent = parent[key]
    if path and draw(st.booleans()) and isinstance(parent, dict):
        del parent[path[-1]]
    elif path:
        parent[path[-1]] = draw(VALUES)
    # json.dumps writes NaN and the infinities as JSON's NaN and Infinity, which no JSON loader may take
    text = json.dumps(document) if kind == "json" else yaml.safe_dump(document)
    if how == 2 and isinstance(document, dict) and document:  # the first key given twice
        first = next(iter(document))
        if kind == "json":
            text = text[:-1] + f", {json.dumps(first)}: 1}}"
        else:
            text += f"{first}: 1\n"
    raw = text.encode()
    if how == 3:
        raw = raw + b"\xe9\xff"
    return raw


def _one_line(error: Exception) -> None:
    assert "\n" not in str(error).strip(), str(error)


@pytest.mark.parametrize("name", sorted(LOADERS))
def test_a_damaged_file_is_loaded_or_refused_in_one_line(tmp_path_factory, name):
    load, error_type, document, kind = LOADERS[name]

    @FUZZ
    @given(st.data())
    def check(data: st.DataObject) -> None:
        folder = tmp_path_factory.mktemp("case")
        path = folder / f"file.{kind}"
        path.write_bytes(data.draw(damaged(document, kind)))
        try:
            load(path)
        except error_type as error:
            _one_line(error)

    check()


@pytest.mark.parametrize("name", sorted(LOADERS))
def test_a_link_a_dangling_link_or_a_folder_is_loaded_or_refused_in_one_line(tmp_path, name):
    load, error_type, document, kind = LOADERS[name]
    real = tmp_path / f"real.{kind}"
    real.write_text(json.dumps(document) if kind == "json" else yaml.safe_dump(document))
    linked = tmp_path / f"linked.{kind}"
    linked.symlink_to(real)
    assert type(load(linked)) is type(load(real))  # a file the user points to through a link is read
    dangling = tmp_path / f"dangling.{kind}"
    dangling.symlink_to(tmp_path / "nowhere")
    folder = tmp_path / f"folder.{kind}"
    folder.mkdir()
    for bad in (dangling, folder, tmp_path / f"missing.{kind}"):
        with pytest.raises(error_type) as caught:
            load(bad)
        _one_line(caught.value)


def _parsers() -> dict[str, Callable[[], argparse.ArgumentParser]]:
    from bt_controller.tools.cli import build_parser as bt
    from evolution_manager.adaptation.adapt import build_parser as adapt
    from evolution_manager.adaptation.adapt_benchmark import build_parser as adapt_benchmark
    from evolution_manager.evolution.libraries import build_parser as library
    from evolution_manager.studies.evolve import build_parser as evolve
    from evolution_manager.studies.experiment import build_parser as experiment

    return {
        "evolve": evolve,
        "experiment": experiment,
        "adapt": adapt,
        "adapt-benchmark": adapt_benchmark,
        "library": library,
        "bt": bt,
    }


OPTIONS = ["--algorithm", "--objective", "--evaluations", "--seed", "--task", "--trials", "--out", "--resume",
           "--profile", "--scenarios", "--scenario-seed", "--library", "--cluster", "--cluster-config",
           "--runs", "--design", "--repertoire", "--budget", "--condition", "--from", "--blocks", "show",
           "--format", "--force", "--homogeneous", "--worker-wait"]  # fmt: skip
ARGUMENTS = st.lists(
    st.sampled_from(OPTIONS)
    | st.text(max_size=8)
    | st.sampled_from(["-1", "0", "nan", "inf", "1e400", "qd"]),
    max_size=6,
)


@pytest.mark.parametrize("name", sorted(_parsers()))
def test_any_command_line_is_parsed_or_refused_in_one_line(name, capsys):
    parser = _parsers()[name]()

    @FUZZ
    @given(ARGUMENTS)
    def check(argv: list[str]) -> None:
        capsys.readouterr()
        try:
            parser.parse_args(argv)
        except UsageError as error:  # the package's parser: the command prints it as one line
            _one_line(error)
        except SystemExit as stop:  # a parser of its own, or --help
            err = capsys.readouterr().err
            assert stop.code in (0, 2) and (stop.code == 0 or err.count("\n") <= 1), err

    check()
