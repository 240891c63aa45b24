"""The robot side: one footbot's onboard software, node-free, step by step (numba where the simulator shares
it).

``timeline`` is the one home of the trial timeline (when a robot senses, refreshes, ticks, broadcasts; reached
as a module: ``from bt_controller.robot import timeline``); ``perception`` a footbot's estimates, smoothing
window and blackboard from its own readings; ``motors`` the wheels after a tick and what the descriptors
count; ``controller`` one footbot's controller in lockstep with the timeline; ``free_running`` the same on its
own clock, as on a robot. The ROS 2 node that wraps them is ``bt_controller.nodes.footbot_controller``.
"""

from bt_controller.robot.controller import FootbotController, StepOutcome, TickOutcome
from bt_controller.robot.free_running import FreeRunningController, FreeTick, SensingCounts, empty_readings
from bt_controller.robot.motors import motors_after_tick, movement_of, rotation_of, running_action
from bt_controller.robot.perception import ROBOT_SIDE, Readings, RobotView, blackboard, region_column, warm_up

__all__ = [
    "ROBOT_SIDE",
    "FootbotController",
    "FreeRunningController",
    "FreeTick",
    "Readings",
    "RobotView",
    "SensingCounts",
    "StepOutcome",
    "TickOutcome",
    "blackboard",
    "empty_readings",
    "motors_after_tick",
    "movement_of",
    "region_column",
    "rotation_of",
    "running_action",
    "warm_up",
]
