"""The division-of-labour benchmark on the carriers task (``docs/results/heterogeneity/carriers``): robots in
three groups that each pick up one food kind. The README's tables recomputed from the committed rows (the
means and the paired comparisons with the best homogeneous swarm), and one row recomputed from the model."""

from __future__ import annotations

from pathlib import Path

import pytest

from swarm_sim.bench import division
from swarm_sim.evaluation import BatchEvaluator, SwarmRequest
from swarm_sim.model import OBJECTIVES, SwarmLayout
from swarm_sim.tasks import task_named

FOLDER = Path(__file__).resolve().parent.parent / "docs" / "results" / "heterogeneity" / "carriers"
TASK = "multifood-arena6-carriers"


def _rows(name: str = "runs.csv") -> list[dict[str, str]]:
    return division.read_rows((FOLDER / name).read_text())


@pytest.mark.parametrize(("name", "seeds"), [("runs.csv", 20), ("runs-100seeds.csv", 100)])
def test_the_readme_tables_are_the_rows_tables(name, seeds):
    rows = _rows(name)
    assert list(rows[0]) == list(division.HEADER)
    names = division.swarms(9)
    assert [r["swarm"] for r in rows] == [swarm for swarm in names for _ in range(seeds)]
    assert {r["seed"] for r in rows} == {str(s) for s in range(1, seeds + 1)}
    assert {r["trials"] for r in rows} == {"10"}
    readme = (FOLDER / "README.md").read_text()
    assert division.table(rows) in readme
    assert division.paired_table(rows) in readme


def test_the_100_seeds_begin_with_the_20():
    """The second run's seeds 1-20 are the first run's rows, value for value (a seed is its scenario)."""
    first = _rows()
    assert [r for r in _rows("runs-100seeds.csv") if int(r["seed"]) <= 20] == first


def test_a_row_is_the_models():
    """The strict specialists on seed 1 (10 trials of 300 s, each robot picking up only its group's kind),
    recomputed on the batch road: the committed values exactly."""
    row = next(r for r in _rows() if r["swarm"] == division.SPECIALISTS and r["seed"] == "1")
    config = task_named(TASK).config()
    assert config.carries == (("food",), ("food2",), ("food3",)) and config.ticks == 600
    trees = division.swarms(config.n_robots)[division.SPECIALISTS][1]
    (result,) = BatchEvaluator(config).evaluate([SwarmRequest(SwarmLayout(trees), 1, 10)])
    named = dict(zip(OBJECTIVES, result.fitness, strict=True))
    for column in division.COLUMNS:
        assert float(row[column]) == pytest.approx(named[column], abs=0.0), column
