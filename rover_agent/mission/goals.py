"""The rover's part of the mission plan: the goal it is on (from the lander's mission direction), the goal it
finished and how, what the lander has been told of it, and what the rover does while the lander is silent
(``contact``) or while it holds a daisy chain's relay spot (``relay``)."""

from __future__ import annotations

import logging
import math

from rover_agent.decisions import Goal, Hit
from rover_agent.mission.contact import ContactSearch
from rover_agent.mission.relay import Relay
from rover_agent.mission.stations import StationAsk
from schemas import messages as m
from schemas import radio
from schemas.params import RoverParams
from shared.pose import Pose

log = logging.getLogger("lunarsim.rover")

GOAL_REPORT_RETRY_S = 2.0
"""A finished goal is told the lander again this often until the next direction comes."""


class Mission:
    def __init__(self, rover_id: int, params: RoverParams, dispatch: m.Calibration | None = None) -> None:
        self.rover_id = rover_id
        self.params = params
        self.goal: Goal | None = None
        self.finished_goal: tuple[int, str] | None = None
        """(index, outcome) reported but not yet followed up."""
        self.stuck_why = ""
        """What stopped it, from the behaviour (``Finish.why``), shown in its status."""
        self.contact = ContactSearch(rover_id, dispatch)
        self.relay = Relay()
        self.stations = StationAsk()
        self.craters_found: set[int] = set()
        """Shared crater goals another rover has reached."""
        self.reported_at = -math.inf

    def joined(self, sim_time: float) -> None:
        """The first clock of a run: the lander's silence is counted from here."""
        self.contact.heard_at = sim_time

    @property
    def goal_index(self) -> int:
        return self.goal.index if self.goal else -1

    @property
    def under_way(self) -> bool:
        """A goal given and not yet finished."""
        return self.goal is not None and self.finished_goal is None

    @property
    def reporting(self) -> bool:
        """A finished goal the lander is told of, again every ``GOAL_REPORT_RETRY_S`` (a stop is not reported)."""
        return self.finished_goal is not None and self.finished_goal[1] != "stopped"

    def report_due(self, now: float) -> bool:
        return self.reporting and now - self.reported_at >= GOAL_REPORT_RETRY_S

    def timers(self) -> list[float]:
        return [self.reported_at + GOAL_REPORT_RETRY_S] if self.reporting else []

    def goal_report(self, now: float, photos_pending: int) -> radio.GoalReport:
        index, outcome = self.finished_goal
        self.reported_at = now
        return radio.GoalReport(goal_index=index, outcome=outcome, photos_pending=photos_pending)

    def direction(self, msg: m.MissionDirection, now: float) -> Goal | None:
        """Take the lander's word: the goal it names, when that is a goal or a spot new to the rover (None: nothing
        new). The word ends a search for contact, whatever it says."""
        self.contact.heard(now)
        if not self.relay.note(msg):
            return None
        rad = math.radians(msg.bearing_deg)
        x, z = msg.distance_m * math.sin(rad), msg.distance_m * math.cos(rad)
        rim = None if msg.rim is None else (x + msg.rim[0], z + msg.rim[1], msg.rim[2])
        goal = Goal(msg.goal_index, msg.goals_total, msg.kind, x, z, msg.station, msg.shared, msg.relayed, rim)
        current = self.goal
        if current is not None and goal.index < current.index:
            return None
        if self.finished_goal and goal.index <= self.finished_goal[0] and not self.relay.released(goal,
                                                                                                  self.finished_goal):
            return None
        self.goal = goal
        if current is None or goal.index != current.index or goal.target != current.target:
            same = current is not None and goal.index == current.index
            log.info("t = %.1f s: rover %d %s goal %d of %d (%s, %.0f m from the lander)", now, self.rover_id,
                     "given a new spot at" if same else "bound for", goal.index + 1, goal.total, goal.kind,
                     msg.distance_m)
            self.finished_goal = None
            return goal
        return None

    def finish(self, outcome: str, why: str, now: float) -> str:
        """The goal is over (``Finish``): the behaviour's state from here."""
        goal, self.stuck_why = self.goal, why
        self.finished_goal = (goal.index, outcome)
        log.info("t = %.1f s: rover %d: goal %d %s%s", now, self.rover_id, goal.index + 1, outcome,
                 f" ({why})" if why else "")
        if outcome in ("stuck", "relay"):
            return outcome
        return "done" if goal.final else "waiting"

    def stop(self, now: float) -> None:
        """The lander's stop (need N6): the goal is over, unreported, until a new one comes. The stop is the
        lander's word too: a search for contact ends with it."""
        self.contact.heard(now)
        self.finished_goal = (self.goal_index, "stopped")

    def walk_on_if_cut_off(self, now: float) -> Goal | None:
        """A relay cut off from the lander at the last goal walks on to the goal it held the route for (``relay``):
        that goal, when it does."""
        silent_s = now - self.contact.heard_at
        goal = self.relay.cut_off(self.finished_goal, silent_s, self.params.communication)
        if goal is None:
            return None
        log.info("rover %d: no word from the lander for %.0f s on its relay spot; walking on to goal %d",
                 self.rover_id, silent_s, goal.index)
        self.goal, self.finished_goal = goal, None
        return goal

    def contact_goal(self, now: float, state: str, placed: bool) -> tuple[Goal | None, bool]:
        """The lander as a goal while a rover that waits for its word has heard none for a while (``contact``),
        and whether the search begins now. ``placed``: the rover knows where it stands."""
        waiting = (self.goal is None or self.finished_goal is not None) and (state == "waiting" or self.contact.seeking)
        was = self.contact.goal is not None
        goal = self.contact.target(now, waiting and placed)
        return goal, goal is not None and not was

    def ask_station(self, pose: Pose | None, hits: tuple[Hit, ...], now: float, fixing: bool,
                    ) -> radio.StationRequest | None:
        """A request for the rover's station at the goal, when one is due (``stations``); none after the goal, nor
        on the way by the lander."""
        if self.finished_goal or fixing:
            return None
        return self.stations.ask(self.goal, pose, hits, now)
