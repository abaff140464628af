"""The rover agent: one rover's behaviour, runtime and dead reckoning. Light: no NumPy, no world service."""
