"""Twin mode: the world follows real rovers from their drivers' telemetry instead of simulating them.

Each rover's driver bridge publishes its own pose estimate (``Telemetry``: wheel odometry and IMU heading,
relative to where the driver started, in the rover-relative axes: +z ahead at the start, +x to the right).
The twin places it on the map from the scenario's start pose and builds the same ``WorldState`` the
simulated world publishes, so viewers, the recorder and the statistics (``MissionStats``) work unchanged.
The drivers do the sensing, moving, radio and camera; the twin only watches.

Like ``World`` this class does no I/O (samples in, (key, message) pairs out) and it offers the interface the
world service's clock loop drives (``served.ServedWorld``), in real time only.
"""

from __future__ import annotations

import logging
import math
from collections.abc import Callable, Collection
from typing import TYPE_CHECKING, Any, ClassVar

import numpy as np

from bus.rejections import Rejections
from schemas import codec
from schemas import keyspace as ks
from schemas import messages as m
from schemas.messages import Out
from schemas.scenario import Scenario
from shared.mission import RoverMissions
from shared.pose import Pose
from world_service.clock import Clock, tick_length
from world_service.outcome import statistics as stats
from world_service.outcome.completion import Completion, relay_wait_s
from world_service.radio.graph import CommGraph, build_graph
from world_service.twin.rovers import TwinRover, rover_truth

if TYPE_CHECKING:
    from world_service.camera.photos import PhotoJob

log = logging.getLogger("lunarsim.world")


def radio_links(partners: dict[int, list[int]]) -> list[tuple[int, int]]:
    """Links as the radios report them: a pair is linked when either side hears the other."""
    return sorted({(min(a, b), max(a, b)) for a, ids in partners.items() for b in ids if a != b})


def radio_graph(ids: list[int], links: list[tuple[int, int]]) -> CommGraph:
    """The graph of reported links: every pair counts as in range, and only the reported ones hear each other."""
    index = {node: i for i, node in enumerate(ids)}
    heard = np.zeros((len(ids), len(ids)), bool)
    for a, b in links:
        heard[index[a], index[b]] = heard[index[b], index[a]] = True
    here = np.zeros(len(ids))
    return build_graph(np.array(ids), here, here, math.inf, math.inf, lambda i, j: heard[i, j])


class TwinWorld:
    RENDERS_PHOTOS: ClassVar[bool] = False
    """No camera: the drivers take the photos."""
    RESUMABLE: ClassVar[bool] = False
    """Real rovers hold their own state: there is nothing of theirs to resume."""
    INPUT_TOPICS: ClassVar[tuple[str, ...]] = (ks.TELEMETRY, ks.STATUS, ks.COMM_PARTNERS)
    """Rover keys the twin follows; the lander's comm_partners, ground commands and liveliness as well."""

    def __init__(self, scenario: Scenario, keyspace: ks.Keyspace) -> None:
        self.scenario, self.keys = scenario, keyspace
        self.clock = Clock(tick_length(scenario.rover_params))  # its hold is never used: real time does not stop
        self.state_period = self.clock.period(scenario.rover_params.perception.publish_frequency)
        self.stats_period = self.clock.period(1.0)
        self.mission_stats = stats.MissionStats(scenario, RoverMissions(scenario))
        self.missions = self.mission_stats.missions
        self.bodies = {i + 1: TwinRover(i + 1, Pose(r.x, r.z, r.heading_deg % 360.0))
                       for i, r in enumerate(scenario.rovers)}
        self.status = {rid: m.RoverStatus(stamp=0.0, state="waiting") for rid in self.bodies}
        self.alive = dict.fromkeys(self.bodies, True)
        self.partners: dict[int, list[int]] = {}  # node (0 the lander) -> ids its radio hears
        self.graph = radio_graph([ks.LANDER_ID, *self.bodies], [])
        self.rejected = Rejections(log)
        self.dropped_messages = 0  # counted by the service's inbox; the twin does not report it
        self.completion = Completion(relay_wait_s(scenario.rover_params))
        self.handlers: dict[str, Callable[[int, Any], None]] = {
            ks.TELEMETRY: self._on_telemetry, ks.STATUS: self._on_status, ks.COMM_PARTNERS: self._on_partners}

    @classmethod
    def input_keys(cls, keys: ks.Keyspace) -> list[str]:
        return [*(keys.rovers(topic) for topic in cls.INPUT_TOPICS), keys.lander(ks.COMM_PARTNERS),
                keys.ground_command]

    @property
    def rover_ids(self) -> Collection[int]:
        return self.bodies.keys()

    @property
    def completed_at(self) -> float | None:
        return self.completion.at

    @property
    def complete(self) -> bool:
        return self.completed_at is not None

    def take_photo_jobs(self) -> list[PhotoJob]:
        return []

    def render(self, job: PhotoJob) -> m.Photo:
        raise ValueError("the twin has no camera: the rovers' drivers take the photos")

    # ---- input ----

    def receive(self, key: str, payload: bytes) -> list[Out]:
        """Handle one sample; a bad one is logged, counted and answered with nothing."""
        try:
            self._receive(key, payload)
        except (codec.DecodeError, ValueError) as exc:
            self.count_rejected(key, exc)
        return []

    def count_rejected(self, key: str, exc: Exception) -> None:
        self.rejected.count(key.rsplit("/", 1)[-1], exc, key)

    def _receive(self, key: str, payload: bytes) -> None:
        if key == self.keys.ground_command:
            self.mission_stats.command(codec.decode(m.GroundCommand, payload))
        elif key == self.keys.lander(ks.COMM_PARTNERS):
            self._on_partners(ks.LANDER_ID, codec.decode(m.CommPartners, payload))
        else:
            rid, topic = self.keys.parse_rover_key(key)
            if rid not in self.bodies:
                raise ValueError(f"no rover {rid} in scenario {self.scenario.name!r} (ids 1..{len(self.bodies)})")
            handler = self.handlers.get(topic)
            if handler is None:
                raise ValueError(f"topic {topic!r} is not an input of the twin")
            handler(rid, codec.decode(m.TOPIC_MODELS[topic], payload))

    def _on_telemetry(self, rid: int, msg: m.Telemetry) -> None:
        self.bodies[rid].follow(msg, self.clock.sim_time)

    def _on_status(self, rid: int, msg: m.RoverStatus) -> None:
        self.status[rid] = msg

    def _on_partners(self, node: int, msg: m.CommPartners) -> None:
        unknown = sorted(set(msg.ids) - {ks.LANDER_ID, *self.bodies})
        if unknown:
            raise ValueError(f"comm_partners of node {node} names ids not in the scenario: {unknown}")
        self.partners[node] = list(msg.ids)
        self.graph = radio_graph([ks.LANDER_ID, *self.bodies], radio_links(self.partners))

    def set_lander_alive(self, alive: bool) -> None:
        self.completion.note_lander(alive, self.clock.sim_time)

    def set_alive(self, rover_id: int, alive: bool) -> None:
        """Liveliness of the rover's agent; the twin cannot stop a real rover, it only records it."""
        if rover_id in self.bodies:
            self.alive[rover_id] = alive

    # ---- time ----

    def step(self) -> list[Out]:
        """Advance one tick and return what the world publishes for it (state, statistics, clock)."""
        clock = self.clock
        clock.tick += 1
        for rover in self.bodies.values():
            rover.check_stale(clock.sim_time)
        out: list[Out] = []
        if clock.tick % self.state_period == 0:
            out.append((self.keys.state, self.observed_state()))
        if clock.tick % self.stats_period == 0:
            out.append((self.keys.stats, m.WorldStats(stamp=clock.sim_time, report=self.report())))
        self.completion.check(clock.sim_time, self.status, {rid: r.in_motion for rid, r in self.bodies.items()},
                              self._reaches_lander)
        out.append((self.keys.clock, clock.message()))
        return out

    def _reaches_lander(self) -> dict[int, bool]:
        return dict(zip(self.graph.ids.tolist(), self.graph.connected_to_lander().tolist(), strict=True))

    # ---- ground truth and statistics ----

    def world_state(self) -> m.WorldState:
        rovers = [rover_truth(r, self.status[rid], self._goal_distance(r), self.alive[rid])
                  for rid, r in self.bodies.items()]
        counters = m.WorldCounters(rejected_messages=self.rejected.total)
        return m.WorldState(stamp=self.clock.sim_time, rovers=rovers, comm_links=self.graph.links(),
                            relays=self.graph.relays(), counters=counters, completed_at=self.completed_at)

    def _goal_distance(self, rover: TwinRover) -> float:
        goal = self.missions.goal(rover.id, self.status[rover.id].goal_index)
        return stats.distance_to_goal(self.scenario, goal, rover.pose.x, rover.pose.z)

    def observed_state(self) -> m.WorldState:
        """The state to publish, counted into the statistics: they are computed from what is published."""
        state = self.world_state()
        self.mission_stats.observe(state)
        return state

    def report(self) -> m.MissionReport:
        if self.mission_stats.last is None:
            self.observed_state()
        return self.mission_stats.report()
