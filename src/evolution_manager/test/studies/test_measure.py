"""``measure``: a bad --seed or --objective is refused in one line, exit status 2, before any run."""

from __future__ import annotations

import pytest

from evolution_manager.studies.measure import measure


@pytest.mark.parametrize(
    ("argv", "expected"),
    [
        (["--seed", "-1"], "argument --seed: expected an integer seed in [0, 9223372036854775807], got -1"),
        (["--objective", "-1"], "argument --objective: invalid choice: '-1'"),
    ],
)
def test_a_bad_seed_or_objective_is_one_line_before_any_run(argv, expected, capsys):
    assert measure([*argv, "--evaluations", "1"]) == 2
    captured = capsys.readouterr()
    assert captured.out == ""
    lines = captured.err.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("measure: error: ") and expected in lines[0]
