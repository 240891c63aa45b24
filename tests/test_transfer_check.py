"""The transfer check on a real small run: `validate --transfer` picks the evolved grid's best and trees
spread over the grid from what `evolution_manager evolve` wrote, and without an ARGoS build it stops in one
line."""

from __future__ import annotations

import json
import math
import os
import subprocess

import pytest

from evolution_manager.graph.startup import executable
from swarm_sim.validation import transfer


@pytest.fixture(scope="module")
def small_run(tmp_path_factory):
    out = tmp_path_factory.mktemp("transfer") / "run"
    done = subprocess.run(
        [str(executable("evolution_manager", "evolve")), "--algorithm", "qd", "--objective", "nest",
         "--evaluations", "100", "--seed", "3", "--out", str(out), "--no-progress", "--no-figures"],
        capture_output=True, text=True, timeout=900,
    )  # fmt: skip
    assert done.returncode == 0, done.stderr[-3000:]
    return out


def test_picks_are_the_best_then_spread_over_the_evolved_grid(small_run):
    picks = transfer.pick_trees([small_run], 4)
    assert len(picks) == 5 and {p.objective for p in picks} == {"nest"}  # passive grids are not picked
    document = json.loads((small_run / "repertoire_nest.json").read_text())
    top = max(item["fitness"] for item in document["items"])
    assert picks[0].role == "best" and picks[0].fitness == top
    in_grid = {(tuple(item["bin"]), item["tree"]) for item in document["items"]}
    assert all((p.bin, p.tree) in in_grid for p in picks)
    assert len({p.bin for p in picks}) == 5 and len({p.tree for p in picks}) == 5

    def centre(p):
        return [(b + 0.5) / 8 for b in p.bin]

    # farthest-point sampling: each pick is at least as far from those before it as any later pick is
    gaps = [min(math.dist(centre(p), centre(q)) for q in picks[:k]) for k, p in enumerate(picks) if k]
    assert gaps == sorted(gaps, reverse=True) and gaps[-1] > 0
    # every other filled bin is no farther from the picks than the last pick was
    elites = {tuple(item["bin"]) for item in document["items"]}
    for b in elites:
        assert min(math.dist([(x + 0.5) / 8 for x in b], centre(q)) for q in picks[:-1]) <= gaps[-1] + 1e-12


def test_without_an_argos_build_the_command_stops_in_one_line(small_run, tmp_path):
    env = {k: v for k, v in os.environ.items() if k not in ("ARGOS_PREFIX", "BT_ARGOS_DIR", "SRAND_SHIM")}
    env.update(HOME=str(tmp_path), ARGOS_EVAL=str(tmp_path / "argos_eval.py"))
    done = subprocess.run(
        [str(executable("swarm_sim", "validate")), "--transfer", str(small_run),
         "--out", str(tmp_path / "t.md")],
        capture_output=True, text=True, timeout=300, env=env,
    )  # fmt: skip
    assert done.returncode == 2
    last = done.stderr.strip().splitlines()[-1]
    assert last.startswith("validate: error: ARGoS build not found:") and str(tmp_path) in last
    assert not (tmp_path / "t.md").exists() and not (tmp_path / "t.tsv").exists()
