"""The browser's command, ``lunarsim view``."""
