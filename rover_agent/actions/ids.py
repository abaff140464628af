"""Action ids: each action an agent sends takes the next one, and an agent never reuses an id of an earlier life."""

from __future__ import annotations

from schemas.wire_limits import ACTION_ID_STRIDE


class ActionIds:
    def __init__(self, next_id: int = 0) -> None:
        self.next_id = next_id
        self.renewing = next_id == 0

    def take(self, now: float) -> int:
        if self.renewing:
            self.next_id, self.renewing = max(self.next_id, _first_id(now)), False
        action_id, self.next_id = self.next_id, self.next_id + 1
        return action_id

    def renew(self) -> None:
        """Go on from ids based on the time of the next action: above every id of an earlier life of this agent
        (based on an earlier millisecond), which the world has when it refuses one of these as stale."""
        self.renewing = True


def _first_id(now: float) -> int:
    """Based on the simulated millisecond (``schemas.wire_limits.ACTION_ID_STRIDE``): an agent restarted without its
    saved state never reuses an id of its earlier life, which the world would answer with the end of an old
    action."""
    return max(0, int(now * 1000)) * ACTION_ID_STRIDE + 1
