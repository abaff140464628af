"""Whether the rover agents keep up with the world's clock, judged from their status (``lunarsim run`` says so).

In real time the agents run below the world's priority (``bus.priority``): on a machine short of CPU the
world keeps its pace and the agents fall behind it, where at equal priority the world itself would slow down.
An agent behind the world decides on old samples, as a slow flight computer would, which a user should know.
A status carries the agent's own time (the newest stamp it has handled); the world's time comes from its
statistics, once a simulated second, so a lag is never over-stated.
"""

from __future__ import annotations

LAG_WARNING_S = 2.0
"""Simulated seconds an agent may be behind the world before the launcher warns. A status goes out once a
second and the world's time is known to the second, so a smaller lag says little."""


class AgentLag:
    def __init__(self, limit_s: float = LAG_WARNING_S) -> None:
        self.limit_s = limit_s
        self.world_time: float | None = None
        self.worst: dict[int, float] = {}
        """Rovers whose agent was ever more than ``limit_s`` behind: the most it was."""

    def world(self, sim_time: float) -> None:
        self.world_time = sim_time if self.world_time is None else max(self.world_time, sim_time)

    def status(self, rover_id: int, stamp: float) -> bool:
        """Note a rover's status; True the first time any agent is found behind (the moment to warn)."""
        if self.world_time is None or self.world_time - stamp <= self.limit_s:
            return False
        first = not self.worst
        self.worst[rover_id] = max(self.worst.get(rover_id, 0.0), self.world_time - stamp)
        return first

    def summary(self) -> str | None:
        if not self.worst:
            return None
        ids = sorted(self.worst)
        shown = ", ".join(map(str, ids[:10])) + (f" and {len(ids) - 10} more" if len(ids) > 10 else "")
        return (f"{len(ids)} rover agent(s) fell more than {self.limit_s:g} s behind the world's clock (rover "
                f"{shown}; up to {max(self.worst.values()):.1f} s)")
