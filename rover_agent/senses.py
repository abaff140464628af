"""The rover's latest readings of itself and of its radio: pitch (and heading, with a sun sensor), battery,
temperature, sunlight, and which radios are in direct range (``CommPartners``). Power sensors come only from a
world with a sun. Each handler answers nothing: what the readings mean is for the agent's next decision."""

from __future__ import annotations

from dataclasses import dataclass, field

from schemas import messages as m
from schemas.messages import Out


@dataclass
class Senses:
    pitch: tuple[float, float] = (0.0, -1.0)
    """(degrees, stamp)."""
    heading: tuple[float, float] | None = None
    """The sun sensor's latest heading reading (degrees, stamp); None without a sun sensor."""
    battery: m.Battery | None = None
    temperature: m.Temperature | None = None
    sunlit: bool | None = None
    partners: list[int] = field(default_factory=list)

    def on_battery(self, msg: m.Battery) -> list[Out]:
        self.battery = msg
        return []

    def on_temperature(self, msg: m.Temperature) -> list[Out]:
        self.temperature = msg
        return []

    def on_sun(self, msg: m.Sunlight) -> list[Out]:
        self.sunlit = msg.lit
        return []

    def on_comm_partners(self, msg: m.CommPartners) -> list[Out]:
        self.partners = msg.ids
        return []

    @property
    def charge(self) -> float | None:
        """The battery's charge as a share of its capacity; None without power sensors."""
        return self.battery.fraction if self.battery is not None else None

    @property
    def powered_off(self) -> bool:
        """The battery is empty or the rover too cold: it can do nothing until the world says it is back."""
        return bool((self.battery and self.battery.empty) or (self.temperature and self.temperature.shutdown))

    @property
    def off_detail(self) -> str:
        return "off: battery empty" if self.battery and self.battery.empty else "off: too cold"
