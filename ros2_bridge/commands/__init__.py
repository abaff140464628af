"""The ROS 2 commands: ``lunarsim ros2`` (``python -m ros2_bridge``) and ``lunarsim export-rosbag``."""
