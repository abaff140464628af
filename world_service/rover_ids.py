"""Rover ids for agents started with ``lunarsim rover --id auto`` (containers scaled with ``--scale rover=N``).

The world is the one process that knows the scenario's rovers, so it hands the ids out: the lowest id that
no live agent holds (liveliness token) and no recent grant reserves. A grant is reserved for a while, so two
agents starting together never get the same id; a requester asking again (same Zenoh id) gets its id back.
"""

from __future__ import annotations

import threading
import time
from collections.abc import Callable, Iterable

from schemas import messages as m

RESERVE_S = 20.0
"""How long a granted id waits for its agent's liveliness token before it is handed out again."""


class IdDesk:
    def __init__(self, ids: Iterable[int], clock: Callable[[], float] = time.monotonic) -> None:
        self.ids = sorted(ids)
        self.clock = clock
        self.held: set[int] = set()
        self.granted: dict[str, tuple[int, float]] = {}  # requester -> (id, when)
        self._lock = threading.Lock()  # grants are answered on Zenoh's thread, liveliness on the world's

    def note_alive(self, rover_id: int, alive: bool) -> None:
        with self._lock:
            if alive:
                self.held.add(rover_id)
                self.granted = {who: g for who, g in self.granted.items() if g[0] != rover_id}  # it has come
            else:
                self.held.discard(rover_id)

    def grant(self, requester: str) -> m.RoverIdGrant:
        with self._lock:
            now = self.clock()
            self.granted = {who: (rid, t) for who, (rid, t) in self.granted.items() if now - t < RESERVE_S}
            if requester in self.granted:
                return m.RoverIdGrant(id=self.granted[requester][0], detail="granted before")
            reserved = {rid for rid, _ in self.granted.values()}
            free = [rid for rid in self.ids if rid not in self.held and rid not in reserved]
            if not free:
                return m.RoverIdGrant(id=None, detail=f"all {len(self.ids)} rovers of the scenario have an agent")
            self.granted[requester] = (free[0], now)
            return m.RoverIdGrant(id=free[0])
