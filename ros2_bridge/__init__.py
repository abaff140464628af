"""ROS 2 over rmw_zenoh's wire format: the ``lunarsim ros2`` bridge and the ``lunarsim export-rosbag`` export, one
mapping between LunarSim's messages and ROS 2's standard types for both (``ros2_bridge.translator``)."""
