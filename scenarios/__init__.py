"""Scenario files shipped with LunarSim (the report's four scenarios and more)."""
