"""What the crowd and crater rules ask of the rover's walking: the default behaviour (``rover_agent.behaviour``)
walks, and hands itself to its rules as these interfaces."""

from __future__ import annotations

from typing import TYPE_CHECKING, Protocol

if TYPE_CHECKING:
    from collections.abc import Iterator

    from rover_agent.decisions import Decision, Hit, View


class Footing(Protocol):
    """Where the rover's body can go from where it stands, and the walking's memory of the way: the crowd rules'
    view of it."""

    @property
    def close_quarters(self) -> bool:
        """Short steps and small gaps: stop only for imminent contact."""

    def free_distance(self, angle: float, hits: tuple[Hit, ...]) -> float:
        """Metres the body can go along ``angle`` (degrees, rover-relative) before coming too close to a hit."""

    def candidates(self, to_goal: float, window: float) -> Iterator[float]:
        """Directions to try, nearest ``to_goal`` first, leaving out those the world refused."""

    def forget_refused(self) -> None:
        """Try again the directions the world refused from here (the rovers in them may have moved on)."""

    def route(self) -> None:
        """Follow a route planned on the map from now on, rather than heading straight for the goal."""


class Walking(Footing, Protocol):
    """Besides its footing, how the rover walks to a spot of its own and how far it has walked: the crater rules'
    view of it."""

    @property
    def odometer(self) -> float:
        """Metres walked since the behaviour began."""

    def head_for(self, view: View, distance: float, step: float | None) -> Decision:
        """A step towards ``view.goal``, ``distance`` metres off; ``step``: at most this long."""

    def pacing(self, distance: float, limit_m: float) -> bool:
        """Walked ``limit_m`` without getting closer than ``distance`` to the goal."""

    def climbing(self, from_spoke: bool) -> None:
        """Up a crater's rim from here: from the foot of a station's spoke, the way there is over too."""
