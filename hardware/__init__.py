"""Real rovers: the driver interface, the bridge that puts one driven rover on the world's keys, a reference
serial driver, an emulated serial device and the driver contract checker (report 4.4, the hardware swap).

The bridge has every process's shape: a pure core (``bridge.Bridge``, which does no I/O), its Zenoh loop
(``runtime``) and its command (``commands.bridge``, ``lunarsim bridge``, ``lunarsim-bridge`` on a flight computer).
Kept light (no NumPy, no world service): the bridge ships on the flight computer with the rover agent.
"""
