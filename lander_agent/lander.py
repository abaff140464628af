"""The lander, with no Zenoh in it: every simulated second it re-sends calibration and mission directions over its
radio (rovers that were out of range catch up), it answers goal reports and ground commands at once, and it keeps
the photo archive and the traverse map. Each handler returns the samples to publish (``schemas.messages.Out``);
its Zenoh loop is ``lander_agent.runtime``, the in-process harness drives it without one."""

from __future__ import annotations

import logging
from collections.abc import Callable
from pathlib import Path
from typing import Any

import msgspec

from bus.rejections import Rejections
from lander_agent.archive import PhotoArchive
from lander_agent.mapping import TraverseMap
from lander_agent.mission import MissionPlan
from lander_agent.resume import LanderMemory
from schemas import codec, radio
from schemas import keyspace as ks
from schemas import messages as m
from schemas.messages import Out
from shared.lockstep import lockstep_answer
from shared.mission import CommandRefused

log = logging.getLogger("lunarsim.lander")
SEND_PERIOD_S = 1.0
MAP_PUBLISH_PERIOD_S = 5.0
"""Simulated seconds between two ``lander/map`` samples (for viewers and the recorder)."""
MAP_SAVE_PERIOD_S = 30.0
"""Simulated seconds between two writes of map.npz / map.png; they are written once more at the end."""


class Lander:
    """The lander's pure core: ``handle(key, payload)`` looks the key up in ``handlers`` and returns what to publish;
    it opens no session and reads no clock but the world's."""

    def __init__(self, plan: MissionPlan, keys: ks.Keyspace, archive: PhotoArchive | None = None,
                 map_folder: Path | None = None, memory: LanderMemory | None = None) -> None:
        self.plan = plan
        self.keys = keys
        self.archive = archive or PhotoArchive(None)
        self.map = TraverseMap.for_scenario(plan.scenario)
        self.map_folder = map_folder
        self.next_map = self.next_map_save = 0.0
        self.map_final = False
        self.now = 0.0
        self.partners: list[int] = []
        self.next_send = 0.0
        self.rejected = Rejections(log, "lander")
        self.memory = memory or LanderMemory(None)
        self._keep_due = False  # a running clock was handled: the state file may be due (``catch_up``)
        self.run: str | None = None  # the world's run, once heard
        self.map_lost = False  # joined this run under way without a saved state: the map began again
        self.reports_heard: dict[int, tuple[int, str]] = {}  # rover -> (goal, outcome) it last reported, for the log
        self.handlers: dict[str, tuple[type[m.Message], Callable[[Any], list[Out]]]] = {
            keys.clock: (m.Clock, self.on_clock), keys.lander(ks.COMM_IN): (m.InboundComm, self.on_comm_in),
            keys.lander(ks.COMM_PARTNERS): (m.CommPartners, self.on_comm_partners),
            keys.ground_command: (m.GroundCommand, self.on_ground_command)}
        """The keys the lander follows, each with its message and its handler: the loop subscribes to these."""

    def _transmit(self, targets: list[int], message: m.Message, channel: str) -> Out:
        out = m.OutboundComm(targets=targets, payload=codec.encode(message), channel=channel)
        return self.keys.lander(ks.COMM_OUT), out

    def broadcast(self, now: float) -> list[Out]:
        out = [self._transmit([rid], cal, "calibration") for rid, cal in self.plan.calibration.items()]
        out += [self._transmit(rids, d, "mission_direction") for d, rids in self.plan.directions().items()]
        status = msgspec.structs.replace(self.plan.status(now, self.partners), rejected=self.rejected.reported,
                                         map_lost=self.map_lost)
        out.append((self.keys.lander(ks.STATUS), status))
        return out

    def on_clock(self, clock: m.Clock) -> list[Out]:
        if clock.run != self.run:
            self._join(clock)
        if not clock.running:  # the world waiting for agents, or done: nothing moves, nothing to answer
            return self.final_map() if self.now > 0 else []
        out = []
        self.now = clock.sim_time
        if clock.sim_time >= self.next_send:
            self.next_send = clock.sim_time + SEND_PERIOD_S
            self._release_quiet_chains()
            out = self.broadcast(clock.sim_time)
        if clock.sim_time >= self.next_map:
            self.next_map = clock.sim_time + MAP_PUBLISH_PERIOD_S
            out.append((self.keys.lander(ks.MAP), self.map.to_message(clock.sim_time)))
        if self.map_folder is not None and clock.sim_time >= self.next_map_save:
            self.next_map_save = clock.sim_time + MAP_SAVE_PERIOD_S
            self.map.save(self.map_folder)
        self._keep_due = True
        if clock.lockstep:
            out = lockstep_answer(out, clock, ks.LANDER_ID, self.keys.lander(ks.ACK), self.next_wake)
        return out

    def next_wake(self) -> float:
        """The next broadcast or map, whichever is first: the lander's timers."""
        return min(self.next_send, self.next_map)

    def _join(self, clock: m.Clock) -> None:
        """The first clock of a run: the plan and map a killed lander saved of it, if there are any."""
        first, self.run = self.run is None, clock.run
        self.plan, traverse, self.map_lost = self.memory.join(clock, self.plan, self.archive, first)
        if traverse is not None:
            self.map = traverse

    def _release_quiet_chains(self) -> None:
        """Chains whose far end has gone quiet let their relays go (``MissionPlan.release_quiet``); the directions
        that say so go out with this broadcast."""
        moving = self.plan.release_quiet(self.now)
        if moving:
            log.info("t = %.1f s: no word from the far end of a daisy chain; directions sent to %s", self.now, moving)

    def final_map(self) -> list[Out]:
        """Once, when the mission is over (the world stopped its clock, or the lander is stopped): the map as
        it ends, published and written, so the files, the recording and the report agree."""
        if self.map_final:
            return []
        self.map_final = True
        if self.map_folder is not None:
            self.map.save(self.map_folder)
        return [(self.keys.lander(ks.MAP), self.map.to_message(self.now))]

    def on_comm_in(self, msg: m.InboundComm) -> list[Out]:
        report = radio.unpack(msg.payload)
        self.plan.heard(msg.sender, self.now)
        if isinstance(report, radio.MapReport):
            self.map.fold(msg.sender, report)
            ack = radio.pack(radio.MapAck(seqs=[report.seq]))
            return [(self.keys.lander(ks.COMM_OUT), m.OutboundComm(targets=[msg.sender], payload=ack))]
        if isinstance(report, radio.PhotoReport):
            if not self.archive.store(msg.sender, report):
                self.rejected.count("photo_report", f"rover {msg.sender} is over its share of the archive")
                return []
            ack = radio.pack(radio.PhotoAck(labels=[report.label]))
            return [(self.keys.lander(ks.COMM_OUT), m.OutboundComm(targets=[msg.sender], payload=ack))]
        if isinstance(report, radio.StationRequest):
            if not self.plan.request_station(msg.sender, report):
                return []
            return [self._transmit([msg.sender], self.plan.direction_for(msg.sender), "mission_direction")]
        if isinstance(report, radio.GoalReport):
            moving = self.plan.on_report(msg.sender, report)
            if self.reports_heard.get(msg.sender) != (heard := (report.goal_index, report.outcome)):
                self.reports_heard[msg.sender] = heard  # repeated until its photos are in: logged once
                log.info("t = %.1f s: rover %d reports goal %d %s; directions sent to %s", self.now, msg.sender,
                         report.goal_index + 1, report.outcome, moving or "none")
            return [self._transmit([rid], self.plan.direction_for(rid), "mission_direction") for rid in moving]
        return []

    def on_ground_command(self, command: m.GroundCommand) -> list[Out]:
        """Carry out a mission command and always answer it, with the reason when it is refused."""
        if command.command not in m.MISSION_COMMANDS:
            return []  # a recorder's or a replay's, not the lander's
        try:
            rovers = self.plan.on_command(command)
        except CommandRefused as exc:
            log.warning("ground command %s refused: %s", command.command, exc)
            return [self._result(command, False, str(exc))]
        if command.command == "stop":
            out = [(self.keys.lander(ks.COMM_OUT), m.OutboundComm(targets=rovers, payload=radio.pack(
                radio.StopCommand())))]
        else:
            out = [self._transmit([rid], self.plan.direction_for(rid), "mission_direction") for rid in rovers]
        detail = f"{command.command} sent to rover(s) {', '.join(map(str, rovers))}"
        log.info("t = %.1f s: ground command %s", self.now, detail)
        return [*out, self._result(command, True, detail)]

    def _result(self, command: m.GroundCommand, accepted: bool, detail: str) -> Out:
        return self.keys.ground_command_result, m.CommandResult(request_id=command.request_id, accepted=accepted,
                                                                detail=detail)

    def on_comm_partners(self, msg: m.CommPartners) -> list[Out]:
        self.partners = msg.ids
        return []

    def catch_up(self) -> None:
        """The state file (``LanderMemory.keep``: a quarter of a megabyte pickled, over a millisecond, every simulated
        second), written once the answer to the clock is out rather than before its ack: the runtime calls this
        after publishing, ``handle`` first thing otherwise. Either way no sample is handled between the clock and
        the save, so the file holds what it held when saved within ``on_clock``."""
        if self._keep_due:
            self._keep_due = False
            self.memory.keep(self.run, self.now, self.plan, self.map, self.archive)

    def handle(self, key: str, payload: bytes) -> list[Out]:
        self.catch_up()
        entry = self.handlers.get(key)
        if entry is None:
            return []
        model, handler = entry
        try:
            return handler(codec.decode(model, payload))
        except (codec.DecodeError, ValueError) as exc:  # ValueError: a valid sample no plan can follow
            self.rejected.count(key.rsplit("/", 1)[-1], exc, key)
            return []
