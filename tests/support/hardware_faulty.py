"""A driver with real bugs, for ``lunarsim check-driver`` to find (tests/e2e/test_hardware.py).

It is the reference serial driver as someone might port it to an older firmware: that firmware called
cancelling ``STOP``, and the port swallows the device's error answer instead of raising it, so a cancel
silently does nothing; and speed levels are clamped into 1..3 rather than refused.
"""

from __future__ import annotations

from hardware.serial_driver import SerialDriver, expect_ok


class OldFirmwareDriver(SerialDriver):
    def cancel(self) -> None:
        self.client.request("STOP")  # bug: the current firmware answers ERR bad_request, and nobody looks

    def set_speed(self, level: int) -> None:
        expect_ok(self.client.request("SPEED", str(min(3, max(1, level)))), "SPEED")  # bug: clamps bad levels
