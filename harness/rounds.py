"""The world and lander of a lockstep mission in one process, with the rovers' agents outside it.

A lockstep tick here is what it is in the world service (``world_service.service``): the world steps and publishes
its samples, then its clock; the agents answer both; only once every answer is in does the world take them, by key
(each key's in order), and what it publishes while taking them (a radio delivery, a navigation status) is late:
the agents hear it before the next step, but the world takes their answers to it only with the next tick's. So a
tick has at most three rounds, each stopping wherever a rover has something to hear: the step's samples, the
clock, the late samples. The caller answers for every rover at once (``advance``), as a rover agent would over
Zenoh. The lander's part runs here, at the same points.

The in-process mission (``harness.loopback``) answers with the rover agents themselves; the PettingZoo
environment (``rover_env``) with a policy. With the shipped agents the report is the one ``lunarsim run --lockstep``
gives (tests/e2e/test_loopback_equals_processes.py, tests/e2e/test_rover_env.py).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path

from lander_agent.archive import PhotoArchive
from lander_agent.lander import Lander
from lander_agent.mission import MissionPlan
from schemas import codec
from schemas import keyspace as ks
from schemas import messages as m
from schemas.messages import Out
from schemas.scenario import Scenario
from world_service.camera.photos import PhotoJob
from world_service.lockstep import LockstepTick
from world_service.sim import World

Heard = dict[int, list[tuple[str, bytes]]]
"""Rover id -> the samples that reached its keys this round, in order: (topic, encoded payload); the topic of
the world's clock is ``keyspace.CLOCK``."""
_WORLD_TOPICS = frozenset((*World.INPUT_TOPICS, ks.ACK))
Drop = Callable[[str, m.Message], bool]
"""Fault injection: says which samples the link loses (key and message); lost samples are never delivered."""


@dataclass
class Rounds:
    scenario: Scenario
    max_sim_time: float
    archive: PhotoArchive | None = None
    map_folder: Path | None = None
    drop: Drop | None = None
    strict: bool = False
    """Raise when a rover publishes on a tick the world does not wait for (its agent's ``next_wake`` misses a
    timer): a bug in an agent, which would make a lockstep run over Zenoh irreproducible."""
    keys: ks.Keyspace = field(default_factory=lambda: ks.Keyspace("loopback"))
    pixels: bool | None = None
    """Render the photos' pixels. By default only when the archive writes them to disk: in process nothing else
    looks at them (an agent forwards a photo by its label, the lander files it), so a photo arrives on its due
    tick with an empty PNG, and the mission, whose camera is most of its compute, gives the same report."""

    def __post_init__(self) -> None:
        self.world = World(self.scenario, self.keys)
        self.world.clock.lockstep = True
        self.world.clock.run_id = f"rounds-{self.scenario.seed}"  # the clock names the run: same seed, same bytes
        self.lander = Lander(MissionPlan(self.scenario), self.keys, self.archive, self.map_folder)
        self.tick = LockstepTick(self.world, self.max_sim_time)
        self.rover_ids = sorted(self.world.rover_ids)
        self._present = {ks.LANDER_ID, *self.rover_ids}
        self._photos: list[PhotoJob] = []
        self._phase = "step"  # next: "samples", "clock", "take", then "step" again
        self._queue: list[Out] = []  # published by the world's step: the agents hear it first
        self._clock: m.Clock | None = None  # the tick's clock, until it is sent
        self._late_round = False  # the last round handed the rovers late samples
        self._clock_round = False  # the last round handed the rovers the clock (and nothing else)
        self._rover_head = f"{self.keys.prefix}/rover/"
        self._rover_topics: dict[str, tuple[int, str] | None] = {}  # the world's keys: a few per rover
        self._lander_inputs = {self.keys.lander(ks.COMM_IN), self.keys.lander(ks.COMM_PARTNERS)}
        self._world_inputs = {self.keys.lander(ks.COMM_OUT), self.keys.lander(ks.STATUS), self.keys.ground_command}
        self.over = False
        if self.pixels is None:
            self.pixels = self.archive is not None and self.archive.folder is not None

    def advance(self, answers: dict[int, list[Out]]) -> Heard:
        """Publish the rovers' answers to the last round and run until some rover hears something; an empty
        result means the mission is over (complete, or at ``max_sim_time``)."""
        self._take_answers(answers)
        self._clock_round = self._late_round = False
        while not self.over:
            heard = self._next_round()
            if heard:
                return heard
        return {}

    def _next_round(self) -> Heard:
        phase = self._phase
        if phase == "samples":
            self._phase = "clock"
            samples, self._queue = self._queue, []
            return self._route(samples)
        if phase == "clock":
            self._phase = "take"
            return self._send_clock()
        if phase == "take":
            self._phase = "step"
            if self.tick.over:
                self.over = True  # as the world service: the tick that ends the mission goes out, its answers unread
                return {}
            return self._route(self.tick.take(), late=True)
        self._step_world()
        return {}

    def finish(self) -> World:
        """The world at the end, its final state counted as the world service counts it before its report."""
        self.world.observed_state()
        self.lander.final_map()
        return self.world

    def _take_answers(self, answers: dict[int, list[Out]]) -> None:
        for rid in sorted(answers):
            said = []
            for key, message in answers[rid]:
                if isinstance(message, m.Ack):
                    self.tick.ack(self.tick.plan.agent_of(key), message)
                else:
                    said.append((key, message))
            if said and self.strict and self._clock_round and rid not in (self._clock.acks or ()):
                raise AssertionError(f"rover {rid} published {[k.rsplit('/', 1)[-1] for k, _ in said]} on tick "
                                     f"{self.world.clock.tick}, which the world does not wait for (asked: "
                                     f"{self._clock.acks}): the agent's next_wake() misses a timer")
            self._said(said)

    def _said(self, said: list[Out]) -> None:
        """What the agents published: the world takes what it subscribes to (with this tick's answers, or the next
        tick's once this tick's are taken, as over Zenoh)."""
        for key, message in said:
            if self.drop is not None and self.drop(key, message):
                continue
            if key in self._world_inputs or (key.startswith(self._rover_head) and self._for_world(key)):
                self.tick.answer(key, codec.encode(message))

    def _for_world(self, key: str) -> bool:
        """A rover's sample the world subscribes to (its actions, radio, status, acks), not one for the ground."""
        return key.rsplit("/", 1)[-1] in _WORLD_TOPICS

    def _route(self, samples: list[Out], late: bool = False) -> Heard:
        """Hand samples the world published to the rovers (returned) and the lander (answered here)."""
        heard: Heard = {}
        for key, message in samples:
            if self.drop is not None and self.drop(key, message):
                continue
            payload = codec.encode(message)
            if key in self._lander_inputs or key == self.keys.ground_command:
                self._said(self.lander.handle(key, payload))
            if key == self.keys.ground_command:  # the world follows it for its statistics, with the tick's answers
                self.tick.answer(key, payload)
            elif (rover := self._rover_topic(key)) is not None:
                heard.setdefault(rover[0], []).append((rover[1], payload))
        self._late_round = late and bool(heard)
        return heard

    def _rover_topic(self, key: str) -> tuple[int, str] | None:
        """(rover, topic) for a sample on a rover's own keys, None for anything the world or lander takes."""
        if key in self._rover_topics:
            return self._rover_topics[key]
        if not key.startswith(self._rover_head):
            return None
        rid, topic = self.keys.parse_rover_key(key)
        found = self._rover_topics[key] = None if topic in World.INPUT_TOPICS else (rid, topic)
        return found

    def _send_clock(self) -> Heard:
        """The tick's clock, if it waits for anyone (``LockstepTick.step``). The lander answers it here."""
        clock = self._clock
        if clock is None:
            return {}
        payload = codec.encode(clock)
        for key, message in self.lander.handle(self.keys.clock, payload):
            if isinstance(message, m.Ack):
                self.tick.ack(ks.LANDER_ID, message)
            elif self.strict and ks.LANDER_ID not in clock.acks:
                raise AssertionError(f"the lander published {key} on tick {clock.tick}, which the world does not "
                                     "wait for: its next_wake() misses a timer")
            else:
                self._said([(key, message)])
        self._clock_round = True
        return {rid: [(ks.CLOCK, payload)] for rid in self.rover_ids}

    def _step_world(self) -> None:
        world = self.world
        self._photos += world.take_photo_jobs()
        tick = world.clock.tick + 1
        due = [(self.keys.rover(job.rover_id, ks.PHOTO), self._photo(job)) for job in self._photos
               if job.due_tick <= tick]
        self._photos = [job for job in self._photos if job.due_tick > tick]
        self._queue, self._clock = self.tick.step(due, self._present)
        self._phase = "samples"

    def _photo(self, job: PhotoJob) -> m.Photo:
        if self.pixels:
            return self.world.render(job)
        return m.Photo(stamp=job.stamp, label=job.label, png=b"")
