"""``record-bench``'s options: a value out of range is refused in one line naming the option, its range and
the value, before any work."""

from __future__ import annotations

import pytest

from bt_controller.draws import MAX_SEED
from swarm_sim.bench import recording


@pytest.mark.parametrize(
    ("argv", "expected"),
    [
        (["--trees", "0"], "--trees must be a positive integer, got 0"),
        (["--reference-trees", "-2"], "--reference-trees must be a non-negative integer, got -2"),
        (["--trial", "10000"], "--trial must be an integer in [0, 9999], got 10000"),
        (["--seed", str(MAX_SEED)], f"--seed must be an integer in [0, {MAX_SEED - 300}], got {MAX_SEED}"),
    ],
)
def test_an_option_out_of_range_is_one_line_and_exit_status_2(argv, expected, capsys):
    with pytest.raises(SystemExit) as stop:
        recording.main(argv)
    assert stop.value.code == 2
    captured = capsys.readouterr()
    assert captured.out == "" and captured.err.strip().splitlines()[-1] == f"record-bench: error: {expected}"
