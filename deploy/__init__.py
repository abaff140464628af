"""Launching and deploying LunarSim: the ``lunarsim`` command, Zenoh configuration, process supervision."""
