"""The world's side of the control-loop benchmark (``benchmarks/control_loop_latency.py``): what the world service
and the lander's radio would send one rover, scripted, so that rover keeps walking and deciding loop after loop.
Pure: both the loop over Zenoh and the one in process feed its messages to the agent."""

from __future__ import annotations

import math

from schemas import keyspace as ks
from schemas import messages as m
from schemas.frames import bearing_deg, to_world
from schemas.wire_limits import INDEX_LIMIT

RUN = "bench"
"""The run the scripted clock names: an agent acts on its sensors only once it has heard its run's clock."""
LOOP_DT_S = 0.2
"""Simulated seconds per loop: Perception at t, action over at t + LOOP_DT_S / 2, next Perception at t + LOOP_DT_S."""
GOAL_AHEAD_M = 100.0
RETARGET_BELOW_M = 50.0
"""When the rover's dead-reckoned distance to the waypoint drops below this, the world moves it GOAL_AHEAD_M on."""
GOALS_TOTAL = INDEX_LIMIT - 1
"""Large enough that no goal is ever the final one (the agent would stop deciding)."""


class ScriptedWorld:
    """Produces what the world (and the lander's radio) would send, and follows the rover's dead reckoning."""

    def __init__(self) -> None:
        self.t = 0.0
        self.x, self.z, self.heading = 0.0, 0.0, 0.0  # the Calibration below: at the lander, facing +z
        self.goal_index = 0
        self.goal = (0.0, GOAL_AHEAD_M)

    def clock(self) -> m.Clock:
        """The run's first clock, stopped: the agent joins the run, and its timers stay quiet."""
        return m.Clock(tick=0, sim_time=0.0, time_scale=1.0, running=False, run=RUN)

    def setup(self) -> list[tuple[str, m.Message]]:
        return [(ks.CALIBRATION, m.Calibration(x=self.x, z=self.z, heading_deg=self.heading)),
                (ks.MISSION_DIRECTION, self._mission_direction()),
                (ks.GYROSCOPE, m.Gyroscope(stamp=self.t, pitch_deg=0.0))]

    def perception(self) -> m.Perception:
        self.t += LOOP_DT_S / 2
        return m.Perception(stamp=self.t, angles_deg=[], distances_m=[], kinds=[])

    def action_done(self, action: m.MoveAction) -> list[tuple[str, m.Message]]:
        """The move is over: what the world sends so the agent settles and will decide on the next Perception."""
        self._move(action.x, action.z)
        self.t += LOOP_DT_S / 2
        out: list[tuple[str, m.Message]] = []
        if math.hypot(self.goal[0] - self.x, self.goal[1] - self.z) < RETARGET_BELOW_M:
            h = math.radians(self.heading)
            self.goal = (self.x + GOAL_AHEAD_M * math.sin(h), self.z + GOAL_AHEAD_M * math.cos(h))
            self.goal_index += 1
            out.append((ks.MISSION_DIRECTION, self._mission_direction()))
        # settled_at becomes this stamp; the agent decides only on a gyroscope and a perception at or after it
        out.append((ks.NAVIGATION_STATUS, m.NavigationStatus(stamp=self.t, action="move", remaining=0.0,
                                                             outcome="completed", action_id=action.action_id)))
        out.append((ks.GYROSCOPE, m.Gyroscope(stamp=self.t, pitch_deg=0.0)))
        return out

    def _move(self, rel_x: float, rel_z: float) -> None:
        """Where a completed move leaves the rover: on its end point, facing along it (as its dead reckoning has it)."""
        x, z = to_world(self.x, self.z, self.heading, rel_x, rel_z)
        if math.hypot(rel_x, rel_z) > 1e-9:
            self.heading = bearing_deg(x - self.x, z - self.z)
        self.x, self.z = x, z

    def _mission_direction(self) -> m.MissionDirection:
        gx, gz = self.goal
        return m.MissionDirection(goal_index=self.goal_index, goals_total=GOALS_TOTAL, kind="waypoint",
                                  bearing_deg=bearing_deg(gx, gz), distance_m=math.hypot(gx, gz))

