from bus.process import main_for

main_for("ros2", "ros2_bridge.commands.ros2")
