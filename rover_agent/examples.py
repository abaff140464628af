"""An example behaviour, about as short as a working one gets: the template for writing your own.

``StraightLine`` heads for the goal: it turns to face it, walks up to 5 m at a time while the way ahead is
clear, and when it is not, turns 45 degrees right and walks a few metres before aiming again. It finishes
when the goal is within half its perception radius, and never observes craters. Select it with
``behaviour: straight`` in a scenario, or ``--behaviour straight``.

``SunIgnoring`` shows the other way to write one: a subclass of the default behaviour changing one trait.
"""

from __future__ import annotations

import math
from typing import ClassVar

from rover_agent.behaviour import DefaultBehaviour
from rover_agent.decisions import BaseBehaviour, Decision, Finish, MoveTo, Rotate, View
from schemas.frames import bearing_deg, wrap_deg

SIDESTEP_M = 3.0


class StraightLine(BaseBehaviour):
    name = "straight"

    def __init__(self, rover_id, params) -> None:
        super().__init__(rover_id, params)
        self.sidestep = False

    def decide(self, view: View) -> Decision:
        pose, goal = view.pose, view.goal
        distance = math.hypot(goal.x - pose.x, goal.z - pose.z)
        if distance <= 0.5 * self.params.perception.perception_radius:
            return Finish("reached")
        clear = self._clear_ahead(view)
        if self.sidestep and clear >= SIDESTEP_M:
            self.sidestep = False
            return MoveTo(0.0, SIDESTEP_M)
        to_goal = wrap_deg(bearing_deg(goal.x - pose.x, goal.z - pose.z) - pose.heading)
        if abs(to_goal) > 5:
            return Rotate(round(to_goal, 3))
        step = min(5.0, distance, clear)
        if step >= 1.0:
            return MoveTo(0.0, round(step, 3))
        self.sidestep = True
        return Rotate(45.0)

    @staticmethod
    def _clear_ahead(view: View) -> float:
        """Metres straight ahead before something solid (keeping 1.5 m from it)."""
        ahead = [h.distance_m - 1.5 for h in view.hits if abs(h.angle_deg) < 15 and h.kind != "crater_terrain"]
        return min([10.0, *ahead])


class SunIgnoring(DefaultBehaviour):
    """The default behaviour blind to its power sensors: it walks into shadow whatever its charge (the
    comparison of ``scenarios/polar_night_edge.yaml``)."""

    name = "sun_ignoring"
    uses_sunlight: ClassVar[bool] = False
