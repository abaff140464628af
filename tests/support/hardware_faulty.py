"""Drivers with real bugs, for ``lunarsim check-driver`` and the bridge to find (tests/e2e/test_hardware.py).

It is the reference serial driver as someone might port it to an older firmware: that firmware called
cancelling ``STOP``, and the port swallows the device's error answer instead of raising it, so a cancel
silently does nothing; and speed levels are clamped into 1..3 rather than refused.
"""

from __future__ import annotations

import math
from dataclasses import replace

from hardware.driver import Imu, Scan
from hardware.serial_driver import SerialDriver, expect_ok
from shared.hit import Hit


class OldFirmwareDriver(SerialDriver):
    def cancel(self) -> None:
        self.client.request("STOP")  # bug: the current firmware answers ERR bad_request, and nobody looks

    def set_speed(self, level: int) -> None:
        expect_ok(self.client.request("SPEED", str(min(3, max(1, level)))), "SPEED")  # bug: clamps bad levels


class GarbledSensorsDriver(SerialDriver):
    """The reference driver with a broken IMU and vision: a pitch of nan, and hits of a kind the interface does not
    have. The bridge builds its messages from these values, so it must refuse them as driver failures."""

    def imu(self) -> Imu:
        return Imu(stamp=super().imu().stamp, pitch_deg=math.nan)

    def perception(self) -> Scan:
        scan = super().perception()
        return Scan(stamp=scan.stamp, hits=tuple(replace(hit, kind="boulder") for hit in scan.hits) or
                    (Hit(angle_deg=0.0, distance_m=1.0, kind="boulder"),))
