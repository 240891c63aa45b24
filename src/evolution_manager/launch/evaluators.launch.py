"""Launch evaluator nodes on a full ROS 2 install, one per core you want to give the evolution manager.

    ros2 launch evolution_manager evaluators.launch.py count:=2

Start them on as many hosts as you like in the same ROS domain: the manager discovers every evaluator.
Arguments: ``count`` (default 1), ``profile`` (the model profile; default: the parameter file's) and
``params_file`` (a parameter file for every evaluator, after ``swarm_sim``'s own ``config/swarm_sim.yaml``).
"""

from launch import LaunchContext, LaunchDescription
from launch.actions import DeclareLaunchArgument, OpaqueFunction
from launch.substitutions import LaunchConfiguration
from launch_ros.actions import Node

from evolution_manager.graph.startup import package_config


def evaluators(context: LaunchContext) -> list[Node]:
    count = int(LaunchConfiguration("count").perform(context))
    user_file = LaunchConfiguration("params_file").perform(context)
    profile = LaunchConfiguration("profile").perform(context)
    parameters = [str(package_config("swarm_sim")), *([user_file] if user_file else [])]
    if profile:
        parameters.append({"profile": profile})
    return [
        Node(
            package="swarm_sim",
            executable="evaluator",
            name=f"evaluator_{k}",
            parameters=parameters,
            output="screen",
        )
        for k in range(count)
    ]


def generate_launch_description() -> LaunchDescription:
    return LaunchDescription(
        [
            DeclareLaunchArgument("count", default_value="1", description="number of evaluator nodes"),
            DeclareLaunchArgument("profile", default_value="", description="model profile (paper or clean)"),
            DeclareLaunchArgument(
                "params_file", default_value="", description="parameter file for every node"
            ),
            OpaqueFunction(function=evaluators),
        ]
    )
