"""The manager's evaluator nodes are started in the run's world: its profile and every parameter its task sets
(an edited task's robot count, arena and trials), not only the trial length."""

from dataclasses import replace
from types import SimpleNamespace

from evolution_manager.evolution.run_config import RunConfig
from evolution_manager.graph.nodes.manager import OwnedEvaluators
from swarm_sim.tasks import FORAGING, Arena, Robots


def _parameters(config: RunConfig) -> dict[str, object]:
    run = SimpleNamespace(config=config, library=None)
    return OwnedEvaluators(None, lambda *_: None, run).parameters  # no graph: only its parameters are read


def test_the_evaluator_nodes_get_the_runs_task_world():
    assert _parameters(RunConfig.make("qd", "food", 10, 1)) == {"profile": "paper", "ticks": 40}
    assert _parameters(RunConfig.make("qd", "foraging", 10, 1, task="foraging", profile="clean")) == {
        "profile": "clean",
        "ticks": 200,
    }
    small = replace(FORAGING, name="small", robots=Robots(count=5), arena=Arena(half_size=2000.0))
    assert _parameters(RunConfig.make("gp", "foraging", 10, 1, task=small)) == {
        "profile": "paper",
        "ticks": 200,
        "n_robots": 5,
        "arena_half": 2000.0,
    }
