"""What a rover's status says beyond its state: the one line the ground reads of why it stands where it does,
where it is going instead of its goal, or how far off its estimate may be."""

from __future__ import annotations

from rover_agent.estimation import lander_fix
from rover_agent.estimation.estimator import Estimator
from rover_agent.mission.goals import Mission
from rover_agent.restarts.resume import Restarts
from rover_agent.senses import Senses


def status_detail(state: str, mission: Mission, estimator: Estimator, senses: Senses, restarts: Restarts,
                  perception_radius: float) -> str:
    """The detail of ``RoverStatus``: the latest that applies of what it says of the goal, of being off, lost,
    seeking the lander's word or going by the lander."""
    detail = "another rover found the crater" if mission.goal_index in mission.craters_found else ""
    if state == "done" and not detail:
        detail = lander_fix.unsure_detail(estimator.localisation, perception_radius)
    if state == "stuck":
        detail = mission.stuck_why
    if senses.powered_off:
        detail = senses.off_detail
    if restarts.lost:
        detail = f"{restarts.lost_why}: position unknown"
    elif mission.contact.seeking:
        detail = mission.contact.detail
    elif estimator.fix.active:
        detail = lander_fix.DETAIL
    elif estimator.search.active:
        detail = estimator.search.detail
    return detail


def walking_cause(mission: Mission, estimator: Estimator) -> str:
    """What the rover walks for now: "contact" (seeking the lander's word), "lander fix" (going by the lander
    before its goal), "fix search" (unsure at its goal), "relay" (to a daisy chain's spot) or "goal"."""
    if mission.contact.seeking:
        return "contact"
    if estimator.fix.active:
        return "lander fix"
    if estimator.search.active:
        return "fix search"
    if mission.goal is not None and mission.goal.kind == "relay":
        return "relay"
    return "goal"
