"""Evaluations: the Evaluator contract and the batch evaluator, and results as ROS messages.

``batch`` holds ``EvaluationRequest``, ``SwarmRequest``, ``EvaluationResult`` and ``BatchEvaluator`` (the
compiled batch road); ``result_messages`` turns results and trial records into message fields and back;
``cli`` is the ``evaluate`` command.
"""

from swarm_sim.evaluation.batch import (
    MAX_TRIALS,
    BatchEvaluator,
    EvaluationRequest,
    EvaluationResult,
    Evaluator,
    SwarmRequest,
    check_request,
    failed,
    from_values,
    most_threads,
)
from swarm_sim.evaluation.result_messages import (
    evaluation_fields,
    evaluation_result_of,
    fill,
    named_values,
    result_fields,
    trial_fields,
    trial_record_of,
    values_of,
)

__all__ = [
    "MAX_TRIALS",
    "BatchEvaluator",
    "EvaluationRequest",
    "EvaluationResult",
    "Evaluator",
    "SwarmRequest",
    "check_request",
    "evaluation_fields",
    "evaluation_result_of",
    "failed",
    "fill",
    "from_values",
    "most_threads",
    "named_values",
    "result_fields",
    "trial_fields",
    "trial_record_of",
    "values_of",
]
