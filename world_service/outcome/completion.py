"""When a mission is over: every rover finished, none moving, no photo still on its way to a lander there to take it.

A relay's state says it is finished, but at the last goal it may yet walk on to the goal
(``CommunicationParams.release_relays``): when the lander releases it, once the word that the last other rover is
done has come down the chain, or by itself once it has been cut off from the lander for ``relay_cut_off_s``. Both
run behind the rovers' own status, which the world hears at once: so with relays among the finished the mission
ends only once all have stayed finished for the cut-off and a margin (``relay_wait_s``), and is dated from when
they first were, so the wait changes no figure.
"""

from __future__ import annotations

from collections.abc import Callable

from schemas import messages as m
from schemas.params import RoverParams

FINISHED_STATES = ("done", "stuck", "stopped", "relay")
RELEASE_MARGIN_S = 5.0
"""Simulated seconds past the cut-off for a relay to set off: its next perception, or the lander's release, sent
again every second over a radio that may lose some."""


LANDER_GONE_S = 60.0
"""Simulated seconds without a lander agent after which a photo still on its way counts as one that will not
arrive: a lander that died would otherwise keep a mission whose rovers have all finished from ever ending (in
lockstep the world steps on without it, at full speed), and one that restarts is back well within it."""


def relay_wait_s(params: RoverParams) -> float:
    """How long relays among the finished keep a mission from ending: none if nothing can release them."""
    radio = params.communication
    return radio.relay_cut_off_s + RELEASE_MARGIN_S if radio.release_relays else 0.0


def all_finished(status: dict[int, m.RoverStatus], moving: dict[int, bool],
                 reaches_lander: Callable[[], dict[int, bool]], stalled: frozenset[int] = frozenset(),
                 lander_gone_s: float = 0.0) -> bool:
    """Every rover finished (or stalled: counted stuck by the world), none but a stalled one moving, and no photo
    still on its way to a lander it can reach. A stalled rover may go on moving (walking to and fro across a
    crater's bowl, say): that must not keep the mission from ending.

    ``reaches_lander`` (rover id -> has a radio route to the lander) is asked only when a photo is pending;
    ``lander_gone_s``: how long the lander agent has been away (``LANDER_GONE_S``).
    """
    if (not all(s.state in FINISHED_STATES or rid in stalled for rid, s in status.items())
            or any(busy for rid, busy in moving.items() if rid not in stalled)):
        return False
    pending = [rid for rid, s in status.items() if s.photos_pending]
    if not pending or lander_gone_s >= LANDER_GONE_S:
        return True
    reach = reaches_lander()
    return not any(reach.get(rid, False) for rid in pending)


class Completion:
    """The moment the mission ended, once it has (``at``)."""

    _lander_gone_at: float | None = None  # the lander agent away since then; a class default for older saved worlds

    def __init__(self, relay_wait: float = 0.0) -> None:
        self.relay_wait = relay_wait
        self.at: float | None = None
        self._since: float | None = None  # every rover finished since then, relays among them

    def note_lander(self, alive: bool, now: float) -> None:
        """The lander agent's liveliness (the world service's; a world stepped in process has its lander)."""
        if alive:
            self._lander_gone_at = None
        elif self._lander_gone_at is None:
            self._lander_gone_at = now

    def check(self, now: float, status: dict[int, m.RoverStatus], moving: dict[int, bool],
              reaches_lander: Callable[[], dict[int, bool]], stalled: frozenset[int] = frozenset()) -> None:
        if self.at is not None:
            return
        gone = 0.0 if self._lander_gone_at is None else now - self._lander_gone_at
        if not all_finished(status, moving, reaches_lander, stalled, gone):
            self._since = None
            return
        self._since = now if self._since is None else self._since
        if not any(s.state == "relay" for s in status.values()) or now - self._since >= self.relay_wait:
            self.at = self._since
