"""Launch the trial graph on a full ROS 2 install: the simulator and one footbot controller per robot.

    ros2 launch evolution_manager trial_graph.launch.py tree:="sel(seq(in_nest, stop), forward)"
    ros2 action send_goal /simulator/run_trial swarm_msgs/action/RunTrial "{seed: 1, trial: 0}" --feedback

Arguments: ``robots`` (default 9), ``namespace`` (e.g. ``/swarm_a``; default the root), ``tree`` (loaded into
every controller), ``swarm`` (instead of ``tree``: a swarm layout file, ``swarm_sim.swarm_layout``, each
controller loading its own robot's tree), ``profile`` (the simulator's model profile; default: its parameter
file's) and ``params_file`` (a parameter file for every node, after the packages' own ``config/*.yaml``).

The node set is ``evolution_manager.graph.startup.trial_graph_nodes``, the same that
``ws/run evolution_manager trial`` starts on the PyPI-wheel workspace (no ``launch`` there).
"""

from launch import LaunchContext, LaunchDescription
from launch.actions import DeclareLaunchArgument, OpaqueFunction
from launch.substitutions import LaunchConfiguration
from launch_ros.actions import Node

from evolution_manager.graph.startup import package_config, trial_graph_nodes
from swarm_sim.swarm_layout import load_layout


def nodes(context: LaunchContext) -> list[Node]:
    def argument(name: str) -> str:
        return LaunchConfiguration(name).perform(context)

    user_file = argument("params_file")
    robots = int(argument("robots"))
    swarm = argument("swarm")
    tree = load_layout(swarm, robots).trees if swarm else argument("tree")
    specs = trial_graph_nodes(robots, argument("namespace"), tree=tree, profile=argument("profile"))
    return [
        Node(
            package=spec.package,
            executable=spec.executable,
            namespace=spec.namespace or None,
            parameters=[
                str(package_config(spec.package)),
                *([user_file] if user_file else []),
                spec.parameters,
            ],
            remappings=list(spec.remaps.items()),
            output="screen",
        )
        for spec in specs
    ]


def generate_launch_description() -> LaunchDescription:
    return LaunchDescription(
        [
            DeclareLaunchArgument("robots", default_value="9", description="number of footbots"),
            DeclareLaunchArgument("namespace", default_value="", description="namespace of the whole graph"),
            DeclareLaunchArgument("tree", default_value="", description="tree loaded into every controller"),
            DeclareLaunchArgument(
                "swarm", default_value="", description="a swarm layout file: each controller its robot's tree"
            ),
            DeclareLaunchArgument("profile", default_value="", description="model profile (paper or clean)"),
            DeclareLaunchArgument(
                "params_file", default_value="", description="parameter file for every node"
            ),
            OpaqueFunction(function=nodes),
        ]
    )
