"""The simulated world, one tick at a time, with no I/O: samples in, (key, message) pairs out.

The service (``world_service.service``) owns Zenoh and paces the clock; this class owns ground truth. It is a
coordinator over parts that own their state: the clock, the terrain and the scene, actuation (the bodies and
their actions), the radio, the rovers' power, their cameras and sensors, and the referee (statuses, stalls, the
mission's end, statistics). It routes each input to the part it is for and, each tick, asks every part for what
it publishes, in a fixed order: that order, and the order of the draws from the one seeded generator, are part
of a run's result.
"""

from __future__ import annotations

import logging
from collections.abc import Callable, Collection
from typing import Any, ClassVar

import numpy as np

from bus.rejections import Rejections
from schemas import codec
from schemas import keyspace as ks
from schemas import messages as m
from schemas.messages import Out
from schemas.scenario import Scenario
from world_service.actuation.actuator import Actuator, action_name
from world_service.camera.photos import PhotoJob
from world_service.camera.shutter import Shutter
from world_service.clock import Clock, tick_length
from world_service.outcome.referee import Referee
from world_service.power.energy import Energy
from world_service.radio.link import RadioLink
from world_service.scene import Scene
from world_service.sensors.readings import Sensors
from world_service.terrain.heightmap import Heightmap
from world_service.terrain.pitch import RoverPitch

log = logging.getLogger("lunarsim.world")

Handler = Callable[[int, Any], list[Out]]
"""What a rover's input topic is handled by: (rover id, decoded message) -> what the world answers."""


class World:
    RENDERS_PHOTOS: ClassVar[bool] = True
    """The service starts a camera process for it (a twin's photos come from the rovers' own cameras)."""
    RESUMABLE: ClassVar[bool] = True
    """The service saves its state for a restart to resume (``world_service.resume``)."""
    INPUT_TOPICS: ClassVar[tuple[str, ...]] = (ks.MOVE_ACTION, ks.ROTATE_ACTION, ks.CANCEL_ACTION, ks.SPEED_ACTION,
                                               ks.COMM_OUT, ks.STATUS, ks.PHOTO_ACTION)
    """Rover topics the world takes from the agents (besides lockstep acks)."""

    def __init__(self, scenario: Scenario, keyspace: ks.Keyspace) -> None:
        self.scenario, self.keys = scenario, keyspace
        p = scenario.rover_params
        rng = np.random.default_rng(scenario.seed)
        self.clock = Clock(tick_length(p))
        self.terrain = Heightmap.from_scenario(scenario, rng)  # first draw: photos.build_ground relies on it
        self.scene = Scene.from_scenario(scenario)
        self.activation_range = scenario.terrain_spec().chunk_activation_range_m
        self.rejected = Rejections(log)
        self.dropped_messages = 0  # counted by the service's inbox, reported here
        self.resumes = 0  # restarts of the world service that resumed this run (``world_service.resume``)
        ids = list(range(1, len(scenario.rovers) + 1))
        self.referee = Referee(scenario, ids)
        self.power = Energy(scenario, self.terrain, self.scene, keyspace, self.clock.dt, ids,
                            self.clock.period(p.perception.publish_frequency),
                            self.clock.period(p.power.publish_frequency)) if scenario.sun else None
        self.shutter = Shutter(self.terrain, self.scene, p, self.clock.dt)
        pitch = RoverPitch(self.terrain)
        self.actuator = Actuator(scenario, keyspace, self.clock, self.terrain, self.scene, rng, self.rejected,
                                 self.shutter, self.power, pitch)
        self.radio = RadioLink(scenario, keyspace, self.clock.dt, self.terrain, self.scene,
                               list(self.actuator.bodies.values()), self.rejected, self.power)
        self.sensors = Sensors(self.scene, self.terrain, p, keyspace, self.clock, rng, pitch)
        self.partners_period = self.clock.period(p.communication.partners_frequency)
        self.state_period = self.sensors.perception_period
        self.stats_period = self.clock.period(1.0)
        self.handlers: dict[str, Handler] = {
            ks.MOVE_ACTION: self.actuator.move, ks.ROTATE_ACTION: self.actuator.rotate,
            ks.CANCEL_ACTION: self.actuator.cancel, ks.SPEED_ACTION: self.actuator.speed,
            ks.COMM_OUT: self._transmit, ks.STATUS: self._status, ks.PHOTO_ACTION: self.actuator.photo,
        }

    @classmethod
    def input_keys(cls, keys: ks.Keyspace) -> list[str]:
        """What the world service subscribes to for this world: the agents' inputs, the ground's commands and the
        lockstep acks."""
        return [*(keys.rovers(topic) for topic in cls.INPUT_TOPICS), keys.lander(ks.COMM_OUT), keys.lander(ks.STATUS),
                keys.ground_command, keys.rovers(ks.ACK), keys.lander(ks.ACK)]

    @property
    def rover_ids(self) -> Collection[int]:
        return self.actuator.bodies.keys()

    # ---- input ----

    def receive(self, key: str, payload: bytes) -> list[Out]:
        """Handle one sample from an agent; a bad one is logged, counted and answered with nothing."""
        try:
            if key == self.keys.ground_command:
                self._ground_command(codec.decode(m.GroundCommand, payload))
                return []
            if key == self.keys.lander(ks.COMM_OUT):
                return self.radio.transmit(ks.LANDER_ID, codec.decode(m.OutboundComm, payload), True, self.clock.tick)
            if key == self.keys.lander(ks.STATUS):
                self.referee.note_lander(codec.decode(m.LanderStatus, payload))
                return []
            rover_id, topic = self.keys.parse_rover_key(key)
            if rover_id not in self.actuator.bodies:
                raise ValueError(f"no rover {rover_id} in scenario {self.scenario.name!r} "
                                 f"(ids 1..{len(self.actuator.bodies)})")
            handler = self.handlers.get(topic)
            if handler is None:
                raise ValueError(f"topic {topic!r} is not an input of the world")
            return handler(rover_id, codec.decode(m.TOPIC_MODELS[topic], payload))
        except (codec.DecodeError, ValueError) as exc:
            self.count_rejected(key, exc)
            return []

    def count_rejected(self, key: str, exc: Exception) -> None:
        topic = key.rsplit("/", 1)[-1] if key.startswith(self.keys.prefix + "/") else "<other world>"
        self.rejected.count(topic, exc, key)

    def _transmit(self, rid: int, msg: m.OutboundComm) -> list[Out]:
        return self.radio.transmit(rid, msg, False, self.clock.tick)

    def _status(self, rid: int, msg: m.RoverStatus) -> list[Out]:
        self.referee.note_status(rid, msg, self.clock.sim_time)
        self.actuator.note_heard(rid, msg.action_id)
        return []

    def _ground_command(self, command: m.GroundCommand) -> None:
        """Follow the ground's changes to the mission, so statistics judge each rover's real final goal; pause,
        resume and step hold and release the clock (a replay follows them too)."""
        self.referee.command(command)
        self.clock.hold.command(command)

    def set_lander_alive(self, alive: bool) -> None:
        self.referee.lander_alive(alive, self.clock.sim_time)

    def set_alive(self, rover_id: int, alive: bool) -> None:
        """Watchdog: a rover whose agent is gone stops where it is. When it comes back (its router restarted,
        its link returned, the agent restarted), the ledger re-sends how its action ended until it has heard."""
        if rover_id in self.actuator.bodies:
            self.actuator.set_alive(rover_id, alive)

    def resumed(self) -> None:
        """Loaded from a saved state by a restarted world service: every agent counts as gone until its liveliness
        token shows again (an agent that died meanwhile sent no word of it); the service waits for the tokens
        before the clock runs, as at the start."""
        self.resumes += 1
        self.actuator.resumed()

    # ---- photos ----

    def take_photo_jobs(self) -> list[PhotoJob]:
        return self.shutter.take_jobs()

    def render(self, job: PhotoJob) -> m.Photo:
        """The photo rendered here (tests, the loopback); the service renders in a ``camera.photos.CameraProcess``."""
        return self.shutter.render(job)

    # ---- time ----

    def step(self) -> list[Out]:
        """Advance one tick and return everything the world publishes for it."""
        clock = self.clock
        clock.tick += 1
        out = self.actuator.step()
        if self.power is not None:
            out += self._power_step()
        bodies = list(self.actuator.bodies.values())
        partners_due = clock.tick % self.partners_period == 0
        if partners_due:
            self.terrain.keep_near(np.array([(b.x, b.z) for b in bodies]), self.activation_range)  # report 10.7.1
            self.radio.rebuild(bodies)
        out += self.radio.due(clock.tick)
        out += self.actuator.resend_due()
        out += self.sensors.read(bodies)
        out += self.actuator.statuses()
        if partners_due:
            out += self.radio.partners()
        if self._observer_tick(self.state_period):
            out.append((self.keys.state, self.observed_state()))
        if self._observer_tick(self.stats_period):
            out.append((self.keys.stats, m.WorldStats(stamp=clock.sim_time, report=self.report())))
        self.referee.check_complete(clock.sim_time, self.actuator.moving(), self.radio.reaches_lander)
        out.append((self.keys.clock, clock.message()))
        return out

    def _power_step(self) -> list[Out]:
        """Batteries, temperatures and light; a rover that has just gone off stops where it is."""
        out, gone_off = self.power.step(self.clock.tick, self.clock.sim_time, list(self.actuator.bodies.values()))
        for rid in gone_off:
            self.actuator.stop(rid)
            log.info("rover %d shut down at t = %.1f s: %s", rid, self.clock.sim_time, self.power.refusal(rid)[1])
        return out

    def _observer_tick(self, period: int) -> bool:
        """Ground truth and statistics, which only observers read, go out half a period after the ticks that
        rebuild the radio graph and send every rover its partners. Together, at 100 rovers, they would make one tick
        a second cost 15 ms of the world's CPU against 4 for the others, and in real time the ticks after it would
        start late."""
        return self.clock.tick % period == period // 2

    # ---- ground truth and statistics ----

    def world_state(self) -> m.WorldState:
        now = self.clock.sim_time
        rovers = [self._truth(rid, now) for rid in self.actuator.bodies]
        self.referee.note_stalled(rovers, now)
        a, radio = self.actuator, self.radio
        counters = m.WorldCounters(rover_collisions=a.rover_collisions, obstacle_collisions=a.obstacle_collisions,
                                   rejected_messages=self.rejected.total, radio_dropped=radio.dropped,
                                   radio_lost=radio.lost, dropped_messages=self.dropped_messages,
                                   world_resumes=self.resumes, **self.referee.agent_counters(),
                                   **(self.power.counters() if self.power is not None else {}))
        return m.WorldState(stamp=now, rovers=rovers, comm_links=radio.graph.links(), relays=radio.graph.relays(),
                            counters=counters, completed_at=self.completed_at)

    def _truth(self, rid: int, now: float) -> m.RoverTruth:
        b = self.actuator.bodies[rid]
        power = self.power.truth(rid) if self.power is not None else {}
        distance, stalled = self.referee.judge(rid, b.x, b.z, now, power.get("powered"))
        status = self.referee.status[rid]
        return m.RoverTruth(id=rid, x=round(b.x, 4), z=round(b.z, 4), heading_deg=round(b.heading, 3),
                            action=action_name(b), state=status.state, goal_index=status.goal_index,
                            distance_to_goal_m=distance, distance_covered_m=round(b.distance_covered, 3),
                            alive=self.actuator.alive[rid], stalled=stalled, **power)

    def observed_state(self) -> m.WorldState:
        """The state to publish, counted into the statistics: they are computed from what is published."""
        state = self.world_state()
        self.referee.stats.observe(state)
        return state

    @property
    def completed_at(self) -> float | None:
        return self.referee.completed_at

    @property
    def complete(self) -> bool:
        return self.completed_at is not None

    def report(self) -> m.MissionReport:
        """Statistics as of the last published state (``lunarsim report`` gets the same from a recording)."""
        if self.referee.stats.last is None:
            self.observed_state()
        return self.referee.stats.report()
