"""One rover's agent: turns incoming samples into outgoing actions, keeping one action in flight.

``RoverAgent.handle(topic, payload)`` returns the (key, message) pairs to publish; the Zenoh loop in
``runtime`` only moves bytes. So the whole agent, not just its behaviour, runs in tests without a router.
"""

from __future__ import annotations

import logging
import math
from pathlib import Path

from bus.rejections import Rejections
from rover_agent import relocalise
from rover_agent.behaviour import DefaultBehaviour
from rover_agent.contact import ContactSearch
from rover_agent.dead_reckoning import Pose
from rover_agent.decisions import BaseBehaviour, Finish, Goal, Hit, Hold, MoveTo, TakePhoto, View
from rover_agent.in_flight import ActionIds, InFlight, Pace
from rover_agent.localising import Localising
from rover_agent.map_report import MapRecorder
from rover_agent.navigation_feedback import NavigationFeedback
from rover_agent.relaying import Relaying
from rover_agent.resuming import Resuming
from rover_agent.saved_state import SavedState, load_state
from rover_agent.sightings import Teammate
from schemas import codec, radio
from schemas import keyspace as ks
from schemas import messages as m
from schemas.lockstep import lockstep_answer
from schemas.params import RoverParams

log = logging.getLogger("lunarsim.rover")

Out = tuple[str, m.Message]
SUBSCRIBED_TOPICS = (ks.PERCEPTION, ks.NAVIGATION_STATUS, ks.CANCEL_RESULT, ks.ACTION_REJECTED, ks.GYROSCOPE,
                     ks.COMM_IN, ks.COMM_PARTNERS, ks.MISSION_DIRECTION, ks.CALIBRATION, ks.PHOTO,
                     ks.BATTERY, ks.TEMPERATURE, ks.SUN)
GOAL_REPORT_RETRY_S = 2.0
STATUS_PERIOD_S = 1.0
PHOTO_TIMEOUT_S = 10.0
"""A photo not back by then is given up (a rover without a working camera must not wait for ever)."""
PHOTO_RETRY_S = 5.0
"""Photos not yet acknowledged by the lander are sent again this often (store and forward)."""
STATION_ASK_M = 15.0
"""Near a shared waypoint, closer than this, the rover asks the lander for its station: just before it reaches
a 20-rover formation (8.5 m in radius at the default spacing), so stations go out in the order rovers arrive."""
STATION_ASK_RETRY_S = 2.0


class RoverAgent(NavigationFeedback, Localising, Resuming, Relaying):
    def __init__(self, rover_id: int, keys: ks.Keyspace, params: RoverParams,
                 behaviour: BaseBehaviour | None = None, state_file: Path | None = None,
                 dispatch: m.Calibration | None = None) -> None:
        self.id = rover_id
        self.keys = keys
        self.params = params
        self.behaviour = behaviour or DefaultBehaviour(rover_id, params)
        self.state_file = state_file
        self.saved: SavedState | None = load_state(state_file) if state_file else None
        self.run: str | None = None  # the world's run (Clock.run; "" from a clock that names none), once heard
        self.ids = ActionIds()
        self.heard_action = 0  # the last action whose end this agent has heard (RoverStatus.action_id)
        self.ids_heard = False  # the world's answers name this agent's action ids (a driver's may not)
        self.queries = 0  # actions sent again after silence
        self.lost = False  # restarted mid-mission with no saved state of this run: it does not know where it is
        self.lost_why = ""
        self.contact = ContactSearch(rover_id, dispatch)  # what it does while the lander is silent
        self.fix = relocalise.LanderFix()  # going by the lander to fix its estimate first (``rover_agent.relocalise``)
        self.pose = None  # the estimate's mean (``rover_agent.localising``), once calibrated
        self.teammates: dict[int, Teammate] = {}  # each teammate's latest estimate of itself, heard by radio
        self.goal: Goal | None = None
        self.now = 0.0
        self.pitch = (0.0, -1.0)  # (degrees, stamp)
        self.in_flight: InFlight | None = None
        self.pace = Pace()  # the speed level sent with moves
        self.settled_at = 0.0
        self.finished_goal: tuple[int, str] | None = None  # (index, outcome) reported but not yet followed up
        self.stuck_why = ""  # what stopped it, from the behaviour (``Finish.why``), shown in its status
        self._last_report = self._last_status = -math.inf
        self.rejected = Rejections(log, f"rover {rover_id}")
        self.partners: list[int] = []
        self.photo_outbox: dict[str, radio.PhotoReport] = {}
        self._last_photo_send = -math.inf
        self._last_station_ask = -math.inf
        self.craters_found: set[int] = set()
        self.map = MapRecorder(params)
        self.battery: m.Battery | None = None  # power sensors: only from a world with a sun (issue 8)
        self.temperature: m.Temperature | None = None
        self.sunlit: bool | None = None

    @property
    def state(self) -> str:
        return self.behaviour.state

    @property
    def reporting(self) -> bool:
        """A finished goal the lander is told of, again every ``GOAL_REPORT_RETRY_S`` (a stop is not reported)."""
        return self.finished_goal is not None and self.finished_goal[1] != "stopped"

    def handle(self, topic: str, payload: bytes) -> list[Out]:
        handler = getattr(self, f"_on_{topic}", None)
        if handler is None:
            self.rejected.count(topic, "no handler for this topic")
            return []
        try:
            return handler(codec.decode(m.TOPIC_MODELS[topic], payload))
        except codec.DecodeError as exc:
            self.rejected.count(topic, exc)
            return []

    def on_clock(self, clock: m.Clock) -> list[Out]:
        if clock.run != self.run:
            self._join(clock)
        if not clock.running:  # the world waiting for agents, or done: nothing moves, nothing to answer
            return []
        self.now = max(self.now, clock.sim_time)
        out: list[Out] = []
        if self.in_flight and self.now >= self.in_flight.query_due():
            out.append(self.in_flight.query(self.now, self.keys, self.id))
            self.queries += 1
            log.info("rover %d: no word of action %d for a while; asking again", self.id, self.in_flight.action_id)
        if self.reporting and self.now - self._last_report >= GOAL_REPORT_RETRY_S:
            out += self._report_goal()
        if self.now - self._last_status >= STATUS_PERIOD_S:
            out.append(self._status())
        flight = self.in_flight
        if flight and isinstance(flight.decision, TakePhoto) and self.now - flight.sent_at > PHOTO_TIMEOUT_S:
            log.warning("rover %d: no photo %r after %g s; going on without it", self.id, flight.decision.label,
                        PHOTO_TIMEOUT_S)
            self._settle(self.now)
        if self.photo_outbox and self.now - self._last_photo_send >= PHOTO_RETRY_S:
            out += self._send_photos()
        if self.pose is not None:
            out += [self._radio([ks.LANDER_ID], report)
                    for report in self.map.due(self.now, self.pose.x, self.pose.z, reachable=bool(self.partners))]
        if clock.lockstep:
            out = lockstep_answer(out, clock, self.id, self.keys.rover(self.id, ks.ACK), self.next_wake())
        return out

    def next_wake(self) -> float:
        """When ``on_clock`` will next act by itself: the earliest of its timers. Every timer in ``on_clock``
        must be here, or a lockstep world would not wait for what it sends (``lockstep_answer`` says so)."""
        timers = [self._last_status + STATUS_PERIOD_S]
        if self.in_flight:
            timers.append(self.in_flight.query_due())
        if self.reporting:
            timers.append(self._last_report + GOAL_REPORT_RETRY_S)
        if self.in_flight and isinstance(self.in_flight.decision, TakePhoto):
            timers.append(self.in_flight.sent_at + PHOTO_TIMEOUT_S)
        if self.photo_outbox:
            timers.append(self._last_photo_send + PHOTO_RETRY_S)
        if self.pose is not None:
            timers.append(self.map.next_due())
        return min(timers)

    # ---- lander, via radio ----

    def _on_calibration(self, msg: m.Calibration) -> list[Out]:
        if self.pose is None and not self.lost:
            self.pose = Pose(msg.x, msg.z, msg.heading_deg % 360.0)
            log.info("rover %d: calibrated at (%.1f, %.1f) from the lander, heading %.0f", self.id, msg.x, msg.z,
                     msg.heading_deg % 360.0)
            self._save()
        return []

    def _on_mission_direction(self, msg: m.MissionDirection) -> list[Out]:
        if self.contact.seeking:  # back in contact: wait for (or take up) the lander's word again
            self.behaviour.state = "waiting"
        self.contact.heard(self.now)
        if not self._note_relay(msg):
            return []
        rad = math.radians(msg.bearing_deg)
        goal = Goal(msg.goal_index, msg.goals_total, msg.kind, msg.distance_m * math.sin(rad),
                    msg.distance_m * math.cos(rad), msg.station, msg.shared, msg.relayed)
        current = self.goal
        if current is not None and goal.index < current.index:
            return []
        if self.finished_goal and goal.index <= self.finished_goal[0] and not self._relay_released(goal):
            return []
        self.goal = goal
        if current is None or goal.index != current.index or goal.target != current.target:
            same = current is not None and goal.index == current.index
            log.info("t = %.1f s: rover %d %s goal %d of %d (%s, %.0f m from the lander)", self.now, self.id,
                     "given a new spot at" if same else "bound for", goal.index + 1, goal.total, goal.kind,
                     msg.distance_m)
            self.finished_goal = None
            self.fix.active = self.fix.active and current is not None and goal.index == current.index
            if not self.fix.active:  # a station for the goal the rover goes by the lander for: taken up later
                self.behaviour.start_goal(goal)
            return [self._status()]
        return []

    def _on_comm_partners(self, msg: m.CommPartners) -> list[Out]:
        self.partners = msg.ids
        return []

    def _on_comm_in(self, msg: m.InboundComm) -> list[Out]:
        message = radio.unpack(msg.payload)
        if isinstance(message, radio.PhotoAck):
            pending = len(self.photo_outbox)
            for label in message.labels:
                self.photo_outbox.pop(label, None)
            if len(self.photo_outbox) == pending:
                return []
            all_in = not self.photo_outbox and self.reporting
            return [self._status(), *(self._report_goal() if all_in else [])]  # the lander waits for all to be in
        elif isinstance(message, radio.MapAck) and msg.sender == ks.LANDER_ID:
            self.map.ack(message.seqs)
        elif isinstance(message, radio.PoseEstimate):
            self._heard_estimate(msg.sender, message)
        elif isinstance(message, radio.CraterFound):
            self.craters_found.add(message.goal_index)
        elif isinstance(message, radio.StopCommand) and msg.sender == ks.LANDER_ID:
            return self._stop()
        return []

    def _stop(self) -> list[Out]:
        """Stop where it is until a new goal comes (need N6): cancel a move, decide nothing more. The stop is the
        lander's word too: a search for contact ends with it."""
        self.contact.heard(self.now)
        self.finished_goal = (self.goal.index if self.goal else -1, "stopped")
        self.behaviour.state, self.fix.active = "stopped", False
        out: list[Out] = []
        flight = self.in_flight
        if flight and flight.navigating and not flight.cancel_sent:
            out.append(flight.cancel(self.keys, self.id))
        return [*out, self._status()]

    def _on_photo(self, msg: m.Photo) -> list[Out]:
        flight = self.in_flight
        if flight is None or not isinstance(flight.decision, TakePhoto) or msg.label != flight.decision.label:
            return []
        index = self.goal.index if self.goal else -1
        self.photo_outbox[msg.label] = radio.PhotoReport(goal_index=index, label=msg.label, stamp=msg.stamp,
                                                         png=msg.png)
        self._settle(msg.stamp)
        return self._send_photos()

    def _send_photos(self) -> list[Out]:
        """Send every photo the lander has not acknowledged yet; those that do not arrive go again later."""
        self._last_photo_send = self.now
        return [self._radio([ks.LANDER_ID], report) for report in self.photo_outbox.values()]

    def _radio(self, targets: list[int], message: m.Message) -> Out:
        return self.keys.rover(self.id, ks.COMM_OUT), m.OutboundComm(targets=targets, payload=radio.pack(message))

    # ---- sensors ----

    def _on_gyroscope(self, msg: m.Gyroscope) -> list[Out]:
        self.pitch = (msg.pitch_deg, msg.stamp)
        self.now = max(self.now, msg.stamp)
        return []

    def _on_battery(self, msg: m.Battery) -> list[Out]:
        self.battery = msg
        return []

    def _on_temperature(self, msg: m.Temperature) -> list[Out]:
        self.temperature = msg
        return []

    def _on_sun(self, msg: m.Sunlight) -> list[Out]:
        self.sunlit = msg.lit
        return []

    @property
    def powered_off(self) -> bool:
        """The battery is empty or the rover too cold: it can do nothing until the world says it is back."""
        return bool((self.battery and self.battery.empty) or (self.temperature and self.temperature.shutdown))

    def _view(self, stamp: float, pose: Pose, hits: tuple[Hit, ...], remaining_m: float = 0.0) -> View:
        charge = self.battery.fraction if self.battery is not None else None
        goal = self.contact.goal or self.fix.goal or self.goal
        return View(stamp, pose, goal, hits, self.pitch[0], charge, self.sunlit, self.localisation.position_std,
                    remaining_m)

    def _on_perception(self, msg: m.Perception) -> list[Out]:
        self.now = max(self.now, msg.stamp)
        if self.run is None:  # no clock: it may resume a saved state, so it neither acts nor takes a pose yet
            return []
        hits = tuple(Hit(a, d, k) for a, d, k in zip(msg.angles_deg, msg.distances_m, msg.kinds, strict=True))
        standing = self.in_flight is None and self.pose is not None and msg.stamp >= self.settled_at
        if standing:  # where the estimate says it stands: correct it, then map what it sees from there
            self._localise(msg.stamp, hits)
            self.map.fold_scan(self.pose.x, self.pose.z, self.pose.heading, hits)
        # answered with perception, which the lockstep world always waits for
        ask = self._ask_station(hits) + self._share_estimate()
        if self.in_flight is not None:
            return ask + self._watch(hits)
        if self._walk_on_if_cut_off():
            ask.append(self._status())
        heading_out = (self.goal is not None and self.finished_goal is None) or self._seek_contact()
        ready = (self.pose is not None and heading_out and not self.lost
                 and self.state not in ("done", "stuck", "stopped") and not self.powered_off
                 and msg.stamp >= self.settled_at and self.pitch[1] >= self.settled_at)
        if not ready:
            return ask
        self._mind_fix()
        return ask + self._act(self.behaviour.decide(self._view(msg.stamp, self.pose, hits)))

    def _seek_contact(self) -> bool:
        """Whether the rover heads for the lander to regain radio contact (``rover_agent.contact``): it waits for
        the lander's word (at the start, or between goals) and has heard none for a while."""
        if self.lost or self.powered_off:
            return False
        if self.pose is None and (assumed := self.contact.assumed_pose(self.now)) is not None:
            self.pose = Pose(assumed.x, assumed.z, assumed.heading_deg % 360.0)
            self._save()
        waiting = (self.goal is None or self.finished_goal is not None) and (
            self.state == "waiting" or self.contact.seeking)
        was = self.contact.goal is not None
        goal = self.contact.target(self.now, waiting and self.pose is not None)
        if goal is not None and not was:
            self.behaviour.start_goal(goal)
        return goal is not None

    def _ask_station(self, hits: tuple[Hit, ...]) -> list[Out]:
        """Near a goal the team shares and with no station yet: ask the lander for one, again every
        ``STATION_ASK_RETRY_S`` until it comes (a lost request, or a lander out of reach for now). Near is
        ``STATION_ASK_M`` from the goal; for a crater, whose size the rover does not know, also once its terrain is
        in view, some metres before the rim (a rover in the bowl sees no rim ahead: it asks by the distance)."""
        goal, pose = self.goal, self.pose
        if (goal is None or pose is None or not goal.shared or goal.station is not None or self.finished_goal
                or self.fix.active or self.now - self._last_station_ask < STATION_ASK_RETRY_S
                or not (math.hypot(goal.x - pose.x, goal.z - pose.z) <= STATION_ASK_M
                        or (goal.kind == "crater" and any(h.kind == "crater_terrain" for h in hits)))):
            return []
        self._last_station_ask = self.now
        return [self._radio([ks.LANDER_ID], radio.StationRequest(goal_index=goal.index, x=round(pose.x, 3),
                                                                        z=round(pose.z, 3)))]

    def _watch(self, hits: tuple[Hit, ...]) -> list[Out]:
        flight = self.in_flight
        if flight.cancel_sent or not isinstance(flight.decision, MoveTo):
            return []
        if self.behaviour.should_cancel(self._view(self.now, flight.start, hits, flight.remaining_m)):
            return [flight.cancel(self.keys, self.id)]
        return []

    def _act(self, decision) -> list[Out]:
        if isinstance(decision, Hold):
            return []
        if isinstance(decision, Finish):
            return self._finish(decision.outcome, decision.why)
        self.in_flight = InFlight(decision, self.pose, self.ids.take(self.now), sent_at=self.now, heard_at=self.now)
        self._save()
        return [*self.pace.speed(decision, self.now, self.keys, self.id), self.in_flight.request(self.keys, self.id)]

    def _finish(self, outcome: str, why: str = "") -> list[Out]:
        if self.contact.seeking:  # at the lander's estimated spot, or stuck on the way: wait there for its word
            self.contact.arrive(self.now, blocked=outcome == "stuck")
            self.behaviour.state = "waiting"
            return [self._status()]
        if self.fix.active:
            return self._fix_arrived(outcome)
        goal, self.stuck_why = self.goal, why
        self.finished_goal = (goal.index, outcome)
        log.info("t = %.1f s: rover %d: goal %d %s%s", self.now, self.id, goal.index + 1, outcome,
                 f" ({why})" if why else "")
        if outcome in ("stuck", "relay"):
            self.behaviour.state = outcome
        elif goal.final:
            self.behaviour.state = "done"
        else:
            self.behaviour.state = "waiting"
        out = [*self._report_goal(), self._status()]
        rovers_near = [p for p in self.partners if p != ks.LANDER_ID]
        if outcome == "reached" and goal.kind == "crater" and rovers_near:
            out.append(self._radio(rovers_near, radio.CraterFound(goal_index=goal.index)))
        return out

    def _report_goal(self) -> list[Out]:
        index, outcome = self.finished_goal
        self._last_report = self.now
        return [self._radio([ks.LANDER_ID], radio.GoalReport(goal_index=index, outcome=outcome,
                                                             photos_pending=len(self.photo_outbox)))]

    def _status(self) -> Out:
        self._last_status = self.now
        index = self.goal.index if self.goal else -1
        detail = "another rover found the crater" if index in self.craters_found else ""
        if self.state == "done" and not detail:
            detail = relocalise.unsure_detail(self.localisation, self.params.perception.perception_radius)
        if self.state == "stuck":
            detail = self.stuck_why
        if self.powered_off:
            detail = "off: battery empty" if self.battery and self.battery.empty else "off: too cold"
        if self.lost:
            detail = f"{self.lost_why}: position unknown"
        elif self.contact.seeking:
            detail = self.contact.detail
        elif self.fix.active:
            detail = relocalise.DETAIL
        return self.keys.rover(self.id, ks.STATUS), m.RoverStatus(
            stamp=self.now, state=self.state, goal_index=index, detail=detail, photos_pending=len(self.photo_outbox),
            action_id=self.heard_action, rejected=self.rejected.reported, lost=self.lost)
