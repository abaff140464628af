"""Twin mode: the world follows real rovers from their drivers' telemetry instead of simulating them.

Each rover's driver bridge publishes its own pose estimate (``Telemetry``: wheel odometry and IMU heading,
relative to where the driver started, in the rover-relative axes: +z ahead at the start, +x to the right).
The twin places it on the map from the scenario's start pose and builds the same ``WorldState`` the
simulated world publishes, so viewers, the recorder and the statistics (``MissionStats``) work unchanged.
The drivers do the sensing, moving, radio and camera; the twin only watches.

Like ``World`` this class does no I/O (samples in, (key, message) pairs out) and it offers the interface the
world service's clock loop drives (``world_service.service.run``), in real time only.
"""

from __future__ import annotations

import logging
import math
import uuid
from dataclasses import dataclass, field

import numpy as np

from bus.rejections import Rejections
from schemas import codec
from schemas import keyspace as ks
from schemas import messages as m
from schemas.frames import to_world
from schemas.mission import RoverMissions
from schemas.scenario import Scenario
from world_service import statistics as stats
from world_service.clock_hold import ClockHold
from world_service.completion import Completion, relay_wait_s
from world_service.radio import CommGraph, build_graph
from world_service.sim import CLOCK_HZ, Out, tick_length, ticks_per_period

log = logging.getLogger("lunarsim.world")

STALE_AFTER_S = 2.0
"""A rover whose driver has sent no telemetry for this long is marked stale (its last pose is kept)."""


@dataclass(frozen=True)
class Pose:
    x: float
    z: float
    heading_deg: float


def compose(start: Pose, telemetry: m.Telemetry) -> Pose:
    """Where a rover is on the map: its start pose moved by the driver's odometry (relative to that start)."""
    x, z = to_world(start.x, start.z, start.heading_deg, telemetry.x, telemetry.z)
    return Pose(x, z, (start.heading_deg + telemetry.heading_deg) % 360.0)


@dataclass
class TwinRover:
    """One real rover as the twin knows it: the last pose its driver reported, and the path summed so far.

    The driver's frame starts at the rover's start pose, so the path is counted from its origin: a twin
    that starts (or a sample that arrives) late bridges the gap with a straight line instead of losing it.
    """

    id: int
    start: Pose
    pose: Pose = field(init=False)
    distance_covered: float = 0.0
    moving: bool = False
    odometry: tuple[float, float] = (0.0, 0.0)  # last (x, z) in the driver's own frame
    last_sample_at: float = 0.0
    stale: bool = False

    def __post_init__(self) -> None:
        self.pose = self.start

    def follow(self, telemetry: m.Telemetry, now: float) -> None:
        here = (telemetry.x, telemetry.z)
        self.distance_covered += math.dist(self.odometry, here)
        self.odometry, self.pose, self.moving = here, compose(self.start, telemetry), telemetry.moving
        self.last_sample_at = now
        if self.stale:
            self.stale = False
            log.warning("rover %d: telemetry again after a gap", self.id)

    def check_stale(self, now: float) -> None:
        """Mark the rover stale once its telemetry stops, and say so once per gap."""
        if not self.stale and now - self.last_sample_at > STALE_AFTER_S:
            self.stale = True
            log.warning("rover %d: no telemetry for %g s; keeping its last pose until its driver reports again",
                        self.id, STALE_AFTER_S)

    @property
    def in_motion(self) -> bool:
        """Moving as far as the twin knows: a stale rover's last word does not hold the mission open."""
        return self.moving and not self.stale


def rover_truth(rover: TwinRover, status: m.RoverStatus, goal_distance_m: float, alive: bool) -> m.RoverTruth:
    pose = rover.pose
    return m.RoverTruth(id=rover.id, x=round(pose.x, 4), z=round(pose.z, 4), heading_deg=round(pose.heading_deg, 3),
                        action="move" if rover.in_motion else "idle", state=status.state,
                        goal_index=status.goal_index, distance_to_goal_m=round(goal_distance_m, 3),
                        distance_covered_m=round(rover.distance_covered, 3), alive=alive,
                        telemetry_stale=rover.stale)


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
    INPUT_TOPICS = (ks.TELEMETRY, ks.STATUS, ks.COMM_PARTNERS)
    """Rover keys the twin follows; the lander's comm_partners, ground commands and liveliness as well."""
    RENDERS_PHOTOS = False

    def __init__(self, scenario: Scenario, keyspace: ks.Keyspace) -> None:
        self.run_id = uuid.uuid4().hex[:12]
        self.scenario, self.keys = scenario, keyspace
        self.hold = ClockHold()  # never paused: the twin follows real rovers, whose time does not stop
        self.dt = tick_length(scenario.rover_params)
        self.state_period = ticks_per_period(scenario.rover_params.perception.publish_frequency, self.dt)
        self.stats_period = ticks_per_period(1.0, self.dt)
        self.clock_period = ticks_per_period(CLOCK_HZ, self.dt)
        self.tick = 0
        self.mission_stats = stats.MissionStats(scenario, RoverMissions(scenario))
        self.missions = self.mission_stats.missions
        self.bodies = {i + 1: TwinRover(i + 1, Pose(r.x, r.z, r.heading_deg % 360.0))
                       for i, r in enumerate(scenario.rovers)}
        self.status = {rid: m.RoverStatus(stamp=0.0, state="waiting") for rid in self.bodies}
        self.alive = dict.fromkeys(self.bodies, True)
        self.partners: dict[int, list[int]] = {}  # node (0 the lander) -> ids its radio hears
        self.graph = radio_graph([ks.LANDER_ID, *self.bodies], [])
        self.rejected = Rejections(log)
        self.completion = Completion(relay_wait_s(scenario.rover_params))
        self.time_scale, self.lockstep = 1.0, False
        self.photo_jobs: list = []  # no camera: the drivers take the photos

    @property
    def sim_time(self) -> float:
        return self.tick * self.dt

    @property
    def completed_at(self) -> float | None:
        return self.completion.at

    @property
    def complete(self) -> bool:
        return self.completed_at is not None

    # ---- input ----

    def receive(self, key: str, payload: bytes) -> list[Out]:
        """Handle one sample; a bad one is logged, counted and answered with nothing."""
        try:
            self._receive(key, payload)
        except (codec.DecodeError, ValueError) as exc:
            self.rejected.count(key.rsplit("/", 1)[-1], exc, key)
        return []

    def _receive(self, key: str, payload: bytes) -> None:
        if key == self.keys.ground_command:
            self.mission_stats.command(codec.decode(m.GroundCommand, payload))
        elif key == self.keys.lander(ks.COMM_PARTNERS):
            self._on_partners(ks.LANDER_ID, codec.decode(m.CommPartners, payload))
        else:
            rid, topic = self.keys.parse_rover_key(key)
            if rid not in self.bodies:
                raise ValueError(f"no rover {rid} in scenario {self.scenario.name!r} (ids 1..{len(self.bodies)})")
            if topic not in self.INPUT_TOPICS:
                raise ValueError(f"topic {topic!r} is not an input of the twin")
            message = codec.decode(m.TOPIC_MODELS[topic], payload)
            if topic == ks.TELEMETRY:
                self.bodies[rid].follow(message, self.sim_time)
            elif topic == ks.STATUS:
                self.status[rid] = message
            else:
                self._on_partners(rid, message)

    def _on_partners(self, node: int, msg: m.CommPartners) -> None:
        unknown = sorted(set(msg.ids) - {ks.LANDER_ID, *self.bodies})
        if unknown:
            raise ValueError(f"comm_partners of node {node} names ids not in the scenario: {unknown}")
        self.partners[node] = list(msg.ids)
        self.graph = radio_graph([ks.LANDER_ID, *self.bodies], radio_links(self.partners))

    def set_alive(self, rover_id: int, alive: bool) -> None:
        """Liveliness of the rover's agent; the twin cannot stop a real rover, it only records it."""
        if rover_id in self.bodies:
            self.alive[rover_id] = alive

    # ---- time ----

    def step(self) -> list[Out]:
        """Advance one tick and return what the world publishes for it (state, statistics, clock)."""
        self.tick += 1
        for rover in self.bodies.values():
            rover.check_stale(self.sim_time)
        out: list[Out] = []
        if self.tick % self.state_period == 0:
            out.append((self.keys.state, self.observed_state()))
        if self.tick % self.stats_period == 0:
            out.append((self.keys.stats, m.WorldStats(stamp=self.sim_time, report=self.report())))
        self.completion.check(self.sim_time, self.status, {rid: r.in_motion for rid, r in self.bodies.items()},
                              self._reaches_lander)
        out.append((self.keys.clock, self.clock()))
        return out

    def clock(self, running: bool = True) -> m.Clock:
        return m.Clock(tick=self.tick, sim_time=self.sim_time, time_scale=self.time_scale, running=running,
                       lockstep=False, run=self.run_id)

    def _reaches_lander(self) -> dict[int, bool]:
        return dict(zip(self.graph.ids.tolist(), self.graph.connected_to_lander().tolist(), strict=True))

    # ---- ground truth and statistics ----

    def world_state(self) -> m.WorldState:
        rovers = [rover_truth(r, self.status[rid], self._goal_distance(r), self.alive[rid])
                  for rid, r in self.bodies.items()]
        counters = m.WorldCounters(rejected_messages=self.rejected.total)
        return m.WorldState(stamp=self.sim_time, rovers=rovers, comm_links=self.graph.links(),
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
