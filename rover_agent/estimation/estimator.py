"""The agent's pose estimate: the filter (``pose_filter``) fed by the ends of actions, by what perception shows of
the lander, of teammates and of the rims of its crater goals (``sightings``), by the estimates teammates in radio
range tell (report 7.2.2) and, when the rover carries one, by a sun sensor's heading (``sun``);
and the way by the lander a rover too unsure for its next waypoint takes first (``lander_fix``).

``pose`` is the estimate's mean: everything that reads the rover's pose (the behaviour, the map, the saved state)
reads the corrected one.

When the rover corrects itself and talks:
- it corrects itself only standing still, between actions, where its estimate is the estimate of where it stands
  (no action in flight, perception taken after the last one ended);
- it tells its estimate to the rovers in range (``radio.PoseEstimate``) once a second, walking or not (a teammate
  sees it walking more often than standing: walking, it tells where its move has got to and when);
- it does either only once its estimate is uncertain at all: a rover without noise, or one just calibrated, has
  nothing to correct and nothing to tell, so noise-free missions send nothing new.

Apart from the radio, it reports its estimate on its own key (``EstimatedPose``) with the agent's periodic status,
for the ground and ROS 2's ``odom``: a few numbers a second, however sure it is, and no tick more for a lockstep
world to wait for.
"""

from __future__ import annotations

import logging
import math

from bus.rejections import Rejections
from rover_agent.actions.in_flight import InFlight
from rover_agent.decisions import Goal, Hit, MoveTo, Rotate
from rover_agent.estimation import rim_look
from rover_agent.estimation.fix_search import FixSearch
from rover_agent.estimation.lander_fix import LanderFix
from rover_agent.estimation.pose_filter import Localisation, NoiseModel
from rover_agent.estimation.sightings import (
    ESTIMATE_MAX_AGE_S,
    FORGET_AFTER_S,
    MAX_RIM_RMS_M,
    ROVER_SIGHTING_STD_M,
    Teammate,
    lander_centre,
    lander_landmark,
    match_teammates,
    rim_centre,
    rim_landmark,
    rover_centres,
    teammate_landmark,
    teammate_spread,
)
from schemas import keyspace as ks
from schemas import messages as m
from schemas import radio
from schemas.params import RoverParams
from schemas.scenario_limits import MAX_ROVERS
from shared.pose import Pose

log = logging.getLogger("lunarsim.rover")

NOT_FROM_TEAMMATES = ("climbing", "observing")
"""States in which a rover takes no correction from teammates: on a crater's rim it finds its goal by pitch,
wherever its estimate is, among rovers come for the same crest at close quarters, and there a correction only
turned it about among them (on the development seeds, rover collisions on rims came with such corrections). The
lander still corrects it there; teammates do again once it is off the rim."""
SHARE_PERIOD_S = 1.0
"""How often a rover tells its estimate. Every sample a rover hears by radio may make it answer, so a lockstep
world waits for its ack: told with every scan (5 Hz), estimates made each tick of a 5-rover mission wait for 2.7
agents on average instead of 1.7 (tests/unit/world_service/test_lockstep.py allows 2)."""
STILL_STATES = ("done", "relay", "stuck", "stopped")
"""A rover in these states stays where it is until it is given a new goal: its estimate holds until it says
otherwise. Any other may be walking by the time a teammate sees it, so its estimate counts as less sure by how far
it can have walked since (``sightings.teammate_landmark``)."""

MAX_RIM_FITS = 4
"""Rim radii one scan fits at most (``Estimator._rim_seen``): a plan's craters seldom crowd one view."""


class Estimator:
    def __init__(self, rover_id: int, params: RoverParams, rejected: Rejections) -> None:
        self.rover_id = rover_id
        self.params = params
        self.rejected = rejected
        self.localisation: Localisation | None = None
        """The filter, once the rover knows where it stands (calibrated, dispatched or resumed)."""
        self.teammates: dict[int, Teammate] = {}
        """Each teammate's latest estimate of itself, heard by radio."""
        self.fix = LanderFix()
        self.search = FixSearch()
        self.sure_at: tuple[float, float] | None = None
        """Where the estimate was last sure (``fix_search``): told where it stands, or fixed since."""
        self.shared_at = -math.inf
        """When the rover last told its estimate."""
        self.rims: dict[int, tuple[float, float, float]] = {}
        """The craters of the crater goals given so far (``learn``), by goal index."""
        self.looked_back: set[int] = set()
        """Goal indexes of craters whose rim the rover has turned to look at on leaving (``look_back``)."""
        self.sun_due = False
        """An action has ended since the last sun sensor reading was fused (``sun``)."""

    @property
    def pose(self) -> Pose | None:
        return self.localisation.pose if self.localisation is not None else None

    def place(self, pose: Pose | None) -> None:
        """Where the rover is told it stands (its calibration, its planned dispatch): exactly there."""
        self.localisation = None if pose is None else Localisation(pose, NoiseModel.of(self.params.navigation))
        self.sure_at = None if pose is None else (pose.x, pose.z)

    def note_sure(self) -> None:
        """Keep where the rover stands as its last sure place when its estimate is sure enough to stop a search
        for a fix there (``fix_search.DONE_STD_SHARE``)."""
        loc, radius = self.localisation, self.params.perception.perception_radius
        if loc is not None and self.search.sure(loc, radius):
            self.sure_at = (loc.pose.x, loc.pose.z)

    def resume(self, pose: Pose, cov: list[list[float]] | None) -> None:
        """Where a restarted agent saved it stood, as sure as it was."""
        self.localisation = Localisation(pose, NoiseModel.of(self.params.navigation), cov)

    def completed(self, start: Pose, decision: MoveTo | Rotate) -> None:
        """A move or rotate that started at ``start`` has ended as asked."""
        loc, self.sun_due = self._from(start), True
        if isinstance(decision, MoveTo):
            loc.moved(start, decision.x, decision.z)
        else:
            loc.rotated(start, decision.degrees)

    def stopped_early(self, start: Pose, x: float, z: float, angle_deg: float) -> None:
        """A move that started at ``start`` stopped where its ``CancelResult`` says."""
        self._from(start).stopped_early(start, x, z, angle_deg)
        self.sun_due = True

    def _from(self, start: Pose) -> Localisation:
        """The estimate an action's end moves (one at the action's start if the agent had none)."""
        if self.localisation is None:
            self.place(start)
        return self.localisation

    def localise(self, stamp: float, hits: tuple[Hit, ...], state: str, partners: list[int]) -> None:
        """Correct the estimate with the lander and the teammates in this scan, taken standing still in ``state``."""
        loc = self.localisation
        if loc is None or loc.exact:
            return
        centre = lander_centre(hits)
        if centre is not None:  # the only thing of its kind: no match to doubt, so no gate
            loc.observe(lander_landmark(centre), gate=None)
        if self.rims and any(h.kind == "crater_terrain" for h in hits):
            self._rim_seen(loc, hits)
        if not self.teammates or state in NOT_FROM_TEAMMATES:
            return
        p = self.params
        centres = rover_centres(hits, p.behaviour.rover_radius, p.perception.ray_step_deg)
        top_speed = max(p.navigation.speed(level) for level in (1, 2, 3))
        mates = list(self.teammates.values())
        gauge = loc.shared_gauge(ROVER_SIGHTING_STD_M)

        def distances(seen: list[tuple[float, float]], known: list[Teammate]) -> list[list[float]]:
            """``loc.mahalanobis(teammate_landmark(centre, mate, ...))`` for every pair, at a fraction of its cost."""
            return gauge.table(seen, [((t.estimate.x, t.estimate.z), teammate_spread(t, stamp, top_speed))
                                      for t in known])

        for seen, mate in match_teammates(centres, mates, partners, stamp, p.communication.comm_range, distances):
            loc.observe(teammate_landmark(seen, mate, stamp, top_speed))

    def sun(self, heading_deg: float) -> None:
        """Correct the heading with a sun sensor reading taken standing still, one a stop: the agent hands the
        latest reading taken since the action ended; more readings of the same stop would add no news of the
        heading the next action turns, only trust in one reading's error (a real sensor's readings of one stop
        share its mounting and the sun's tabled azimuth)."""
        loc = self.localisation
        if loc is None or loc.exact or not self.sun_due:
            return
        self.sun_due = False
        loc.observe_heading(heading_deg, self.params.perception.sun_sensor_noise_std_deg)

    def learn(self, goal: Goal) -> None:
        """Keep a crater goal's crater (``Goal.rim``): its rim, seen from outside, fixes the estimate on the way
        to it and on from it, far from the lander."""
        if goal.rim is not None:
            self.rims[goal.index] = goal.rim

    def look_back(self, goal: Goal | None, radius: float) -> float | None:
        """The turn (degrees) to face the rim of a crater goal left behind, once, when the rover stands just outside
        it (``rim_look.turn``); None: no look due."""
        loc = self.localisation
        if loc is None or goal is None:
            return None
        due = rim_look.turn(loc, self.rims, goal.index, self.looked_back, radius)
        if due is None:
            return None
        index, turn = due
        self.looked_back.add(index)
        return turn

    def _rim_seen(self, loc: Localisation, hits: tuple[Hit, ...]) -> None:
        """Correct the estimate with the rim of a known crater in view: the one whose fitted centre lies nearest
        where the estimate expects it (gated: crater terrain of a crater not in the plan fits none).

        A fit depends only on the hits and the rim's radius, so it is made once a radius, and only for rims whose
        sighting could pass the gate: a fitted centre lies within the farthest hit plus the radius and the
        largest residual a fit may have. A fit of 4,096 hits takes tens of milliseconds, so a scan fits at most
        ``MAX_RIM_FITS`` radii, those of the rims nearest the estimate: the rims a rover keeps, which the lander
        names, do not set the cost of its every scan."""
        farthest = max((h.distance_m for h in hits if h.kind == "crater_terrain"), default=0.0)
        rims = [rim for rim in set(self.rims.values())
                if loc.may_pass(rim_landmark((0.0, 0.0), rim), farthest + rim[2] + MAX_RIM_RMS_M)]
        radii: dict[float, None] = {}
        for rim in sorted(rims, key=lambda rim: math.dist((loc.pose.x, loc.pose.z), rim[:2]) - rim[2]):
            if len(radii) == MAX_RIM_FITS:
                break
            radii[rim[2]] = None
        fits = {radius: rim_centre(hits, radius) for radius in radii}
        marks = [rim_landmark(centre, rim) for rim in rims if (centre := fits.get(rim[2])) is not None]
        if marks:
            loc.observe(min(marks, key=loc.mahalanobis))

    def heard(self, sender: int, estimate: radio.PoseEstimate, now: float) -> None:
        """Keep a teammate's latest estimate. Dropped, and counted as rejected: one from the lander, from this
        rover or from an id no rover has; one stamped ahead of this rover's clock (kept, it would be fresh for
        ever and shut the sender's real ones out as older); one older than the sender's last. Estimates older than
        ``FORGET_AFTER_S`` go, so a flood of senders cannot pile up."""
        why = None
        if sender == ks.LANDER_ID or sender == self.rover_id or not 1 <= sender <= MAX_ROVERS:
            why = f"from {sender}, not a teammate"
        elif estimate.stamp > now + ESTIMATE_MAX_AGE_S:
            why = f"stamped {estimate.stamp:.1f}, ahead of the clock ({now:.1f})"
        elif (known := self.teammates.get(sender)) is not None and estimate.stamp < known.estimate.stamp:
            why = f"stamped {estimate.stamp:.1f}, older than the last one ({known.estimate.stamp:.1f})"
        if why is not None:
            self.rejected.count("pose_estimate", why)
            log.debug("rover %d: dropped a pose estimate %s", self.rover_id, why)
            return
        self.teammates = {rid: mate for rid, mate in self.teammates.items()
                          if now - mate.estimate.stamp <= FORGET_AFTER_S}
        self.teammates[sender] = Teammate(sender, estimate)

    def share(self, now: float, partners: list[int], state: str,
              flight: InFlight | None) -> tuple[list[int], radio.PoseEstimate] | None:
        """The estimate, and the rovers in range to tell it to, once it is uncertain at all (see the module's
        docstring); during a move, where the move has got to."""
        loc = self.localisation
        rovers = [p for p in partners if p != ks.LANDER_ID and p != self.rover_id]
        if loc is None or loc.exact or not rovers:
            return None
        if now - self.shared_at < SHARE_PERIOD_S - 1e-9:
            return None
        self.shared_at = now
        pose, cov, stamp = loc.pose, loc.cov, now
        moving = flight is not None or state not in STILL_STATES
        if flight is not None and isinstance(flight.decision, MoveTo):
            pose, cov = loc.part_way(flight.start, flight.decision.x, flight.decision.z, flight.walked)
            stamp = max(flight.walked_at, flight.sent_at)
        try:
            estimate = radio.PoseEstimate(stamp=stamp, x=round(pose.x, 3), z=round(pose.z, 3),
                                          cov_xx=round(cov[0][0], 6), cov_xz=round(cov[0][1], 6),
                                          cov_zz=round(cov[1][1], 6), moving=moving)
        except ValueError as exc:  # an estimate past what the message carries: untold, rather than a crash
            log.warning("rover %d: pose estimate not told: %s", self.rover_id, exc)
            return None
        return rovers, estimate

    def report(self, now: float, flight: InFlight | None) -> m.EstimatedPose | None:
        """The estimate for the rover's own key (see the module's docstring); during a move, where it has got to."""
        loc = self.localisation
        if loc is None:
            return None
        pose, cov = loc.pose, loc.cov
        if flight is not None and isinstance(flight.decision, MoveTo):
            pose, cov = loc.part_way(flight.start, flight.decision.x, flight.decision.z, flight.walked)
        try:
            return m.EstimatedPose(stamp=max(0.0, now), x=pose.x, z=pose.z, heading_deg=pose.heading % 360.0,
                                   cov_xx=cov[0][0], cov_xz=cov[0][1], cov_zz=cov[1][1], cov_xh=cov[0][2],
                                   cov_zh=cov[1][2], cov_hh=cov[2][2], moving=flight is not None)
        except ValueError as exc:  # past what the message carries: unreported, rather than a crash
            log.warning("rover %d: pose estimate not reported: %s", self.rover_id, exc)
            return None

    # ---- the way by the lander ----

    def mind_fix(self, goal: Goal) -> str | None:
        """Before a decision towards ``goal``: "detour" (take up, or begin again, a way by the lander: walk to
        ``fix.goal``), "over" (fixed: on to the rover's own goal) or None (as it was)."""
        loc = self.localisation
        if loc is None:
            return None
        if self.fix.fixed(loc):
            return "over"
        if self.fix.sharpened(loc) or self.fix.consider(goal, loc, self.params):
            return "detour"
        return None

    def fix_arrived(self, outcome: str) -> str:
        """A leg of the way by the lander is over and the estimate not yet fixed: "look", "search" or "over"
        (``LanderFix.arrived``)."""
        loc = self.localisation
        return self.fix.arrived(outcome, (loc.pose.x, loc.pose.z), self.params.perception.perception_radius,
                                loc.position_std if loc else 0.0)

    # ---- the search for a fix at the goal ----

    def search_leg(self, goal: Goal, now: float, begins: bool) -> bool:
        """At ``goal`` by an estimate it knows to be unsure: begin a search for a fix (``begins``), or go on to its
        next leg; False: no search, or it is over (``fix_search``)."""
        loc, radius = self.localisation, self.params.perception.perception_radius
        if begins:
            return self.search.wanted(goal, loc, radius) and self.search.begin(
                goal, loc, now, self.teammates, self.sure_at, radius)
        return loc is not None and self.search.next_leg(goal, loc, now, self.teammates, self.sure_at, radius)

    def search_over(self, now: float) -> bool:
        """Searching, and sure again or out of time."""
        return self.search.over(self.localisation, now, self.params.perception.perception_radius)
