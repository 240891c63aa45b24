"""Adding a condition and an objective as ``docs/tasks.md`` says, and seeing both on the batch and reference
roads.

A copy of bt_controller and swarm_sim gets exactly the edits the document lists: a condition is a row of
``CONDITION_TABLE`` and its line in ``perception.blackboard``; an objective is a row of ``OBJECTIVE_TABLE``
and its mapping in ``world.robot_objectives``. The copy runs in a subprocess with a numba cache of its own
(its kernels compile anew: about 45 s of CPU). The batch kernels skip bearings no condition reads, from the
table: a new condition that reads one must still act on the batch road, exactly as on the reference road.
"""

from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

SRC = Path(__file__).resolve().parents[3]
CONDITION_ROW = '    Condition("nest_ahead", ("nest",), "nest", "the nest estimate\'s source is ahead"),\n'
CONDITION_LINE = "    out[N_CONDITIONS - 1] = 0.0 < raw[0] < cap and abs(bearings[0]) < 0.5\n"
OBJECTIVE_ROW = (
    '    Objective("near_nest", "smoothed nest estimate, last step", "1 - final / cap", 1.0, ""),\n'
)


def _edit(path: Path, anchor: str, addition: str) -> None:
    """Insert ``addition`` after the one occurrence of ``anchor`` in ``path``."""
    text = path.read_text()
    assert text.count(anchor) == 1, f"{path.name}: the anchor {anchor!r} is not there once"
    path.write_text(text.replace(anchor, anchor + addition))


@pytest.fixture(scope="module")
def extended(tmp_path_factory: pytest.TempPathFactory) -> dict[str, str]:
    """The environment of a copy of the two packages with the new condition and objective."""
    root = tmp_path_factory.mktemp("extended")
    for package in ("bt_controller", "swarm_sim"):
        shutil.copytree(
            SRC / package / package, root / package, ignore=shutil.ignore_patterns("__pycache__", "*.nb[ic]")
        )
    vocabulary = root / "bt_controller" / "language" / "vocabulary.py"
    text = vocabulary.read_text()
    end = text.index(')\n"""Every condition')  # the table's end
    vocabulary.write_text(text[:end] + CONDITION_ROW + text[end:])
    _edit(
        root / "bt_controller" / "robot" / "perception.py",
        "            out[at] = out[at + 1] = out[at + 2] = out[at + 3] = False\n",  # blackboard's last line
        CONDITION_LINE,
    )
    objectives = root / "swarm_sim" / "model" / "objectives.py"
    text = objectives.read_text()
    end = text.index(')\n"""Every objective')
    objectives.write_text(text[:end] + OBJECTIVE_ROW + text[end:])
    world = root / "swarm_sim" / "core" / "world.py"
    old = "    return (\n        density, nest, food, idensity, inest, ifood, total, aggregation,\n"
    new = f"    near_nest = 1.0 - final[0] / p.estimate_cap\n{old}"
    tail = "        kind1, kind2, kind3, biased, balanced,\n"
    assert world.read_text().count(old + tail) == 1
    world.write_text(world.read_text().replace(old + tail, new + tail + "        near_nest,\n"))
    env = dict(os.environ, PYTHONSAFEPATH="1")  # the copy, never the sources beside the working directory
    env["PYTHONPATH"] = os.pathsep.join([str(root), env.get("PYTHONPATH", "")])
    env["NUMBA_CACHE_DIR"] = str(root / "numba-cache")
    return env


def _evaluate(env: dict[str, str], tree: str, engine: str) -> dict:
    done = subprocess.run(
        [
            sys.executable,
            "-m",
            "swarm_sim.evaluation.cli",
            "--tree",
            tree,
            "--seed",
            "3",
            "--trials",
            "2",
            "--engine",
            engine,
        ],
        capture_output=True,
        text=True,
        env=env,
        check=False,
        timeout=900,
    )
    assert done.returncode == 0, done.stderr
    return json.loads(done.stdout)


def test_a_new_condition_and_objective_act_alike_on_the_batch_and_reference_roads(extended):
    tree = "sel(seq(nest_ahead, stop), forward)"
    batch = _evaluate(extended, tree, "compiled")
    reference = _evaluate(extended, tree, "reference")
    assert batch["fitness"] == reference["fitness"]
    assert batch["descriptors"] == reference["descriptors"]
    assert "near_nest" in batch["fitness"]
    assert 0.0 <= batch["fitness"]["near_nest"] <= 1.0
    # the condition holds at some tick on the batch road: the swarm stops there, so it moves less than one
    # that never stops
    without = _evaluate(extended, "forward", "compiled")
    assert batch["descriptors"]["movement"] < without["descriptors"]["movement"]


def test_the_copy_is_what_the_document_says_and_the_installed_packages_are_untouched(extended):
    from bt_controller.language import CONDITIONS
    from swarm_sim.model import OBJECTIVES

    assert "nest_ahead" not in CONDITIONS and "near_nest" not in OBJECTIVES
    copy = Path(extended["PYTHONPATH"].split(os.pathsep)[0])
    assert CONDITION_ROW in (copy / "bt_controller" / "language" / "vocabulary.py").read_text()
    assert OBJECTIVE_ROW in (copy / "swarm_sim" / "model" / "objectives.py").read_text()
