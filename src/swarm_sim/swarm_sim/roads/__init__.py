"""The roads that run one trial step by step, where someone other than the kernels chooses the actions.

``lockstep`` is the simulator's side of a chain, advanced by the robots' answers (the simulator node runs it),
and ``free_timing`` the answers it advances by when it steps on its own clock;
``reference_road`` drives it with one reference controller per robot (the oracle); ``recording`` keeps every
step of a trial for bags and animations.
"""

from swarm_sim.roads.free_timing import FreeAnswers
from swarm_sim.roads.lockstep import (
    LockstepChain,
    RobotAnswer,
    action_of_wheels,
    run_chain_with_controllers,
    run_with_controllers,
    warm_up,
)
from swarm_sim.roads.recording import RecordedTrial, record_trial, record_trial_reference

__all__ = [
    "FreeAnswers",
    "LockstepChain",
    "RecordedTrial",
    "RobotAnswer",
    "action_of_wheels",
    "record_trial",
    "record_trial_reference",
    "run_chain_with_controllers",
    "run_with_controllers",
    "warm_up",
]
