"""Results travel in messages as names plus values, and messages recorded before that are still read."""

from types import SimpleNamespace

import numpy as np
import pytest

from swarm_sim.core import TrialRecord
from swarm_sim.evaluation import (
    EvaluationResult,
    evaluation_result_of,
    named_values,
    result_fields,
    trial_fields,
    trial_record_of,
    values_of,
)
from swarm_sim.model import N_OBJECTIVES, VALUE_NAMES

VALUES = tuple(0.1 * (k + 1) for k in range(len(VALUE_NAMES)))


def test_an_evaluation_result_goes_through_its_fields_by_name_bit_for_bit():
    fields = result_fields("forward", 3, 2, VALUES, "nest", profile="paper")
    assert fields["names"] == list(VALUE_NAMES) and fields["values"] == list(VALUES)
    assert fields["fitness"] == VALUES[VALUE_NAMES.index("nest")]
    message = SimpleNamespace(**fields)
    assert evaluation_result_of(message) == EvaluationResult(
        VALUES[:N_OBJECTIVES], VALUES[N_OBJECTIVES:], None
    )
    failed = SimpleNamespace(**result_fields("forward", 3, 2, None, "nest", "no tree", profile="paper"))
    assert (failed.names, failed.values, evaluation_result_of(failed).error) == ([], [], "no tree")


def test_a_trial_result_goes_through_its_fields_by_name():
    poses = np.arange(27.0).reshape(9, 3)
    record = TrialRecord(trial=2, gap=700.0, values=VALUES, start_poses=poses, end_poses=poses + 1)
    message = SimpleNamespace(**trial_fields(record, SimpleNamespace))
    again = trial_record_of(message, 2)
    assert again.values == VALUES and np.array_equal(again.end_poses, record.end_poses)


def test_the_order_of_names_does_not_matter_and_a_missing_value_is_named():
    message = SimpleNamespace(names=list(reversed(VALUE_NAMES)), values=list(reversed(VALUES)))
    assert values_of(message) == VALUES
    with pytest.raises(ValueError, match="no value for nest"):
        values_of(SimpleNamespace(names=["density"], values=[0.5]))
    with pytest.raises(ValueError, match="1 value names but 2 values"):
        named_values(SimpleNamespace(names=["density"], values=[0.5, 0.6]))


def test_messages_recorded_before_names_and_values_are_read_by_their_fields():
    old = SimpleNamespace(**dict(zip(VALUE_NAMES, VALUES, strict=True)))
    assert values_of(old) == VALUES
    paper_only = SimpleNamespace(
        density=0.1, nest=0.2, food=0.3, movement=0.4, rotation=0.5, conditionality=0.6
    )
    assert named_values(paper_only) == {"density": 0.1, "nest": 0.2, "food": 0.3, "movement": 0.4,
                                        "rotation": 0.5, "conditionality": 0.6}  # fmt: skip
