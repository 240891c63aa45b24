"""Launch the trial graph on a full ROS 2 install: the simulator and one footbot controller per robot.

    ros2 launch evolution_manager trial_graph.launch.py tree:="sel(seq(in_nest, stop), forward)"
    ros2 service call /simulator/run_trial swarm_msgs/srv/RunTrial "{seed: 1, trial: 0}"

On the PyPI-wheel workspace (no `launch` there) `ws/run evolution_manager trial` starts the same graph.
"""

from launch import LaunchDescription
from launch.actions import DeclareLaunchArgument
from launch.substitutions import LaunchConfiguration
from launch_ros.actions import Node

ROBOTS = 9


def generate_launch_description() -> LaunchDescription:
    tree = LaunchConfiguration("tree")
    nodes = [Node(package="swarm_sim", executable="simulator", name="simulator", output="screen")]
    nodes += [
        Node(
            package="bt_controller",
            executable="footbot_controller",
            name="footbot_controller",
            namespace=f"footbot_{i}",
            parameters=[{"robot": i, "tree": tree}],
            output="screen",
        )
        for i in range(ROBOTS)
    ]
    return LaunchDescription(
        [
            DeclareLaunchArgument("tree", default_value="", description="tree loaded into every controller"),
            *nodes,
        ]
    )
