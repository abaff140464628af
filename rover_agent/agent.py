"""One rover's agent: turns incoming samples into outgoing actions, keeping one action in flight.

``RoverAgent.handle(topic, payload)`` returns the (key, message) pairs to publish; the Zenoh loop in ``runtime``
only moves bytes, so the whole agent, not just its behaviour, runs in tests without a router.

The agent coordinates parts that each own their state: its actions (``actions.tracker``), its pose estimate
(``estimation.estimator``), its part of the mission (``mission.goals``), its photos and map on their way to the
lander (``mission.photos``, ``mission.traverse_map``), what survives a restart (``restarts.resume``), its latest
sensor readings (``senses``) and the behaviour that decides (``decisions.BaseBehaviour``). What one part's news
means for another is decided here, in one handler a topic (``handlers``).
"""

from __future__ import annotations

import logging
import math
from collections.abc import Callable
from pathlib import Path

from bus.rejections import Rejections
from rover_agent.actions.tracker import ActionTracker
from rover_agent.behaviour import DefaultBehaviour
from rover_agent.decisions import BaseBehaviour, Decision, Finish, Hit, Hold, MoveTo, Rotate, View
from rover_agent.detours import Detours
from rover_agent.estimation.estimator import Estimator
from rover_agent.mission.goals import Mission
from rover_agent.mission.photos import PhotoOutbox
from rover_agent.mission.stations import drawn_in
from rover_agent.mission.traverse_map import MapRecorder
from rover_agent.outgoing import Sender
from rover_agent.restarts.resume import Restarts
from rover_agent.senses import Senses
from rover_agent.status import status_detail, walking_cause
from schemas import codec, radio
from schemas import keyspace as ks
from schemas import messages as m
from schemas.messages import Out
from schemas.params import RoverParams
from shared.lockstep import lockstep_answer
from shared.pose import Pose

log = logging.getLogger("lunarsim.rover")

STATUS_PERIOD_S = 1.0
IDLE_STATES = ("done", "stuck", "stopped")
"""States in which the agent decides nothing until a new goal comes."""


class RoverAgent:
    def __init__(self, rover_id: int, keys: ks.Keyspace, params: RoverParams,
                 behaviour: BaseBehaviour | None = None, state_file: Path | None = None,
                 dispatch: m.Calibration | None = None) -> None:
        self.id = rover_id
        self.keys = keys
        self.params = params
        self.behaviour = behaviour or DefaultBehaviour(rover_id, params)
        self.send = Sender(keys, rover_id)
        self.rejected = Rejections(log, f"rover {rover_id}")
        self.restarts = Restarts(rover_id, state_file)
        self.actions = ActionTracker(self.send)
        self.estimator = Estimator(rover_id, params, self.rejected)
        self.mission = Mission(rover_id, params, dispatch)
        self.photos = PhotoOutbox()
        self.map = MapRecorder(params)
        self.senses = Senses()
        self.detours = Detours(self.mission, self.estimator, self.behaviour)
        self.now = 0.0
        self.status_at = -math.inf
        self.walked: dict[str, float] = {}
        """Metres walked by what the rover walked for (``status.walking_cause``): where a mission's distance goes."""
        self.handlers: dict[str, Callable[[m.Message], list[Out]]] = {
            ks.PERCEPTION: self._on_perception, ks.NAVIGATION_STATUS: self._on_navigation_status,
            ks.CANCEL_RESULT: self._on_cancel_result, ks.ACTION_REJECTED: self._on_action_rejected,
            ks.GYROSCOPE: self._on_gyroscope, ks.COMM_IN: self._on_comm_in,
            ks.COMM_PARTNERS: self.senses.on_comm_partners, ks.MISSION_DIRECTION: self._on_mission_direction,
            ks.CALIBRATION: self._on_calibration, ks.PHOTO: self._on_photo, ks.BATTERY: self.senses.on_battery,
            ks.TEMPERATURE: self.senses.on_temperature, ks.SUN: self.senses.on_sun}

    @property
    def state(self) -> str:
        return self.behaviour.state

    @property
    def pose(self) -> Pose | None:
        """The estimate's mean, once the rover knows where it stands."""
        return self.estimator.pose

    def catch_up(self) -> None:
        """Map book-keeping deferred until the answer is out (``MapRecorder.fold_later``): done first thing by the
        next ``handle`` or ``on_clock``, so a caller need not call it, only may, where it has time to spare."""
        self.map.catch_up()

    def handle(self, topic: str, payload: bytes) -> list[Out]:
        self.catch_up()
        handler = self.handlers.get(topic)
        if handler is None:
            self.rejected.count(topic, "no handler for this topic")
            return []
        try:
            return handler(codec.decode(m.TOPIC_MODELS[topic], payload))
        except codec.DecodeError as exc:
            self.rejected.count(topic, exc)
            return []

    def on_clock(self, clock: m.Clock) -> list[Out]:
        self.catch_up()
        if clock.run != self.restarts.run:
            self._join(clock)
        if not clock.running:  # the world waiting for agents, or done: nothing moves, nothing to answer
            return []
        self.now = max(self.now, clock.sim_time)
        out: list[Out] = []
        if (query := self.actions.query(self.now)) is not None:
            out.append(query)
        if self.mission.report_due(self.now):
            out += self._report_goal()
        if self.now - self.status_at >= STATUS_PERIOD_S:
            out += [self.status(), *self._report_estimate()]
        if self.actions.photo_overdue(self.now):
            self._settle(self.now)
        if self.photos.due(self.now):
            out += self._send_photos()
        if (pose := self.pose) is not None:
            reachable = bool(self.senses.partners)
            out += [self.send.radio([ks.LANDER_ID], report)
                    for report in self.map.due(self.now, pose.x, pose.z, reachable=reachable)]
        if clock.lockstep:
            out = lockstep_answer(out, clock, self.id, self.keys.rover(self.id, ks.ACK), self.next_wake)
        return out

    def next_wake(self) -> float:
        """When ``on_clock`` will next act by itself: the earliest of its timers. Every timer in ``on_clock``
        must be here, or a lockstep world would not wait for what it sends (``lockstep_answer`` says so)."""
        timers = [self.status_at + STATUS_PERIOD_S, *self.actions.timers(), *self.mission.timers(),
                  *self.photos.timers()]
        if self.pose is not None:
            timers.append(self.map.next_due())
        return min(timers)

    def _join(self, clock: m.Clock) -> None:
        """The first clock of a run: resume what was saved of it, or know the rover lost (``restarts.resume``)."""
        self.mission.joined(clock.sim_time)
        saved = self.restarts.join(clock, placed=self.pose is not None)
        if saved is not None:
            self.estimator.resume(saved.pose, saved.cov)
            self.actions.resume(saved.next_action, saved.flight, self.now)
        elif self.restarts.lost:
            self.actions.drop()

    def _save(self) -> None:
        loc = self.estimator.localisation
        flight, next_action = self.actions.saved()
        self.restarts.save(self.pose, loc.cov if loc is not None else None, flight, next_action)

    def _settle(self, stamp: float) -> None:
        """The action is over; decide again only on sensor data taken after this moment."""
        self.actions.settle(stamp)
        self._save()

    # ---- the world's answers to actions ----

    def _on_navigation_status(self, msg: m.NavigationStatus) -> list[Out]:
        self.now = max(self.now, msg.stamp)
        flight = self.actions.answered(msg.action_id)
        if flight is None:
            return []  # an old action's end sent again, or a photo's (not a navigation action)
        flight.heard_at = self.now
        if msg.outcome == "running":
            flight.walking(msg.stamp, msg.remaining)
            return []
        if msg.outcome == "completed":
            self.estimator.completed(flight.start, flight.decision)
            if isinstance(flight.decision, MoveTo):
                self._moved(math.hypot(flight.decision.x, flight.decision.z))
            self._settle(msg.stamp)
        # otherwise the action ended early: the CancelResult that follows says where the rover stopped
        return []

    def _on_cancel_result(self, msg: m.CancelResult) -> list[Out]:
        flight = self.actions.answered(msg.action_id)
        if flight is None:
            return []
        self.estimator.stopped_early(flight.start, msg.x, msg.z, msg.angle_deg)
        self._moved(math.hypot(msg.x, msg.z))
        self.behaviour.cancelled(self.now)
        self._settle(self.now)
        return []

    def _moved(self, distance: float) -> None:
        self.behaviour.moved(distance)
        cause = walking_cause(self.mission, self.estimator)
        self.walked[cause] = self.walked.get(cause, 0.0) + distance

    def _on_action_rejected(self, msg: m.ActionRejected) -> list[Out]:
        flight = self.actions.answered(msg.action_id)
        if flight is None:
            return []
        if msg.action == "cancel":  # the world never had the action (its sample was lost): the rover did not move
            if msg.action_id == flight.action_id:
                self._settle(self.now)
            return []
        if msg.action not in ("move", "rotate"):
            return []
        if msg.reason in ("stale", "out_of_sequence"):  # nothing about the ground: only the ids to renew
            self.actions.renew_ids()
        elif isinstance(flight.decision, MoveTo):
            self.behaviour.rejected(math.degrees(math.atan2(flight.decision.x, flight.decision.z)))
        log.info("rover %d: %s rejected (%s): %s", self.id, msg.action, msg.reason, msg.detail)
        self._settle(self.now)
        return []

    def _on_photo(self, msg: m.Photo) -> list[Out]:
        if not self.actions.photo(msg.label):
            return []
        self.photos.add(msg.label, radio.PhotoReport(goal_index=self.mission.goal_index, label=msg.label,
                                                     stamp=msg.stamp, png=msg.png))
        self._settle(msg.stamp)
        return self._send_photos()

    # ---- the lander, via radio ----

    def _on_calibration(self, msg: m.Calibration) -> list[Out]:
        if self.pose is None and not self.restarts.lost:
            self.estimator.place(Pose(msg.x, msg.z, msg.heading_deg % 360.0))
            log.info("rover %d: calibrated at (%.1f, %.1f) from the lander, heading %.0f", self.id, msg.x, msg.z,
                     msg.heading_deg % 360.0)
            self._save()
        return []

    def _on_mission_direction(self, msg: m.MissionDirection) -> list[Out]:
        if self.mission.contact.seeking:  # back in contact: wait for (or take up) the lander's word again
            self.behaviour.state = "waiting"
        current = self.mission.goal
        goal = self.mission.direction(msg, self.now)
        if goal is None:
            return []
        self.estimator.learn(goal)
        fix = self.estimator.fix
        fix.active = fix.active and current is not None and goal.index == current.index
        if not fix.active:  # a station for the goal the rover goes by the lander for: taken up later
            self.behaviour.start_goal(goal)
        return [self.status()]

    def _on_comm_in(self, msg: m.InboundComm) -> list[Out]:
        message = radio.unpack(msg.payload)
        if isinstance(message, radio.PhotoAck):
            if not self.photos.ack(message.labels):
                return []
            all_in = not self.photos.pending and self.mission.reporting
            return [self.status(), *(self._report_goal() if all_in else [])]  # the lander waits for all to be in
        elif isinstance(message, radio.MapAck) and msg.sender == ks.LANDER_ID:
            self.map.ack(message.seqs)
        elif isinstance(message, radio.PoseEstimate):
            self.estimator.heard(msg.sender, message, self.now)
        elif isinstance(message, radio.CraterFound):
            self.mission.craters_found.add(message.goal_index)
        elif isinstance(message, radio.StopCommand) and msg.sender == ks.LANDER_ID:
            return self._stop()
        return []

    def _stop(self) -> list[Out]:
        """Stop where it is until a new goal comes (need N6): cancel a move, decide nothing more."""
        self.mission.stop(self.now)
        self.behaviour.state, self.estimator.fix.active = "stopped", False
        return [*self.actions.stop(), self.status()]

    def _send_photos(self) -> list[Out]:
        """Every photo the lander has not acknowledged yet; those that do not arrive go again later."""
        return [self.send.radio([ks.LANDER_ID], report) for report in self.photos.send(self.now)]

    # ---- sensors (the others go straight to ``senses``) ----

    def _on_gyroscope(self, msg: m.Gyroscope) -> list[Out]:
        self.senses.pitch = (msg.pitch_deg, msg.stamp)
        if msg.heading_deg is not None:
            self.senses.heading = (msg.heading_deg, msg.stamp)
        self.now = max(self.now, msg.stamp)
        return []

    def view(self, stamp: float, pose: Pose, hits: tuple[Hit, ...], remaining_m: float = 0.0) -> View:
        """What the behaviour sees: its goal is the lander while it seeks contact or goes by it to fix its
        estimate, else the mission's."""
        std, radius = self.estimator.localisation.position_std, self.params.perception.perception_radius
        goal = (self.mission.contact.goal or self.estimator.fix.goal or self.estimator.search.goal
                or drawn_in(self.mission.goal, std, radius))
        return View(stamp, pose, goal, hits, self.senses.pitch[0], self.senses.charge, self.senses.sunlit, std,
                    remaining_m)

    def _on_perception(self, msg: m.Perception) -> list[Out]:
        self.now = max(self.now, msg.stamp)
        if self.restarts.run is None:  # no clock: it may resume a saved state, so it neither acts nor takes a pose
            return []
        hits = tuple(Hit(a, d, k) for a, d, k in zip(msg.angles_deg, msg.distances_m, msg.kinds, strict=True))
        standing = self.actions.in_flight is None and self.pose is not None and self.actions.settled_by(msg.stamp)
        if standing:  # where the estimate says it stands: correct it, then map what it sees from there
            self.estimator.localise(msg.stamp, hits, self.state, self.senses.partners)
            if (sun := self.senses.heading) is not None and self.actions.settled_by(sun[1]):
                self.estimator.sun(sun[0])
            self.estimator.note_sure()
            self.map.fold_later(self.pose.x, self.pose.z, self.pose.heading, hits)
        # answered with perception, which the lockstep world always waits for
        ask = self._ask_station(hits) + self._share_estimate()
        flight = self.actions.in_flight
        if flight is not None:
            if flight.cancel_sent or not isinstance(flight.decision, MoveTo):
                return ask
            cancel = self.behaviour.should_cancel(self.view(self.now, flight.start, hits, flight.remaining_m))
            return [*ask, flight.cancel(self.send)] if cancel else ask
        if (relay_goal := self.mission.walk_on_if_cut_off(self.now)) is not None:
            self.behaviour.start_goal(relay_goal)
            ask.append(self.status())
        heading_out = self.mission.under_way or self._seek_contact()
        ready = (self.pose is not None and heading_out and not self.restarts.lost and self.state not in IDLE_STATES
                 and not self.senses.powered_off and self.actions.settled_by(msg.stamp)
                 and self.actions.settled_by(self.senses.pitch[1]))
        if not ready:
            return ask
        if (look := self.estimator.look_back(self.mission.goal, self.params.perception.perception_radius)) is not None:
            return ask + self._act(Rotate(look))  # a crater's rim behind it: turn to see it (``rim_look``)
        self.detours.before_decision(self.now)
        return ask + self._act(self.behaviour.decide(self.view(msg.stamp, self.pose, hits)))

    def _ask_station(self, hits: tuple[Hit, ...]) -> list[Out]:
        fixing = self.estimator.fix.active or self.estimator.search.active
        request = self.mission.ask_station(self.pose, hits, self.now, fixing=fixing)
        return [] if request is None else [self.send.radio([ks.LANDER_ID], request)]

    def _share_estimate(self) -> list[Out]:
        if self.restarts.lost or self.senses.powered_off:
            return []
        told = self.estimator.share(self.now, self.senses.partners, self.state, self.actions.in_flight)
        return [] if told is None else [self.send.radio(*told)]

    def _seek_contact(self) -> bool:
        """Whether the rover heads for the lander to regain radio contact (``mission.contact``): it waits for the
        lander's word (at the start, or between goals) and has heard none for a while."""
        if self.restarts.lost or self.senses.powered_off:
            return False
        if self.pose is None and (assumed := self.mission.contact.assumed_pose(self.now)) is not None:
            self.estimator.place(Pose(assumed.x, assumed.z, assumed.heading_deg % 360.0))
            self._save()
        goal, begins = self.mission.contact_goal(self.now, self.state, placed=self.pose is not None)
        if begins:
            self.behaviour.start_goal(goal)
        return goal is not None

    def _act(self, decision: Decision) -> list[Out]:
        if isinstance(decision, Hold):
            return []
        if isinstance(decision, Finish):
            return self.finish(decision.outcome, decision.why)
        out = self.actions.start(decision, self.pose, self.now)
        self._save()
        return out

    def finish(self, outcome: str, why: str = "") -> list[Out]:
        """The behaviour is done with the goal it walked to: the lander's estimated place while seeking contact, a
        leg of the way by the lander, or the mission's goal (reported to the lander)."""
        contact = self.mission.contact
        if contact.seeking:  # at the lander's estimated spot, or stuck on the way: wait there for its word
            contact.arrive(self.now, blocked=outcome == "stuck")
            self.behaviour.state = "waiting"
            return [self.status()]
        if (detour := self.detours.arrived(outcome, self.now)) is not False:  # a leg of a way to fix the estimate
            return self._act(detour) if isinstance(detour, Rotate) else [self.status()]
        self.behaviour.state = self.mission.finish(outcome, why, self.now)
        goal = self.mission.goal
        out = [*self._report_goal(), self.status()]
        rovers_near = [p for p in self.senses.partners if p != ks.LANDER_ID]
        if outcome == "reached" and goal.kind == "crater" and rovers_near:
            out.append(self.send.radio(rovers_near, radio.CraterFound(goal_index=goal.index)))
        return out

    def _report_estimate(self) -> list[Out]:
        """The estimate on the rover's own key, with the periodic status (``Estimator.report``)."""
        own = None if self.restarts.lost else self.estimator.report(self.now, self.actions.in_flight)
        return [] if own is None else [(self.send.key(ks.POSE_ESTIMATE), own)]

    def _report_goal(self) -> list[Out]:
        return [self.send.radio([ks.LANDER_ID], self.mission.goal_report(self.now, self.photos.pending))]

    def status(self) -> Out:
        """The rover's status for the world and the ground, with what its state alone does not say."""
        self.status_at = self.now
        detail = status_detail(self.state, self.mission, self.estimator, self.senses, self.restarts,
                               self.params.perception.perception_radius)
        return self.send.key(ks.STATUS), m.RoverStatus(
            stamp=self.now, state=self.state, goal_index=self.mission.goal_index, detail=detail,
            photos_pending=self.photos.pending, action_id=self.actions.heard_action, rejected=self.rejected.reported,
            lost=self.restarts.lost)
