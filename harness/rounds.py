"""The world and lander of a lockstep mission in one process, with the rovers' agents outside it.

A lockstep tick is a cascade: the world steps and publishes; each sample, routed to its subscriber, may make it
publish more; when nothing more is said the world sends its clock, whose answers cascade in turn. Routed first in,
first out, the samples of a cascade fall into generations (what the world published, the answers to those, the
answers to the answers...). ``Rounds`` runs the world's and the lander's part of each generation itself and stops
wherever a rover has something to hear: the caller answers for every rover at once (``advance``), as a rover
agent would over Zenoh, and the cascade goes on. That is one round; a tick has as many as its cascade needs and
ticks that send the rovers nothing have none.

The in-process mission (``harness.loopback``) answers with the rover agents themselves; the PettingZoo
environment (``rover_env``) with a policy. With the shipped agents the report is the one ``lunarsim run --lockstep``
gives (tests/test_loopback_equals_processes.py, tests/test_rover_env.py), though a reply to an answer can reach a
rover within the tick here where over Zenoh it may come a tick later.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path

from lander_agent.mission import MissionPlan
from lander_agent.runtime import Lander, PhotoArchive
from schemas import codec
from schemas import keyspace as ks
from schemas import messages as m
from schemas.scenario import Scenario
from world_service.lockstep import AckPlan
from world_service.sim import PhotoJob, World

Out = tuple[str, m.Message]
Heard = dict[int, list[tuple[str, bytes]]]
"""Rover id -> the samples that reached its keys this round, in order: (topic, encoded payload); the topic of
the world's clock is ``keyspace.CLOCK``."""
MAX_ROUNDS_PER_TICK = 64
"""A cascade still going after this many rounds (agents answering each other's radio without end) goes on over
the next ticks, as it would over Zenoh, where the world does not wait for chatter to stop: the clock must run.
The shipped agents' cascades end in a few rounds."""
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

    def __post_init__(self) -> None:
        self.world = World(self.scenario, self.keys)
        self.world.lockstep = True
        self.world.run_id = f"rounds-{self.scenario.seed}"  # the clock names the run: the same seed, the same bytes
        self.lander = Lander(MissionPlan(self.scenario), self.keys, self.archive, self.map_folder)
        self.plan = AckPlan(self.keys, self.world.dt)
        self.rover_ids = sorted(self.world.bodies)
        self._photos: list[PhotoJob] = []
        self._queue: list[Out] = []  # published, not yet routed
        self._clock: m.Clock | None = None  # the tick's clock, until it is sent
        self._asked: list[int] = []  # the rovers the last clock sent waits for
        self._clock_round = False  # the last round handed the rovers the clock (and nothing else)
        self._rover_head = f"{self.keys.prefix}/rover/"
        self.over = False
        self.rounds_this_tick = 0

    def advance(self, answers: dict[int, list[Out]]) -> Heard:
        """Publish the rovers' answers to the last round and run until some rover hears something; an empty
        result means the mission is over (complete, or at ``max_sim_time``)."""
        self._take_answers(answers)
        self._clock_round = False
        while not self.over:
            chatter = self.rounds_this_tick >= MAX_ROUNDS_PER_TICK
            heard = self._route() if self._queue and not chatter else self._next_phase()
            if heard:
                self.rounds_this_tick += 1
                return heard
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
                    if message.tick == self.world.tick:  # as the service: an ack of another tick says nothing
                        self.plan.acked(self.plan.agent_of(key), message.tick, message.wake)
                else:
                    said.append((key, message))
            if said and self.strict and self._clock_round and rid not in self._asked:
                raise AssertionError(f"rover {rid} published {[k.rsplit('/', 1)[-1] for k, _ in said]} on tick "
                                     f"{self.world.tick}, which the world does not wait for (asked: "
                                     f"{self._asked}): the agent's next_wake() misses a timer")
            self._queue += said

    def _route(self) -> Heard:
        """Route one generation: the world's and the lander's part here, the rovers' returned."""
        generation, self._queue = self._queue, []
        heard: Heard = {}
        taken: list[tuple[str, bytes]] = []
        for key, message in generation:
            self.plan.note(key)
            if self.drop is not None and self.drop(key, message):
                continue
            payload = codec.encode(message)
            rover = self._rover_topic(key)
            if rover is not None:
                heard.setdefault(rover[0], []).append((rover[1], payload))
            else:
                taken.append((key, payload))
        # By key, each key's samples in order, as the world service takes a tick's inputs: moves draw their noise
        # from one generator, so rover 10's move before rover 2's ("rover/10" < "rover/2") is part of the result.
        for key, payload in sorted(taken, key=lambda sample: sample[0]):
            self._queue += self._deliver(key, payload)
        return heard

    def _rover_topic(self, key: str) -> tuple[int, str] | None:
        """(rover, topic) for a sample on a rover's own keys, None for anything the world or lander takes."""
        if not key.startswith(self._rover_head):
            return None
        rid, topic = self.keys.parse_rover_key(key)
        return None if topic in World.INPUT_TOPICS else (rid, topic)

    def _deliver(self, key: str, payload: bytes) -> list[Out]:
        world, lander = self.world, self.lander
        if key == self.keys.ground_command:  # the lander carries it out, the world follows it for its statistics
            return lander.handle(key, payload) + world.receive(key, payload)
        if key.startswith(self.keys.lander("")):
            return lander.handle(key, payload) if key != self.keys.lander(ks.COMM_OUT) else world.receive(key, payload)
        if key.startswith(self._rover_head):
            return world.receive(key, payload)
        return []

    def _next_phase(self) -> Heard:
        """The cascade is over: send the tick's clock if it waits for anyone, else step the world."""
        if self._clock is not None:
            clock, self._clock = self._clock, None
            clock = clock.model_copy(update={"acks": self.plan.ask(clock.tick, {ks.LANDER_ID, *self.rover_ids})})
            if clock.acks:  # as the world service: no clock on a tick that waits for nobody
                return self._send_clock(clock)
            return {}
        if self.world.sim_time >= self.max_sim_time or self.world.complete:
            self.over = True
            return {}
        self._step_world()
        return {}

    def _send_clock(self, clock: m.Clock) -> Heard:
        payload = codec.encode(clock)
        self._asked = [a for a in clock.acks or () if a != ks.LANDER_ID]
        for key, message in self.lander.handle(self.keys.clock, payload):
            if isinstance(message, m.Ack):
                self.plan.acked(ks.LANDER_ID, message.tick, message.wake)
            elif self.strict and ks.LANDER_ID not in (clock.acks or ()):
                raise AssertionError(f"the lander published {key} on tick {clock.tick}, which the world does not "
                                     "wait for: its next_wake() misses a timer")
            else:
                self._queue.append((key, message))
        self._clock_round = True
        return {rid: [(ks.CLOCK, payload)] for rid in self.rover_ids}

    def _step_world(self) -> None:
        world = self.world
        self._photos += world.photo_jobs
        world.photo_jobs = []
        due = [(self.keys.rover(job.rover_id, ks.PHOTO), world.render(job)) for job in self._photos
               if job.due_tick <= world.tick + 1]
        self._photos = [job for job in self._photos if job.due_tick > world.tick + 1]
        out = world.step()
        self._clock = next(message for key, message in out if key == self.keys.clock)
        self._queue += [*due, *((key, message) for key, message in out if key != self.keys.clock)]
        self.rounds_this_tick = 0
