"""``bench``'s options: a value out of range is refused in one line naming the option, its range and the
value, before any work; ``--reference-trees 0`` times the batch road alone."""

from __future__ import annotations

import pytest

from bt_controller.draws import MAX_SEED
from swarm_sim.bench import batch
from swarm_sim.evaluation import most_threads


@pytest.mark.parametrize(
    ("argv", "expected"),
    [
        (["--trees", "0"], "--trees must be a positive integer, got 0"),
        (["--reference-trees", "-1"], "--reference-trees must be a non-negative integer, got -1"),
        (["--trials", "0"], "--trials must be an integer in [1, 10000], got 0"),
        (["--seed", "-1"], f"--seed must be an integer in [0, {MAX_SEED - 200}], got -1"),
        (["--parity", "-1"], "--parity must be a non-negative integer, got -1"),
        (["--threads", "0"], f"--threads must be an integer in [1, {most_threads()}], got 0"),
    ],
)
def test_an_option_out_of_range_is_one_line_and_exit_status_2(argv, expected, capsys):
    with pytest.raises(SystemExit) as stop:
        batch.main(argv)
    assert stop.value.code == 2
    captured = capsys.readouterr()
    assert captured.out == "" and captured.err.strip().splitlines()[-1] == f"bench: error: {expected}"


def test_with_no_reference_trees_bench_times_the_batch_road_alone(capsys):
    assert batch.main(["--trees", "2", "--trials", "1", "--reference-trees", "0"]) == 0
    out = capsys.readouterr().out
    assert "batch:" in out and "reference:" not in out and "ratio:" not in out
