"""Real rovers: the driver interface, the bridge that puts one driven rover on the world's keys, a reference
serial driver, an emulated serial device and the driver contract checker (report 4.4, the hardware swap).

Kept light (no NumPy, no world service): the bridge ships on the flight computer with the rover agent.
"""
