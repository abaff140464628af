"""Real rovers: the driver interface, the bridge that puts one driven rover on the world's keys, a reference
serial driver, an emulated serial device and the driver contract checker (report 4.4, the hardware swap).

The bridge has every process's shape: a pure core (``bridge.Bridge``, which does no I/O), its Zenoh loop
(``runtime``) and its command (``commands.bridge``, ``lunarsim bridge``, ``lunarsim-bridge`` on a flight computer).
Kept light (no NumPy, no world service): the bridge ships on the flight computer with the rover agent.
"""

from __future__ import annotations

DRIVER = ("ActionRefused", "ActionStatus", "Driver", "DriverError", "DriverTimeout", "Imu", "InvalidCommand",
          "NotSupported", "Odometry", "Radio", "Scan", "Transmission")
"""A driver's interface (``hardware.driver``): what a new driver subclasses, returns and raises."""
__all__ = [*DRIVER, "Checker", "Violation", "load_driver"]


def __getattr__(name: str) -> object:
    """Loaded on first use, so ``lunarsim bridge --help`` and a flight computer's start read no more than they
    need."""
    if name in DRIVER:
        from hardware import driver

        return getattr(driver, name)
    if name in ("Checker", "Violation"):
        from hardware import check

        return getattr(check, name)
    if name == "load_driver":
        from hardware.drivers import load_driver

        return load_driver
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
