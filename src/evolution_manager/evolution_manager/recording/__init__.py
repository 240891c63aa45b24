"""Bags: rosbag2 with MCAP storage, written and read with ``rosbags`` (no ROS), and trial bags checked
against the model.

``bags`` writes a run's evaluations and reads any bag the project records (and recovers a bag whose
writer was killed); ``reproduce`` re-runs a recorded trial in-process and compares it with the bag.
Imports: the base modules, bt_controller, swarm_sim and rosbags; no other wing.
"""

__all__ = ["bags", "reproduce"]
