"""Twin mode: the world follows real rovers instead of simulating them. ``world`` is the twin the service drives,
``rovers`` what it knows of each real rover."""
