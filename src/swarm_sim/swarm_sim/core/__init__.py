"""The trial-step core, compiled: the world's functions, the batch kernels and a trial's record.

``world`` holds the model as ``njit`` functions (physics, messages, one robot's view, probes and scores),
``fast_world`` the same physics with less work, ``kernel`` whole chains of trials for many trees at once, and
``sensing`` one step's readings for every robot. ``trial_data`` says what a trial records and how chains are
planned. Every road (``swarm_sim.roads``, ``swarm_sim.evaluation``) steps the world through these.
"""

from swarm_sim.core.sensing import sense_swarm
from swarm_sim.core.trial_data import ChainSetup, TrialRecord, chain_plan, combine, robot_faults, setup_chain

__all__ = ["ChainSetup", "TrialRecord", "chain_plan", "combine", "robot_faults", "sense_swarm", "setup_chain"]
