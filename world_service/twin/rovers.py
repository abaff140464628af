"""The world service in twin mode: what it listens to, and the checks that keep it in real time.

The clock loop, liveliness watchdog, final report and lingering are the simulated world's own
(``world_service.service``); only the inputs differ: telemetry, agent status and the radios' reports.
"""

from __future__ import annotations

from bus.bus import Bus
from bus.process import UsageError
from schemas import keyspace as ks
from world_service.twin import TwinWorld


def check_settings(lockstep: bool, time_scale: float, photos: object) -> None:
    """Real rovers move in real time and take their own photos: refuse what only a simulation can do."""
    if lockstep:
        raise UsageError("--twin follows real rovers in real time: it cannot run --lockstep")
    if time_scale != 1.0:
        raise UsageError(f"--twin follows real rovers in real time: --time-scale must be 1, got {time_scale:g}")
    if photos is not None:
        raise UsageError("--twin has no simulated camera: the rovers' drivers take the photos (drop --photos)")


def declare_io(bus: Bus, keys: ks.Keyspace) -> None:
    for topic in TwinWorld.INPUT_TOPICS:
        bus.subscribe(keys.rovers(topic))
    bus.subscribe(keys.lander(ks.COMM_PARTNERS))
    bus.subscribe(keys.ground_command)
    bus.watch_liveliness(keys.alive_rovers)
    bus.watch_liveliness(keys.alive_lander)
