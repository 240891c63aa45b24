"""Validation against the authors' ARGoS simulation: reference statistics, verdicts and the transfer check.

``reference`` reads the reference TSVs and compares our estimates with theirs (the tolerance of
``docs/model.md``); ``transfer`` scores trees evolved here in both simulators; ``cli`` is the ``validate``
command.
"""

from swarm_sim.validation.reference import AGREES, INDISTINGUISHABLE, OUTSIDE, Comparison, Estimate
from swarm_sim.validation.transfer import GridItem

__all__ = ["AGREES", "INDISTINGUISHABLE", "OUTSIDE", "Comparison", "Estimate", "GridItem"]
