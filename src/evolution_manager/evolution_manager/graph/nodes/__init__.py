"""The graph wing's ROS 2 executables: thin nodes that declare parameters, topics and services and call the
pure core (``manager``, ``trial``, ``recorder``, ``replay``, ``main_job``, ``measure_graph``,
``measure_services``, ``adaptation_node``)."""
