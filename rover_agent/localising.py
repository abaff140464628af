"""How a rover agent keeps its pose estimate (``rover_agent.localisation``): each action's end moves it, what
perception shows of the lander and of teammates corrects it, teammates in radio range hear it (report 7.2.2),
and a rover too unsure for its next waypoint goes by the lander first (``rover_agent.relocalise``).

A mixin of ``RoverAgent`` (its state: ``params``, ``in_flight``, ``partners``, ``now``...), kept apart so the
agent's own module stays about its inputs and decisions. ``pose`` is the estimate's mean: everything that read the
dead-reckoned pose (the behaviour, the map, the saved state) reads the corrected one.

When the rover corrects itself and talks:
- it corrects itself only standing still, between actions, where its estimate is the estimate of where it stands
  (no action in flight, perception taken after the last one ended);
- it tells its estimate to the rovers in range (``radio.PoseEstimate``) once a second, walking or not (a teammate
  sees it walking more often than standing: walking, it tells where its move has got to and when);
- it does either only once its estimate is uncertain at all: a rover without noise, or one just calibrated, has
  nothing to correct and nothing to tell, so noise-free missions send nothing new and run as before.
"""

from __future__ import annotations

import logging
import math

from rover_agent.dead_reckoning import Pose
from rover_agent.decisions import Hit, MoveTo, Rotate
from rover_agent.localisation import Localisation, NoiseModel
from rover_agent.relocalise import LanderFix
from rover_agent.sightings import (
    ESTIMATE_MAX_AGE_S,
    Teammate,
    lander_centre,
    lander_landmark,
    match_teammates,
    rover_centres,
    teammate_landmark,
)
from schemas import keyspace as ks
from schemas import radio
from schemas.scenario_limits import MAX_ROVERS

log = logging.getLogger("lunarsim.rover")

NOT_FROM_TEAMMATES = ("climbing", "observing")
"""States in which a rover takes no correction from teammates: on a crater's rim it finds its goal by pitch,
wherever its estimate is, among rovers come for the same crest at close quarters, and there a correction only
turned it about among them (on the development seeds, rover collisions on rims came with such corrections). The
lander still corrects it there; teammates do again once it is off the rim."""


SHARE_PERIOD_S = 1.0
"""How often a rover tells its estimate. Every sample a rover hears by radio may make it answer, so a lockstep
world waits for its ack: told with every scan (5 Hz), estimates made each tick of a 5-rover mission wait for 2.7
agents on average instead of 1.7 (tests/test_lockstep.py allows 2)."""
FORGET_AFTER_S = 2 * ESTIMATE_MAX_AGE_S
"""A teammate's estimate older than this is forgotten: never matched again (``sightings.match_teammates``), and
a flood of senders must not pile up."""
STILL_STATES = ("done", "relay", "stuck", "stopped")
"""A rover in these states stays where it is until it is given a new goal: its estimate holds until it says
otherwise. Any other may be walking by the time a teammate sees it, so its estimate counts as less sure by how far
it can have walked since (``sightings.teammate_landmark``)."""


class Localising:
    localisation: Localisation | None = None
    fix: LanderFix
    shared_at: float = -math.inf  # when the rover last told its estimate

    @property
    def pose(self) -> Pose | None:
        return self.localisation.pose if self.localisation is not None else None

    @pose.setter
    def pose(self, pose: Pose | None) -> None:
        """Where the rover is told it stands (its calibration, its planned dispatch): exactly there."""
        self.localisation = None if pose is None else Localisation(pose, NoiseModel.of(self.params.navigation))

    def _estimate(self, start: Pose) -> Localisation:
        """The estimate an action's end moves (one at the action's start if the agent had none)."""
        if self.localisation is None:
            self.pose = start
        return self.localisation

    def _resume_estimate(self, pose: Pose, cov: list[list[float]] | None) -> None:
        self.localisation = Localisation(pose, NoiseModel.of(self.params.navigation), cov)

    def _localise(self, stamp: float, hits: tuple[Hit, ...]) -> None:
        """Correct the estimate with the lander and the teammates in this scan, taken standing still."""
        loc = self.localisation
        if loc is None or loc.exact:
            return
        centre = lander_centre(hits)
        if centre is not None:  # the only thing of its kind: no match to doubt, so no gate
            loc.observe(lander_landmark(centre), gate=None)
        if not self.teammates or self.state in NOT_FROM_TEAMMATES:
            return
        p = self.params
        centres = rover_centres(hits, p.behaviour.rover_radius, p.perception.ray_step_deg)
        top_speed = max(p.navigation.speed(level) for level in (1, 2, 3))
        mates = list(self.teammates.values())

        def distance(seen: tuple[float, float], mate: Teammate) -> float:
            return loc.mahalanobis(teammate_landmark(seen, mate, stamp, top_speed))

        for seen, mate in match_teammates(centres, mates, self.partners, stamp, p.communication.comm_range, distance):
            loc.observe(teammate_landmark(seen, mate, stamp, top_speed))

    def _mind_fix(self) -> None:
        """Before a decision: take up, or end, a way by the lander to fix the estimate (``relocalise``)."""
        loc, goal = self.localisation, self.goal
        if loc is None or goal is None or self.finished_goal is not None or self.contact.seeking:
            return
        if self.fix.fixed(loc):
            self._fix_over()
        elif self.fix.sharpened(loc) or self.fix.consider(goal, loc, self.params):
            self.behaviour.start_goal(self.fix.goal)

    def _fix_arrived(self, outcome: str) -> list:
        """A leg of the way by the lander is over and the estimate not yet fixed: turn round to look, go on to the
        next spot of the search, or give up and go on to the rover's own goal (``LanderFix.arrived``)."""
        step = self.fix.arrived(outcome, (self.pose.x, self.pose.z), self.params.perception.perception_radius,
                                self.localisation.position_std if self.localisation else 0.0)
        if step == "look":
            return self._act(Rotate(180.0))
        if step == "search":
            self.behaviour.start_goal(self.fix.goal)
        else:
            self._fix_over()
        return [self._status()]

    def _fix_over(self) -> None:
        """Fixed, or where the lander was thought to be: on to the rover's own goal."""
        self.fix.active = False
        if self.goal is not None:
            self.behaviour.start_goal(self.goal)

    def _heard_estimate(self, sender: int, estimate: radio.PoseEstimate) -> None:
        """Keep a teammate's latest estimate. Dropped, and counted as rejected: one from the lander, from this
        rover or from an id no rover has; one stamped ahead of this rover's clock (kept, it would be fresh for
        ever and shut the sender's real ones out as older); one older than the sender's last. Estimates too old to
        be matched go, so a flood of senders cannot pile up."""
        why = None
        if sender == ks.LANDER_ID or sender == self.id or not 1 <= sender <= MAX_ROVERS:
            why = f"from {sender}, not a teammate"
        elif estimate.stamp > self.now + ESTIMATE_MAX_AGE_S:
            why = f"stamped {estimate.stamp:.1f}, ahead of the clock ({self.now:.1f})"
        elif (known := self.teammates.get(sender)) is not None and estimate.stamp < known.estimate.stamp:
            why = f"stamped {estimate.stamp:.1f}, older than the last one ({known.estimate.stamp:.1f})"
        if why is not None:
            self.rejected.count("pose_estimate", why)
            log.debug("rover %d: dropped a pose estimate %s", self.id, why)
            return
        self.teammates = {rid: mate for rid, mate in self.teammates.items()
                          if self.now - mate.estimate.stamp <= FORGET_AFTER_S}
        self.teammates[sender] = Teammate(sender, estimate)

    def _share_estimate(self) -> list:
        """The estimate, to the rovers in range, once it is uncertain at all (see the module's docstring)."""
        loc = self.localisation
        rovers = [p for p in self.partners if p != ks.LANDER_ID and p != self.id]
        if loc is None or loc.exact or not rovers or self.lost or self.powered_off:
            return []
        if self.now - self.shared_at < SHARE_PERIOD_S - 1e-9:
            return []
        self.shared_at = self.now
        flight = self.in_flight
        pose, cov, stamp = loc.pose, loc.cov, self.now
        moving = flight is not None or self.state not in STILL_STATES
        if flight is not None and isinstance(flight.decision, MoveTo):
            pose, cov = loc.part_way(flight.start, flight.decision.x, flight.decision.z, flight.walked)
            stamp = max(flight.walked_at, flight.sent_at)
        try:
            estimate = radio.PoseEstimate(stamp=stamp, x=round(pose.x, 3), z=round(pose.z, 3),
                                          cov_xx=round(cov[0][0], 6), cov_xz=round(cov[0][1], 6),
                                          cov_zz=round(cov[1][1], 6), moving=moving)
        except ValueError as exc:  # an estimate past what the message carries: untold, rather than a crash
            log.warning("rover %d: pose estimate not told: %s", self.id, exc)
            return []
        return [self._radio(rovers, estimate)]

    def _walking(self, stamp: float, remaining: float) -> None:
        """A running move's status: how far along it the rover has got (the world says what is still to go)."""
        flight = self.in_flight
        if flight is not None and isinstance(flight.decision, MoveTo):
            flight.walked = max(0.0, math.hypot(flight.decision.x, flight.decision.z) - remaining)
            flight.walked_at = stamp
