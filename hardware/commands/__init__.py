"""The real rovers' commands: ``lunarsim bridge`` (``lunarsim-bridge`` on a flight computer), ``emulate-device`` and
``check-driver``."""
