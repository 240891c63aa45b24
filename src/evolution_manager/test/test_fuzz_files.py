"""Files a user hands in, fuzzed (hypothesis): a run's config.json and checkpoint.json given to ``evolve
--resume``, a repertoire given to ``adapt``. Whatever the damage, the command answers with an exit status
(never a traceback), a refusal is one line, and a refused command changes nothing saved."""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from evolution_manager.adaptation.adapt import adapt
from evolution_manager.studies.evolve import evolve

QUIET = ["--no-figures", "--no-progress"]
JSON_VALUES = st.recursive(
    st.none()
    | st.booleans()
    | st.integers(min_value=-(2**70), max_value=2**70)
    | st.floats(allow_nan=False, allow_infinity=False)
    | st.text(max_size=12),
    lambda inner: st.lists(inner, max_size=3) | st.dictionaries(st.text(max_size=6), inner, max_size=3),
    max_leaves=6,
)
# The same examples on every run (derandomize), as every hypothesis test here: a CI run must not fail by
# chance. A wider random search (max_examples=300 without derandomize) found the null tree and null timing
# that these files are now refused for.
FUZZ = settings(
    max_examples=40,
    derandomize=True,
    deadline=None,
    suppress_health_check=[HealthCheck.function_scoped_fixture],
)


@pytest.fixture(scope="module")
def finished_run(tmp_path_factory):
    out = tmp_path_factory.mktemp("fuzz") / "run"
    args = [
        "--algorithm",
        "qd",
        "--objective",
        "food",
        "--evaluations",
        "60",
        "--seed",
        "5",
        "--out",
        str(out),
    ]
    assert evolve([*args, "--checkpoint-every", "0", *QUIET]) == 0
    return out


def _paths(value: object, here: tuple = ()) -> list[tuple]:
    """Every path to a value inside a JSON document (the root excluded)."""
    found = []
    if isinstance(value, dict):
        for key, item in value.items():
            found += [(*here, key), *_paths(item, (*here, key))]
    elif isinstance(value, list):
        for index, item in enumerate(value[:4]):  # a few items of long lists (the archive's bins)
            found += [(*here, index), *_paths(item, (*here, index))]
    return found


@st.composite
def damaged(draw: st.DrawFn, document: object) -> str:
    """``document`` with one value replaced by any JSON value, or removed, as text; or text that is not
    JSON at all."""
    if draw(st.integers(0, 9)) == 0:
        return draw(st.text(max_size=40))
    document = json.loads(json.dumps(document))
    path = draw(st.sampled_from(_paths(document)))
    parent = document
    for key in path[:-1]:
        parent = parent[key]
    if draw(st.booleans()) and isinstance(parent, dict):
        del parent[path[-1]]
    else:
        parent[path[-1]] = draw(JSON_VALUES)
    return json.dumps(document)


def _saved(root: Path) -> dict[str, bytes]:
    return {
        str(p.relative_to(root)): p.read_bytes() for p in root.rglob("*") if p.is_file() and p.name != ".lock"
    }


def _answers_in_one_line(code: int, err: str) -> None:
    assert code in (0, 2), err
    assert "Traceback" not in err
    if code == 2:
        assert len([line for line in err.splitlines() if line.strip()]) == 1, err


@pytest.mark.parametrize("name", ["config.json", "checkpoint.json"])
def test_a_damaged_run_file_is_refused_in_one_line_or_resumed(tmp_path_factory, finished_run, capsys, name):
    original = json.loads((finished_run / name).read_text())

    @FUZZ
    @given(st.data())
    def check(data: st.DataObject) -> None:
        out = tmp_path_factory.mktemp("case") / "run"
        shutil.copytree(finished_run, out)
        (out / name).write_text(data.draw(damaged(original)))
        before = _saved(out)
        capsys.readouterr()
        code = evolve(["--out", str(out), "--resume", *QUIET])
        _answers_in_one_line(code, capsys.readouterr().err)
        if code == 2:
            assert _saved(out) == before
        shutil.rmtree(out.parent)

    check()


def test_a_damaged_repertoire_is_refused_by_adapt_in_one_line(tmp_path_factory, finished_run, capsys):
    original = json.loads((finished_run / "repertoire_food.json").read_text())

    @FUZZ
    @given(st.data())
    def check(data: st.DataObject) -> None:
        root = tmp_path_factory.mktemp("case")
        run = root / "run"
        shutil.copytree(finished_run, run)
        (run / "repertoire_food.json").write_text(data.draw(damaged(original)))
        before = _saved(run)
        capsys.readouterr()
        args = ["--repertoire", str(run), "--objective", "food", "--out", str(root / "adapted")]
        code = adapt([*args, "--condition", "dead-robots=2", "--budget", "1", "--trials", "1"])
        _answers_in_one_line(code, capsys.readouterr().err)
        assert _saved(run) == before
        if code == 2:
            assert not (root / "adapted").exists()
        shutil.rmtree(root)

    check()
