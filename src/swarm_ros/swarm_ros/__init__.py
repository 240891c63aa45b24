"""The ROS 2 helpers every node package of the workspace shares.

- ``swarm_ros.isolation``: a DDS domain per graph, so graphs started side by side never see each other.
- ``swarm_ros.spinning``: the one spin-until-shutdown loop of every node executable.
- ``swarm_ros.qos``: the quality-of-service profiles of the graph's topics.
- ``swarm_ros.names``: robot namespaces and the robot index a namespace names.
- ``swarm_ros.parameters``: declared parameters with descriptors, from a frozen dataclass's fields, and the
  start-up of every node that refuses a bad parameter in one line.
- ``swarm_ros.lifecycle``: managed (lifecycle) nodes with diagnostics, and the client that drives them.
"""
