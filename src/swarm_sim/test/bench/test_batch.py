"""The benchmarks' options (``bench``, ``record-bench``, ``division-bench``): a value out of range is refused
in one line naming the option, its range and the value, before any work; ``bench --reference-trees 0``
times the batch road alone."""

from __future__ import annotations

import pytest

from bt_controller.draws import MAX_SEED
from swarm_sim.bench import batch, division, recording
from swarm_sim.evaluation import most_threads

PROGS = {batch.main: "bench", recording.main: "record-bench", division.main: "division-bench"}


@pytest.mark.parametrize(
    ("main", "argv", "expected"),
    [
        (batch.main, ["--trees", "0"], "--trees must be a positive integer, got 0"),
        (batch.main, ["--reference-trees", "-1"], "--reference-trees must be a non-negative integer, got -1"),
        (batch.main, ["--trials", "0"], "--trials must be an integer in [1, 10000], got 0"),
        (batch.main, ["--seed", "-1"], f"--seed must be an integer in [0, {MAX_SEED - 200}], got -1"),
        (batch.main, ["--parity", "-1"], "--parity must be a non-negative integer, got -1"),
        (batch.main, ["--threads", "0"], f"--threads must be an integer in [1, {most_threads()}], got 0"),
        (recording.main, ["--trees", "0"], "--trees must be a positive integer, got 0"),
        (
            recording.main,
            ["--reference-trees", "-2"],
            "--reference-trees must be a non-negative integer, got -2",
        ),
        (recording.main, ["--trial", "10000"], "--trial must be an integer in [0, 9999], got 10000"),
        (
            recording.main,
            ["--seed", str(MAX_SEED)],
            f"--seed must be an integer in [0, {MAX_SEED - 300}], got {MAX_SEED}",
        ),
        (division.main, ["--seeds", "1"], "--seeds must be an integer of at least 2, got 1"),
        (division.main, ["--trials", "0"], "--trials must be an integer in [1, 10000], got 0"),
        (
            division.main,
            ["--threads", "99999"],
            f"--threads must be an integer in [1, {most_threads()}], got 99999",
        ),
    ],
)
def test_an_option_out_of_range_is_one_line_and_exit_status_2(main, argv, expected, capsys):
    with pytest.raises(SystemExit) as stop:
        main(argv)
    assert stop.value.code == 2
    captured = capsys.readouterr()
    assert captured.out == "" and captured.err.strip().splitlines()[-1] == f"{PROGS[main]}: error: {expected}"


def test_with_no_reference_trees_bench_times_the_batch_road_alone(capsys):
    assert batch.main(["--trees", "2", "--trials", "1", "--reference-trees", "0"]) == 0
    out = capsys.readouterr().out
    assert "batch:" in out and "reference:" not in out and "ratio:" not in out
