"""The evaluator node: the compiled batch evaluator behind an EvaluateBatch action and service.

Node ``evaluator`` (start several with different names: ``--ros-args -r __node:=evaluator_2``).

Parameters (``config/swarm_sim.yaml``):
    every field of ``swarm_sim.config.Config`` (read-only), as the simulator's: the world evaluated.
    slice (int, 1..1000, default 10): evaluations between two feedback messages and cancel checks.

Actions and services:
    ~/evaluate (swarm_msgs/action/EvaluateBatch): evaluate a batch of trees, the evaluations done as feedback;
        a cancel stops after the slice under way. One result per tree, each depending only on its (tree, seed,
        trials), with a clear error for a tree that could not be evaluated.
    ~/evaluate (swarm_msgs/srv/EvaluateBatch): the same without feedback or cancel, a thin wrapper (the
        evolution manager discovers evaluators by this service's type).

An evolution manager discovers every evaluator in its ROS domain, on this machine or others, and spreads its
batches over them.
"""

from __future__ import annotations

import sys
import threading

import rclpy
from rclpy.action import ActionServer, CancelResponse
from rclpy.action.server import ServerGoalHandle
from rclpy.callback_groups import MutuallyExclusiveCallbackGroup
from rclpy.executors import MultiThreadedExecutor
from rclpy.node import Node

from swarm_msgs.action import EvaluateBatch as EvaluateBatchAction
from swarm_msgs.msg import EvaluationResult
from swarm_msgs.srv import EvaluateBatch
from swarm_ros.parameters import declare_dataclass, descriptor
from swarm_ros.spinning import spin_until_shutdown
from swarm_sim.config import DEFAULT, ConfigError
from swarm_sim.evaluation import MAX_TRIALS, BatchEvaluator, EvaluationRequest
from swarm_sim.result_messages import OBJECTIVES, evaluation_fields


def check_batch(request: object) -> str:
    """Why a whole request (the action's goal or the service's request) must be refused, or ""."""
    trees, seeds = request.trees, request.seeds  # type: ignore[attr-defined]
    if len(trees) != len(seeds):
        return f"got {len(trees)} trees but {len(seeds)} seeds: give one seed per tree"
    if not 1 <= request.trials <= MAX_TRIALS:  # type: ignore[attr-defined]
        return f"trials must be in 1..{MAX_TRIALS}, got {request.trials}"  # type: ignore[attr-defined]
    if request.objective not in OBJECTIVES:  # type: ignore[attr-defined]
        return f"objective must be one of {', '.join(OBJECTIVES)}, got {request.objective!r}"  # type: ignore[attr-defined]
    return ""


class BatchCancelledError(RuntimeError):
    """The batch's goal was cancelled."""


class EvaluatorNode(Node):
    """Serves ~/evaluate (action and service) with an in-process ``BatchEvaluator``."""

    def __init__(self) -> None:
        super().__init__("evaluator")
        config = declare_dataclass(self, DEFAULT, read_only=True)
        self.slice = int(
            self.declare_parameter(
                "slice",
                10,
                descriptor(
                    "evaluations between two feedback messages and cancel checks",
                    read_only=True,
                    value_range=(1, 1000),
                    integer=True,
                ),
            ).value
        )
        self.evaluator = BatchEvaluator(config)
        self.profile = config.profile
        self._busy = threading.Lock()  # one batch at a time: the evaluator uses one core
        group = MutuallyExclusiveCallbackGroup()
        self.create_service(EvaluateBatch, "~/evaluate", self._on_evaluate, callback_group=group)
        self._action_server = ActionServer(
            self,
            EvaluateBatchAction,
            "~/evaluate",
            self._execute,
            callback_group=group,
            cancel_callback=lambda _request: CancelResponse.ACCEPT,
        )
        self.get_logger().info("ready: evaluate action and service")

    def _evaluate(self, request: object, goal: ServerGoalHandle | None = None) -> list[EvaluationResult]:
        """Every result of ``request``, a slice at a time; feedback and cancel checks between slices."""
        trees, seeds = list(request.trees), [int(s) for s in request.seeds]  # type: ignore[attr-defined]
        trials, objective = int(request.trials), request.objective  # type: ignore[attr-defined]
        results: list[EvaluationResult] = []
        step = self.slice if goal is not None else max(len(trees), 1)  # the service has no feedback to give
        with self._busy:
            for start in range(0, len(trees), step):
                if goal is not None and goal.is_cancel_requested:
                    raise BatchCancelledError(f"cancelled after {start} of {len(trees)} evaluations")
                part = [
                    EvaluationRequest(tree=tree, seed=seed, trials=trials)
                    for tree, seed in zip(
                        trees[start : start + step], seeds[start : start + step], strict=True
                    )
                ]
                for request_, result in zip(part, self.evaluator.evaluate(part), strict=True):
                    fields = evaluation_fields(
                        request_.tree, request_.seed, trials, result, objective, profile=self.profile
                    )
                    results.append(EvaluationResult(**fields))
                if goal is not None:
                    goal.publish_feedback(EvaluateBatchAction.Feedback(done=len(results), total=len(trees)))
        return results

    def _on_evaluate(
        self, request: EvaluateBatch.Request, response: EvaluateBatch.Response
    ) -> EvaluateBatch.Response:
        response.message = check_batch(request)
        if response.message:
            self.get_logger().error(response.message)
            return response
        response.results = self._evaluate(request)
        return response

    def _execute(self, goal: ServerGoalHandle) -> EvaluateBatchAction.Result:
        result = EvaluateBatchAction.Result(message=check_batch(goal.request))
        if result.message:
            self.get_logger().error(result.message)
            goal.abort()
            return result
        try:
            result.results = self._evaluate(goal.request, goal)
        except BatchCancelledError as error:
            result.message = str(error)
            self.get_logger().info(result.message)
            goal.canceled()
            return result
        goal.succeed()
        return result


def main(args: list[str] | None = None) -> None:
    """Run an evaluator node until shut down; a bad parameter is a one-line error and exit status 2."""
    rclpy.init(args=args)
    try:
        node = EvaluatorNode()
    except ConfigError as error:
        print(f"evaluator: bad parameter: {error}", file=sys.stderr)
        rclpy.try_shutdown()
        raise SystemExit(2) from None
    spin_until_shutdown(node, MultiThreadedExecutor(num_threads=2))
