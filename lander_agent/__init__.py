"""The lander agent: holds the mission plan and tells each rover, over the radio, where to go."""
