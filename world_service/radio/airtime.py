"""The radio's capacity: how many deliveries one sender's transmissions may make in a simulated second.

A real radio has a data rate, and a sender flooding it (a buggy agent, or one taken over) only fills its own
airtime. Without a bound, every flooded transmission would go on to every target, and the agents would fall tens of
seconds behind handling them. The bound is generous: twenty deliveries a second for every radio in the scenario, where a
mission's own traffic (the lander's calibration and direction to each rover once a second, a rover's estimate,
reports and photos) is a few.
"""

from __future__ import annotations

DELIVERIES_PER_S_PER_RADIO = 20


class Airtime:
    """A token bucket per sender, refilled with simulated time."""

    def __init__(self, radios: int, dt: float) -> None:
        self.rate = DELIVERIES_PER_S_PER_RADIO * radios * dt  # tokens a tick
        self.capacity = DELIVERIES_PER_S_PER_RADIO * radios  # a second's worth
        self.tokens: dict[int, float] = {}
        self.last: dict[int, int] = {}

    def take(self, sender: int, deliveries: int, tick: int) -> bool:
        """Whether ``sender`` may make ``deliveries`` on ``tick``; if so they are spent."""
        tokens = min(self.capacity, self.tokens.get(sender, self.capacity) + (tick - self.last.get(sender, tick)) *
                     self.rate)
        self.last[sender] = tick
        if deliveries > tokens:
            self.tokens[sender] = tokens
            return False
        self.tokens[sender] = tokens - deliveries
        return True
