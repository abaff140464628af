"""The recording commands: ``lunarsim record``, ``replay``, ``recover``, ``report`` and ``export-foxglove``."""
