"""Launch evaluator nodes on a full ROS 2 install, one per core you want to give the evolution manager.

    ros2 launch evolution_manager evaluators.launch.py count:=2

Start them on as many hosts as you like in the same ROS domain: the manager discovers every evaluate service.
"""

from launch import LaunchContext, LaunchDescription
from launch.actions import DeclareLaunchArgument, OpaqueFunction
from launch.substitutions import LaunchConfiguration
from launch_ros.actions import Node


def evaluators(context: LaunchContext) -> list[Node]:
    count = int(LaunchConfiguration("count").perform(context))
    return [
        Node(package="swarm_sim", executable="evaluator", name=f"evaluator_{k}", output="screen")
        for k in range(count)
    ]


def generate_launch_description() -> LaunchDescription:
    return LaunchDescription(
        [
            DeclareLaunchArgument("count", default_value="1", description="number of evaluator nodes"),
            OpaqueFunction(function=evaluators),
        ]
    )
