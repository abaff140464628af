"""The lander agent's command, ``lunarsim lander`` (``python -m lander_agent``)."""
