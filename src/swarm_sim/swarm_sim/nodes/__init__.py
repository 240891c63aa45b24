"""ROS 2 nodes: thin wrappers that declare parameters, topics and services and call the pure core."""
