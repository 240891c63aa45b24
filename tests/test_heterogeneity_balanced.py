"""The division-of-labour benchmark on the balanced task (``docs/results/heterogeneity/balanced``): the
README's table recomputed from the committed rows, and one row recomputed from the model."""

from __future__ import annotations

from pathlib import Path

import pytest

from swarm_sim.bench import division
from swarm_sim.evaluation import BatchEvaluator, SwarmRequest
from swarm_sim.model import OBJECTIVES, SwarmLayout
from swarm_sim.tasks import task_named

FOLDER = Path(__file__).resolve().parent.parent / "docs" / "results" / "heterogeneity" / "balanced"


def _rows(name: str = "runs.csv") -> list[dict[str, str]]:
    return division.read_rows((FOLDER / name).read_text())


@pytest.mark.parametrize("name", ["runs.csv", "runs-300s.csv"])
def test_the_readme_tables_are_the_rows_tables(name):
    rows = _rows(name)
    assert list(rows[0]) == list(division.HEADER)
    names = division.swarms(9)
    assert [r["swarm"] for r in rows] == [swarm for swarm in names for _ in range(20)]
    assert {r["seed"] for r in rows} == {str(s) for s in range(1, 21)}
    assert {r["trials"] for r in rows} == {"10"}
    assert division.table(rows) in (FOLDER / "README.md").read_text()


def test_a_row_is_the_models():
    """The specialists on seed 1 (10 trials), recomputed on the batch road: the committed values exactly."""
    row = next(r for r in _rows() if r["swarm"] == division.SPECIALISTS and r["seed"] == "1")
    config = task_named(division.TASK).config()
    trees = division.swarms(config.n_robots)[division.SPECIALISTS][1]
    (result,) = BatchEvaluator(config).evaluate([SwarmRequest(SwarmLayout(trees), 1, 10)])
    named = dict(zip(OBJECTIVES, result.fitness, strict=True))
    for column in division.COLUMNS:
        assert float(row[column]) == pytest.approx(named[column], abs=0.0), column


def test_the_estimate_shares_are_the_recordings():
    """The README's shares of robot-steps with a food estimate, recomputed from recordings of the trials."""
    readme = (FOLDER / "README.md").read_text()
    for line in division.estimates_lines(division.TASK).splitlines():
        assert f"  {line}\n" in readme, line
