"""The rover agent's command, ``lunarsim rover`` (``python -m rover_agent``, ``lunarsim-rover`` on a flight
computer)."""
