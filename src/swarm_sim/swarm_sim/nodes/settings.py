"""The parameters the simulator and the evaluator declare beside the world's
(``swarm_sim.model.config.Config``): one home, so that each node knows which names of a shared parameter file
(``/**``) belong to the other."""

from __future__ import annotations

from dataclasses import dataclass


@dataclass(frozen=True)
class EvaluatorSettings:
    """The evaluator's parameters beside the world's."""

    slice: int = 10
    """Evaluations between two feedback messages and cancel checks of the evaluate action."""
    library: str = ""
    """A primitive library file (``bt_controller.language.library``) whose names the trees may use; empty:
    none."""


EVALUATOR_RANGES = {"slice": (1, 1000)}
"""Closed ranges of the evaluator's parameters."""

SIMULATOR_PARAMETERS = frozenset(
    {"conditions", "robot_namespaces", "answer_timeout", "timing", "rate", "sensing"}
)
"""The simulator's parameters beside the world's (declared by ``SimulatorNode``; a test checks that the two
agree)."""

TIMINGS = ("lockstep", "free")
"""How the simulator steps (its ``timing`` parameter; ``swarm_sim.roads.free_timing``)."""
SENSINGS = ("model", "external")
"""Who publishes the robots' readings (the simulator's ``sensing`` parameter): the simulator, as the model
senses, or a node outside it (the virtual-sensor bridge, free timing only)."""
RATE_RANGE = (0.01, 100.0)
"""Simulated seconds per second of wall time the simulator's ``rate`` parameter may be (free timing)."""
