"""``ws/run bt_controller bench``'s options: a count out of range is refused by the command, before any
work, in one line naming the option, its range and the value, exit status 2."""

from __future__ import annotations

import subprocess
import sys

import pytest


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
def test_a_count_out_of_range_is_refused_in_one_line(argv, expected):
    done = subprocess.run(
        [sys.executable, "-m", "bt_controller.bench.tick_bench", *argv], capture_output=True, text=True
    )
    assert (done.returncode, done.stdout) == (2, "")
    assert done.stderr.strip().splitlines()[-1] == f"bench: error: {expected}"
