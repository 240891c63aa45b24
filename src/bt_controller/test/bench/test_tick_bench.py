"""``ws/run bt_controller bench``'s options: a count out of range is refused in one line naming the option,
its range and the value, before any work."""

from __future__ import annotations

import pytest

from bt_controller.bench import tick_bench


@pytest.mark.parametrize(
    ("argv", "expected"),
    [
        (["--trees", "0"], "--trees must be a positive integer, got 0"),
        (["--robots", "-1"], "--robots must be a positive integer, got -1"),
        (["--ticks", "0"], "--ticks must be a positive integer, got 0"),
        (["--repeats", "-1"], "--repeats must be a positive integer, got -1"),
        (["--reference-robots", "-1"], "--reference-robots must be a positive integer, got -1"),
        (["--agreement", "-1"], "--agreement must be a non-negative integer, got -1"),
        (["--seed", "-1"], "--seed must be a non-negative integer, got -1"),
        (["--sizes", "2"], "no tree has 2 nodes"),
    ],
)
def test_an_option_out_of_range_is_one_line_and_exit_status_2(argv, expected, capsys):
    with pytest.raises(SystemExit) as stop:
        tick_bench.main(argv)
    assert stop.value.code == 2
    captured = capsys.readouterr()
    assert captured.out == "" and captured.err.strip().splitlines()[-1] == f"bench: error: {expected}"
