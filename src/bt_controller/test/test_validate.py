"""``validate``: ``check_options`` names an option as it is typed and says its range, in ``bounds``' order."""

from __future__ import annotations

import argparse

import pytest

from bt_controller.validate import check_options


def test_check_options_names_the_first_option_out_of_range_as_typed():
    args = argparse.Namespace(reference_trees=-1, trials=0, seed=5)
    with pytest.raises(ValueError, match=r"^--reference-trees must be a non-negative integer, got -1$"):
        check_options(args, {"reference_trees": (0, None), "trials": (1, 10)})
    with pytest.raises(ValueError, match=r"^--trials must be an integer in \[1, 10\], got 0$"):
        check_options(args, {"seed": (0, 9), "trials": (1, 10)})
    check_options(args, {"seed": (0, 5)})  # in range: nothing raised


def test_check_options_raises_the_error_type_given():
    class RefusedError(Exception):
        pass

    with pytest.raises(RefusedError, match="--seed must be an integer of at most 4, got 5"):
        check_options(argparse.Namespace(seed=5), {"seed": (None, 4)}, error=RefusedError)
