"""The ROS 2 side of evolution: node processes, the manager and trial nodes, recording, evaluator nodes.

``startup`` starts and stops node processes (the trial graph, evaluator nodes); ``dispatch`` spreads a
batch over evaluators in chunks and re-sends the work of any that vanish (plain Python);
``service_evaluator`` is the evaluator contract over evaluator nodes' actions; ``graph_evaluator`` runs
evaluations through a trial graph. ``nodes/`` holds the executables: ``manager``, ``trial``, ``record``,
``replay``/``recover``, the main job and the graph benchmarks. Imports: the base modules, the ``evolution``,
``recording`` and ``viewing`` wings, swarm_ros, swarm_msgs and rclpy.
"""

__all__ = ["dispatch", "graph_evaluator", "nodes", "service_evaluator", "startup"]
