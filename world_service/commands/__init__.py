"""The world service's command, ``lunarsim world`` (``python -m world_service``)."""
