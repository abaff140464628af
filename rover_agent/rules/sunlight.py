"""Staying in the sun when the charge runs low (report appendix E 3.1: "Rovers should stay as much
within sunlight as possible ... to recharge").

The rover knows only its own sensors: its battery's charge, whether its panel is lit, and its dead-reckoned
pose. So it remembers where it last stood in sunlight and, per shadow it walks into, the charge it had on
entering:

- lit and below ``low_charge_fraction`` (or already charging): stop and charge up to ``recharge_to_fraction``;
- in shadow, having entered it with at least ``low_charge_fraction``: go on (a full battery crosses a shadow
  a half-empty one dies in; turning back half way costs as much as going on);
- in shadow, having entered it below that: walk back to the last lit spot, charge there, then cross;
- during a move from sunlight, entering shadow below that: stop the move at once, so the way back is short.

No power sensors (a world without a sun) means no advice at all: the behaviour is then exactly as before.
Pure standard library: this runs on the rover's flight computer.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from rover_agent.decisions import View

CHARGE = "charge"
LIT_SPOT_M = 1.0
"""Within this of the remembered lit spot and still in shadow, the spot is forgotten (the sun has moved on,
or dead reckoning has drifted): the rover goes on rather than pace in the dark."""


@dataclass
class SunSeeker:
    low: float
    full: float
    last_lit: tuple[float, float] | None = None
    shadow_entry: float | None = None  # charge when the rover first found itself in this shadow
    charging: bool = False
    turned_back: bool = False  # a move into shadow was cancelled for want of charge

    def advise(self, view: View) -> str | tuple[float, float] | None:
        """``CHARGE`` (hold here), a lander-frame point to walk back to, or None (carry on)."""
        if view.battery is None or view.sunlit is None:
            return None
        if view.sunlit:
            self.last_lit, self.shadow_entry = (view.pose.x, view.pose.z), None
            self.charging = (self.charging or view.battery < self.low) and view.battery < self.full
            return CHARGE if self.charging else None
        self.charging = False
        if self.shadow_entry is None:
            self.shadow_entry = view.battery
        if self.shadow_entry >= self.low or self.last_lit is None:
            return None
        if math.hypot(self.last_lit[0] - view.pose.x, self.last_lit[1] - view.pose.z) <= LIT_SPOT_M:
            self.last_lit = None
            return None
        return self.last_lit

    def should_turn_back(self, view: View) -> bool:
        """During a move that started in sunlight: the panel has just gone dark and the charge is low."""
        turn = (view.sunlit is False and view.battery is not None and view.battery < self.low
                and self.shadow_entry is None and self.last_lit is not None)
        self.turned_back = self.turned_back or turn
        return turn
