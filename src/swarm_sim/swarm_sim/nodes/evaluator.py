"""The evaluator node: the compiled batch evaluator behind an EvaluateBatch service.

Node ``evaluator`` (start several with different names: ``--ros-args -r __node:=evaluator_2``).

Services:
    ~/evaluate (swarm_msgs/EvaluateBatch): evaluate a batch of trees; one result per tree, each depending only
        on its (tree, seed, trials), with a clear error for a tree that could not be evaluated.

An evolution manager discovers every service of this type in its ROS domain, on this machine or others, and
spreads its batches over them.
"""

from __future__ import annotations

import rclpy
from rclpy.node import Node

from bt_controller.nodes.spinning import spin_until_shutdown
from swarm_msgs.msg import EvaluationResult
from swarm_msgs.srv import EvaluateBatch
from swarm_sim.evaluation import MAX_TRIALS, BatchEvaluator, EvaluationRequest
from swarm_sim.trial_data import VALUE_NAMES

OBJECTIVES = VALUE_NAMES[:3]


def check_batch(request: EvaluateBatch.Request) -> str:
    """Why a whole request must be refused, or the empty string."""
    if len(request.trees) != len(request.seeds):
        return f"got {len(request.trees)} trees but {len(request.seeds)} seeds: give one seed per tree"
    if not 1 <= request.trials <= MAX_TRIALS:
        return f"trials must be in 1..{MAX_TRIALS}, got {request.trials}"
    if request.objective not in OBJECTIVES:
        return f"objective must be one of {', '.join(OBJECTIVES)}, got {request.objective!r}"
    return ""


class EvaluatorNode(Node):
    """Serves ~/evaluate with an in-process ``BatchEvaluator``."""

    def __init__(self) -> None:
        super().__init__("evaluator")
        self.evaluator = BatchEvaluator()
        self.create_service(EvaluateBatch, "~/evaluate", self._on_evaluate)

    def _on_evaluate(
        self, request: EvaluateBatch.Request, response: EvaluateBatch.Response
    ) -> EvaluateBatch.Response:
        response.message = check_batch(request)
        if response.message:
            self.get_logger().error(response.message)
            return response
        seeds = [int(s) for s in request.seeds]
        requests = [
            EvaluationRequest(tree=tree, seed=seed, trials=int(request.trials))
            for tree, seed in zip(request.trees, seeds, strict=True)
        ]
        for tree, seed, result in zip(request.trees, seeds, self.evaluator.evaluate(requests), strict=True):
            msg = EvaluationResult(tree=tree, seed=seed, trials=request.trials, ok=result.ok)
            if result.fitness is not None and result.descriptors is not None:  # result.ok
                values = (*result.fitness, *result.descriptors)
                for name, value in zip(VALUE_NAMES, values, strict=True):
                    setattr(msg, name, value)
                msg.fitness = getattr(msg, request.objective)
            else:
                msg.error = result.error
            response.results.append(msg)
        return response


def main(args: list[str] | None = None) -> None:
    """Run an evaluator node until shut down."""
    rclpy.init(args=args)
    spin_until_shutdown(EvaluatorNode())
