"""Launch the trial graph on a full ROS 2 install: the simulator and one footbot controller per robot.

    ros2 launch evolution_manager trial_graph.launch.py tree:="sel(seq(in_nest, stop), forward)"
    ros2 action send_goal /simulator/run_trial swarm_msgs/action/RunTrial "{seed: 1, trial: 0}" --feedback

Arguments (``evolution_manager.graph.startup.LAUNCH_ARGUMENTS``, the options of ``trial`` that shape the
graph): ``robots`` (default: the task's), ``namespace`` (e.g. ``/swarm_a``; default the root), ``tree``
(loaded into every controller), ``swarm`` (instead of ``tree``: a swarm layout file,
``swarm_sim.model.swarm_layout``, each controller loading its own robot's tree), ``profile`` (the simulator's
model profile; default: its parameter file's), ``task`` (a registered task or a task file), ``library`` (a
primitive library file for every controller), ``clock`` (the graph's clock topic: ``/swarm_a/clock`` for a
second graph in one domain), ``commands`` (the controllers' ``wheels``, ``cmd_vel`` or ``both``),
``use_sim_time`` (``true``: every node follows the graph's clock), ``timing`` (``lockstep`` or ``free``: the
simulator steps at ``rate`` times real time, the controllers tick on their own timers) and ``params_file`` (a
parameter file for every node, after the packages' own ``config/*.yaml``).

The node set is ``evolution_manager.graph.startup.launch_graph_nodes``, built on the same
``trial_graph_nodes`` that ``ws/run evolution_manager trial`` starts on the PyPI-wheel workspace (no
``launch`` there).
"""

from launch import LaunchContext, LaunchDescription
from launch.actions import DeclareLaunchArgument, OpaqueFunction
from launch.substitutions import LaunchConfiguration
from launch_ros.actions import Node

from evolution_manager.graph.startup import LAUNCH_ARGUMENTS, launch_graph_nodes, package_config


def nodes(context: LaunchContext) -> list[Node]:
    arguments = {name: LaunchConfiguration(name).perform(context) for name in LAUNCH_ARGUMENTS}
    user_file = arguments["params_file"]
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
        for spec in launch_graph_nodes(arguments)
    ]


def generate_launch_description() -> LaunchDescription:
    return LaunchDescription(
        [
            *(
                DeclareLaunchArgument(name, default_value=default, description=description)
                for name, (default, description) in LAUNCH_ARGUMENTS.items()
            ),
            OpaqueFunction(function=nodes),
        ]
    )
