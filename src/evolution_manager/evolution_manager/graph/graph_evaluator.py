"""Evaluations through the node graph, for ``adapt --graph``: each tree is loaded into every controller node
(``load_tree``) and each of its trials run by the simulator node in the changed world, recorded to a bag of
its own; the evaluation's values are the trials' mean, exactly as the batch evaluator computes them."""

from __future__ import annotations

import contextlib
from collections.abc import Iterator, Sequence
from pathlib import Path

from evolution_manager.graph.nodes.trial import TrialGraph
from swarm_ros.safe_paths import make_folder
from swarm_sim.core import combine
from swarm_sim.evaluation import EvaluationRequest, EvaluationResult, from_values
from swarm_sim.model import DEFAULT
from swarm_sim.tasks import TaskSpec


class GraphEvaluator:
    """The evaluator contract over a running ``TrialGraph``; trials recorded under ``bags`` when given."""

    def __init__(self, graph: TrialGraph, bags: Path | None) -> None:
        self.graph = graph
        self.bags = bags
        self.evaluations = 0

    def evaluate(self, requests: Sequence[EvaluationRequest]) -> list[EvaluationResult]:
        """Evaluate every request, trial by trial, through the graph."""
        out = []
        for request in requests:
            self.evaluations += 1
            records = []
            for trial in range(request.trials):
                bag = None
                if self.bags is not None:
                    bag = self.bags / f"evaluation_{self.evaluations:03d}_trial_{trial:02d}"
                records.append(self.graph.run(request.tree, request.seed, trial, bag))
            out.append(from_values(combine(records)))
        return out


@contextlib.contextmanager
def graph_evaluator(
    conditions: Sequence[str],
    bags: Path | None,
    timeout: float = 120.0,
    profile: str = DEFAULT.profile,
    task: TaskSpec | str | None = None,
) -> Iterator[GraphEvaluator]:
    """A node graph of the model's ``profile`` on ``task`` (its name or spec; None: the primitives' task) in
    the changed world (``conditions``), started for the block, as an evaluator whose trials are recorded
    under ``bags`` when given."""
    with TrialGraph(conditions=conditions, timeout=timeout, profile=profile, task=task) as graph:
        if bags is not None:
            make_folder(bags)
        yield GraphEvaluator(graph, bags)
