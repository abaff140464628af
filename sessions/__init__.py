"""Sessions: recording, replaying and reporting LunarSim traffic in MCAP files (``lunarsim record`` etc.)."""
