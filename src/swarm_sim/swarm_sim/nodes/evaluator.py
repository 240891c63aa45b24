"""The evaluator node: the compiled batch evaluator behind an EvaluateBatch action and service.

Node ``evaluator`` (start several with different names: ``--ros-args -r __node:=evaluator_2``), a managed
(lifecycle) node (``swarm_ros.lifecycle``): ``configure`` builds the evaluator and offers the action and the
service, ``activate`` lets it take goals, ``deactivate`` stops the batch under way after its slice (its
results so far returned) and refuses goals, ``cleanup`` and ``shutdown`` withdraw the action and the service.
It configures and activates itself at start unless ``-p autostart:=false``.

Parameters (``config/swarm_sim.yaml``; a bad one stops the node with one line, exit status 2):
    every field of ``swarm_sim.model.config.Config`` (read-only), as the simulator's: the world evaluated.
    slice (int, 1..1000, default 10): evaluations between two feedback messages and cancel checks.
    library (string, default none): a primitive library file (``bt_controller.language.library``) whose
    primitives'
        names the trees may use; the manager that starts evaluators passes its run's library. A library that
        cannot be read stops the node with one line, exit status 2.
    autostart (bool, default true): configure and activate at start.

Actions and services:
    ~/evaluate (swarm_msgs/action/EvaluateBatch): evaluate a batch of trees, the evaluations done as feedback;
        a goal with unequal trees and seeds, trials out of range or an unknown objective, or sent while the
        node is not active, is rejected at once. A cancel stops after the slice under way, and the result
        holds the evaluations finished. One result per tree, each depending only on its (tree, seed,
        trials), with a clear error for a tree that could not be evaluated.
    ~/evaluate (swarm_msgs/srv/EvaluateBatch): the same without feedback or cancel, a thin wrapper (the
        evolution manager discovers evaluators by this service's type); a request it cannot take is answered
        with the reason in ``message``.

Publishers:
    /diagnostics (diagnostic_msgs/DiagnosticArray): every second, the lifecycle state, evaluations done and
        per second (over the last second), goals waiting and evaluations left in the batch under way.

An evolution manager discovers every evaluator in its ROS domain, on this machine or others, and spreads its
batches over them.
"""

from __future__ import annotations

import threading
import time
from typing import Any

from rclpy.action import ActionServer, CancelResponse, GoalResponse
from rclpy.action.server import ServerGoalHandle
from rclpy.callback_groups import MutuallyExclusiveCallbackGroup
from rclpy.executors import MultiThreadedExecutor
from rclpy.lifecycle import LifecycleState, TransitionCallbackReturn

from bt_controller.language import LibraryError, load_library
from bt_controller.nodes.footbot_controller import ControllerSettings
from swarm_msgs.action import EvaluateBatch as EvaluateBatchAction
from swarm_msgs.msg import EvaluationResult
from swarm_msgs.srv import EvaluateBatch
from swarm_ros.lifecycle import ManagedNode
from swarm_ros.parameters import declare_dataclass, field_names, start_node
from swarm_ros.spinning import spin_until_shutdown
from swarm_sim.errors import ConfigError
from swarm_sim.evaluation import MAX_TRIALS, BatchEvaluator, EvaluationRequest, evaluation_fields
from swarm_sim.model import DEFAULT, OBJECTIVES
from swarm_sim.nodes.settings import EVALUATOR_RANGES, SIMULATOR_PARAMETERS, EvaluatorSettings
from swarm_sim.nodes.world_parameters import declare_world


def check_batch(request: Any) -> str:  # the action's goal or the service's request (generated, untyped)
    """Why a whole request must be refused, or ""."""
    trees, seeds = request.trees, request.seeds
    if len(trees) != len(seeds):
        return f"got {len(trees)} trees but {len(seeds)} seeds: give one seed per tree"
    if not 1 <= request.trials <= MAX_TRIALS:
        return f"trials must be in 1..{MAX_TRIALS}, got {request.trials}"
    if request.objective not in OBJECTIVES:
        return f"objective must be one of {', '.join(OBJECTIVES)}, got {request.objective!r}"
    return ""


class EvaluatorNode(ManagedNode):
    """Serves ~/evaluate (action and service) with an in-process ``BatchEvaluator`` while active."""

    def __init__(self) -> None:
        super().__init__("evaluator", "swarm_sim evaluator")
        self.config = declare_world(self, DEFAULT)
        self.settings = declare_dataclass(self, EvaluatorSettings(), read_only=True, ranges=EVALUATOR_RANGES)
        self.slice = self.settings.slice
        self.library = load_library(self.settings.library) if self.settings.library else None
        self.profile = self.config.profile
        self.evaluator: BatchEvaluator | None = None
        self._busy = threading.Lock()  # one batch at a time: the evaluator uses one core
        self._figures = threading.Lock()
        self.evaluations = 0
        self.goals_waiting = 0
        self.evaluations_left = 0
        self._last = (time.monotonic(), 0)
        self._service: Any = None
        self._action_server: ActionServer | None = None

    # --- lifecycle
    def on_configure(self, state: LifecycleState) -> TransitionCallbackReturn:
        self.evaluator = BatchEvaluator(self.config, library=self.library)
        group = MutuallyExclusiveCallbackGroup()
        self._service = self.create_service(
            EvaluateBatch, "~/evaluate", self._on_evaluate, callback_group=group
        )
        self._action_server = ActionServer(
            self,
            EvaluateBatchAction,
            "~/evaluate",
            self._execute,
            callback_group=group,
            goal_callback=self._on_goal,
            cancel_callback=lambda _request: CancelResponse.ACCEPT,
        )
        self.get_logger().info("ready: evaluate action and service")
        return TransitionCallbackReturn.SUCCESS

    def release(self) -> None:
        if self._action_server is not None:
            self._action_server.destroy()
            self._action_server = None
        if self._service is not None:
            self.destroy_service(self._service)
            self._service = None
        self.evaluator = None

    def diagnostic_values(self) -> dict[str, str]:
        now = time.monotonic()
        with self._figures:
            (then, before), done = self._last, self.evaluations
            self._last = (now, done)
            waiting, left = self.goals_waiting, self.evaluations_left
        rate = (done - before) / (now - then) if now > then else 0.0
        return {
            "evaluations": str(done),
            "evaluations per second": f"{rate:.1f}",
            "goals waiting": str(waiting),
            "evaluations left": str(left),
        }

    # --- work
    def _evaluate(
        self, request: Any, goal: ServerGoalHandle | None = None
    ) -> tuple[list[EvaluationResult], str]:
        """The results of ``request``, a slice at a time, and why the batch stopped early ("" when it did
        not: "cancelled" or "deactivated"); feedback and the checks between slices."""
        trees, seeds = list(request.trees), [int(s) for s in request.seeds]
        trials, objective = int(request.trials), request.objective
        results: list[EvaluationResult] = []
        step = self.slice if goal is not None else max(len(trees), 1)  # the service has no feedback to give
        with self._busy:
            assert self.evaluator is not None, "a goal or request is taken only while configured"
            with self._figures:
                self.evaluations_left = len(trees)
            try:
                for start in range(0, len(trees), step):
                    if goal is not None and goal.is_cancel_requested:
                        return results, "cancelled"
                    if not self.active:
                        return results, "deactivated"
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
                    with self._figures:
                        self.evaluations += len(part)
                        self.evaluations_left = len(trees) - len(results)
                    if goal is not None:
                        goal.publish_feedback(
                            EvaluateBatchAction.Feedback(done=len(results), total=len(trees))
                        )
            finally:
                with self._figures:
                    self.evaluations_left = 0
        return results, ""

    def _on_evaluate(
        self, request: EvaluateBatch.Request, response: EvaluateBatch.Response
    ) -> EvaluateBatch.Response:
        response.message = check_batch(request) if self.active else f"{self.get_name()} is not active"
        if response.message:
            self.get_logger().error(response.message)
            return response
        response.results, stopped = self._evaluate(request)
        if stopped:
            response.message = f"{stopped} after {len(response.results)} of {len(request.trees)} evaluations"
        return response

    def _on_goal(self, goal: Any) -> GoalResponse:  # an EvaluateBatch goal (generated, untyped)
        problem = check_batch(goal) if self.active else f"{self.get_name()} is not active ({self.state})"
        if problem:
            self.get_logger().error(f"rejected a goal: {problem}")
            return GoalResponse.REJECT
        with self._figures:
            self.goals_waiting += 1
        return GoalResponse.ACCEPT

    def _execute(self, goal: ServerGoalHandle) -> EvaluateBatchAction.Result:
        with self._figures:
            self.goals_waiting -= 1
        result = EvaluateBatchAction.Result()
        result.results, stopped = self._evaluate(goal.request, goal)
        if not stopped:
            goal.succeed()
            return result
        result.message = f"{stopped} after {len(result.results)} of {len(goal.request.trees)} evaluations"
        self.get_logger().info(result.message)
        if stopped == "cancelled":
            goal.canceled()
        else:
            goal.abort()
        return result


SHARED = SIMULATOR_PARAMETERS | field_names(ControllerSettings)
"""Parameters of the graph's other nodes that a ``/**`` section of a shared parameter file may hold."""


def main(args: list[str] | None = None) -> None:
    """Run an evaluator node until shut down; a bad parameter is a one-line error and exit status 2."""
    node = start_node("evaluator", EvaluatorNode, args, shared=SHARED, errors=(ConfigError, LibraryError))
    node.start()
    spin_until_shutdown(node, MultiThreadedExecutor(num_threads=2))
