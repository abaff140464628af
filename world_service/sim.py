"""The simulated world, one tick at a time, with no I/O: samples in, (key, message) pairs out.

The service (``world_service.service``) owns Zenoh and the clock; this class owns ground truth.
Keeping them apart lets the whole world be tested, and later stepped in lockstep, without a router.
"""

from __future__ import annotations

import logging
import uuid
from typing import ClassVar

import numpy as np

from bus.rejections import Rejections
from schemas import codec
from schemas import keyspace as ks
from schemas import messages as m
from schemas.mission import RoverMissions
from schemas.params import RoverParams
from schemas.scenario import Scenario
from world_service import navigation as nav
from world_service import statistics as stats
from world_service.actions import ActionLedger
from world_service.airtime import Airtime
from world_service.clock_hold import ClockHold
from world_service.completion import FINISHED_STATES, Completion, relay_wait_s
from world_service.energy import Energy
from world_service.perception import Perceiver
from world_service.photos import PhotoJob, render_photo
from world_service.progress import ProgressWatch
from world_service.scene import Scene, circle_pairs
from world_service.terrain import Heightmap
from world_service.terrain_views import UncachedView
from world_service.world_actions import ActionInputs
from world_service.world_radio import RadioLink

log = logging.getLogger("lunarsim.world")

Out = tuple[str, m.Message]
KIND_NAMES = np.array(m.HIT_KINDS)
CLOCK_HZ = 5.0
"""How often the clock is published in real time. Agents learn the time from every sample's stamp; the clock
drives their own timers, the shortest of which is a second, and tells them the world is there. At the tick rate
(20 Hz) it was 40% of what every agent received. In lockstep it goes out on every tick that waits for an ack."""
ACTION_RESEND_S = 1.0
SAVE_PERIOD_S = 1.0
"""Simulated seconds between two saves of the world's state (``world_service.resume``): a rover walks at most 3.5 m
in that time, which a restart may cost it."""
"""How often the world re-sends the end of a rover's last action until its agent's status says it has heard it."""


def tick_length(params: RoverParams) -> float:
    """The world's tick: the period of its fastest publication, so every rate is a whole number of ticks."""
    p = params
    return 1.0 / max(p.perception.publish_frequency, p.perception.gyroscope_frequency, p.navigation.publish_frequency)


def ticks_per_period(rate_hz: float, dt: float) -> int:
    return max(1, round(1.0 / (rate_hz * dt)))


class World(ActionInputs, RadioLink):
    RENDERS_PHOTOS: ClassVar[bool] = True
    """The service starts a camera process for it (a twin's photos come from the rovers' own cameras)."""

    def __init__(self, scenario: Scenario, keyspace: ks.Keyspace) -> None:
        self.scenario = scenario
        self.keys = keyspace
        self.params = scenario.rover_params
        self.rng = np.random.default_rng(scenario.seed)
        self.radio_rng = np.random.default_rng([scenario.seed, 1])  # its own stream: traffic never shifts the noise
        p = self.params
        self.dt = tick_length(p)
        self.perception_period = self._period(p.perception.publish_frequency)
        self.gyroscope_period = self._period(p.perception.gyroscope_frequency)
        self.status_period = self._period(p.navigation.publish_frequency)
        self.partners_period = self._period(p.communication.partners_frequency)
        self.stats_period = self._period(1.0)
        self.save_period = self._period(1.0 / SAVE_PERIOD_S)
        self.clock_period = self._period(CLOCK_HZ)
        self.activation_range = scenario.terrain_spec().chunk_activation_range_m
        self.tick = 0
        self.terrain = Heightmap.from_scenario(scenario, self.rng)  # first draw: photos.build_ground relies on it
        self.scene = Scene.from_scenario(scenario)
        self.mission_stats = stats.MissionStats(scenario, RoverMissions(scenario))
        self.missions = self.mission_stats.missions  # one bookkeeping of goals, followed with the ground's commands
        self.perceiver = Perceiver(self.scene, self.terrain, self.params)
        self.bodies = {i + 1: nav.RoverBody(i + 1, r.x, r.z, r.heading_deg % 360.0)
                       for i, r in enumerate(scenario.rovers)}
        self.status = {rid: m.RoverStatus(stamp=0.0, state="waiting") for rid in self.bodies}
        self.alive = dict.fromkeys(self.bodies, True)
        self.actions = ActionLedger(self._period(ACTION_RESEND_S))
        self.progress = ProgressWatch(p.watchdog.stall_after_s)
        self.stalled: frozenset[int] = frozenset()
        self.lander_status: m.LanderStatus | None = None
        self.resumes = 0  # restarts of the world service that resumed this run (``world_service.resume``)
        self._refused_on: dict[int, int] = {}  # rover -> the tick its last refusal was answered on
        self.refusals_held = 0
        self.dropped_messages = 0  # counted by the service's inbox, reported here
        self.rover_collisions = 0
        self.camera_free_at: dict[int, int] = {}  # rover -> first tick its camera may take another photo
        self.obstacle_collisions = 0
        self.rejected = Rejections(log)
        self.radio_dropped = 0
        self.radio_lost = 0
        self.photo_jobs: list[PhotoJob] = []
        self._in_flight_radio: list[tuple[int, Out]] = []  # (due tick, delivery) with latency
        self.completion = Completion(relay_wait_s(scenario.rover_params))
        self._positions: tuple[np.ndarray, np.ndarray, np.ndarray] | None = None
        self.time_scale = 1.0  # what the clock announces; the service paces the ticks
        self.lockstep = False
        self.hold = ClockHold()  # the ground's pause: the service holds the clock
        self.run_id = uuid.uuid4().hex[:12]  # not the seed's: two runs of one seed are still two runs
        self.graph = self._build_graph()
        self.airtime = Airtime(len(self.bodies) + 1, self.dt)
        self.energy = Energy(scenario, self.terrain, self.scene, keyspace, self.dt, list(self.bodies),
                             self.perception_period, self._period(p.power.publish_frequency)) if scenario.sun else None

    def _period(self, rate_hz: float) -> int:
        return ticks_per_period(rate_hz, self.dt)

    @property
    def sim_time(self) -> float:
        return self.tick * self.dt

    # ---- input ----

    def receive(self, key: str, payload: bytes) -> list[Out]:
        """Handle one sample from an agent; a bad one is logged, counted and answered with nothing."""
        try:
            if key == self.keys.ground_command:
                self._on_ground_command(codec.decode(m.GroundCommand, payload))
                return []
            if key == self.keys.lander(ks.COMM_OUT):
                return self._radio(ks.LANDER_ID, codec.decode(m.OutboundComm, payload), from_lander=True)
            if key == self.keys.lander(ks.STATUS):
                self.lander_status = codec.decode(m.LanderStatus, payload)
                return []
            rover_id, topic = self.keys.parse_rover_key(key)
            if rover_id not in self.bodies:
                raise ValueError(f"no rover {rover_id} in scenario {self.scenario.name!r} "
                                 f"(ids 1..{len(self.bodies)})")
            handler = self._handlers.get(topic)
            if handler is None:
                raise ValueError(f"topic {topic!r} is not an input of the world")
            return handler(self, rover_id, codec.decode(m.TOPIC_MODELS[topic], payload))
        except (codec.DecodeError, ValueError) as exc:
            self.count_rejected(key, exc)
            return []

    def count_rejected(self, key: str, exc: Exception) -> None:
        topic = key.rsplit("/", 1)[-1] if key.startswith(self.keys.prefix + "/") else "<other world>"
        self.rejected.count(topic, exc, key)

    def render(self, job: PhotoJob) -> m.Photo:
        """The photo rendered here (tests, the loopback); the service renders in a ``photos.CameraProcess``."""
        return render_photo(UncachedView(self.terrain), self.scene, self.params, job)

    def _on_ground_command(self, command: m.GroundCommand) -> None:
        """Follow the ground's changes to the mission, so statistics judge each rover's real final goal; pause,
        resume and step hold and release the clock (a replay follows them too)."""
        self.mission_stats.command(command)
        self.hold.command(command)

    def set_alive(self, rover_id: int, alive: bool) -> None:
        """Watchdog: a rover whose agent is gone stops where it is. When it comes back (its router restarted,
        its link returned, the agent restarted), the ledger re-sends how its action ended until it has heard."""
        if rover_id not in self.bodies:
            return
        self.alive[rover_id] = alive
        if not alive:
            self.bodies[rover_id].cancel()

    def resumed(self) -> None:
        """Loaded from a saved state by a restarted world service: every agent counts as gone until its liveliness
        token shows again (an agent that died meanwhile sent no word of it); the service waits for the tokens
        before the clock runs, as at the start."""
        self.resumes += 1
        self.alive = dict.fromkeys(self.bodies, False)
        self._positions = None

    def _activate_terrain(self) -> None:
        """Chunk activation (report 10.7.1): keep terrain tiles near rovers loaded, let far ones go."""
        points = np.array([(b.x, b.z) for b in self.bodies.values()])
        self.terrain.keep_near(points, self.activation_range)

    # ---- time ----

    def step(self) -> list[Out]:
        """Advance one tick and return everything the world publishes for it."""
        self.tick += 1
        out: list[Out] = []
        out += self._move_bodies()
        if self.energy is not None:
            out += self._power_step()
        if self.tick % self.partners_period == 0:
            self._activate_terrain()
            self.graph = self._build_graph()
        out += self._due_radio()
        out += self.actions.resend_due(self.tick, self.alive)
        out += self._sensors()
        self._check_complete()
        out.append((self.keys.clock, self.clock()))
        return out

    def clock(self, running: bool = True) -> m.Clock:
        return m.Clock(tick=self.tick, sim_time=self.sim_time, time_scale=self.time_scale, running=running,
                       lockstep=self.lockstep, run=self.run_id)

    def _move_bodies(self) -> list[Out]:
        """Step every busy rover, then stop short, as one batch, those that would touch something."""
        active = [b for b in self.bodies.values() if b.busy]
        if not active:
            return []
        factors = self._slope_factors([b for b in active if isinstance(b.action, nav.Move)])
        before = {b.id: (b.x, b.z, b.distance_covered) for b in active}
        ended = {b.id: nav.step(b, self.dt, self.params.navigation, factors.get(b.id, 1.0)) for b in active}
        moved = [b for b in active if (b.x, b.z) != before[b.id][:2]]
        for body in self._colliding(moved):
            body.x, body.z, body.distance_covered = before[body.id]
            # a move may have ended on this very step: its start is then in its end, and the agent needs the
            # CancelResult built from it (a "collided" status without one left the agent waiting for ever)
            done = ended[body.id]
            start = body.action.start if body.action is not None else done.start if done else None
            body.action, body.velocity = None, 0.0
            ended[body.id] = nav.Ended("move", "collided", start)
        self._positions = None
        return [o for b in active if ended[b.id] for o in self._ended(b, ended[b.id])]

    def _power_step(self) -> list[Out]:
        """Batteries, temperatures and light; a rover that has just gone off stops where it is."""
        out, gone_off = self.energy.step(self.tick, self.sim_time, list(self.bodies.values()))
        for rid in gone_off:
            self.bodies[rid].cancel()
            log.info("rover %d shut down at t = %.1f s: %s", rid, self.sim_time, self.energy.refusal(rid)[1])
        return out

    def _slope_factors(self, moving: list[nav.RoverBody]) -> dict[int, float]:
        if not moving:
            return {}
        pitch = self.terrain.pitch_deg(*(np.array([getattr(b, a) for b in moving]) for a in ("x", "z", "heading")))
        return dict(zip((b.id for b in moving), nav.slope_factor(pitch, self.params.navigation).tolist(),
                        strict=True))

    def _colliding(self, moved: list[nav.RoverBody]) -> list[nav.RoverBody]:
        """Movers now touching a rock, wall, the lander or another rover; counts each contact once."""
        if not moved:
            return []
        radius = self.params.behaviour.rover_radius
        mx, mz = np.array([b.x for b in moved]), np.array([b.z for b in moved])
        static = self.scene.contacts(mx, mz, radius)
        self.obstacle_collisions += int(static.sum())
        bodies = list(self.bodies.values())
        xs, zs = np.array([b.x for b in bodies]), np.array([b.z for b in bodies])
        index = {b.id: i for i, b in enumerate(bodies)}
        mover, other = circle_pairs(mx, mz, xs, zs, np.full(len(xs), radius), radius, 4 * radius)
        own = np.array([index[moved[i].id] for i in mover], int)
        touching = (other != own) & (np.hypot(xs[other] - mx[mover], zs[other] - mz[mover]) < 2 * radius)
        pairs = {tuple(sorted((int(own[k]), int(other[k])))) for k in np.nonzero(touching)[0]}
        self.rover_collisions += len(pairs)
        hit = {moved[i].id for i in np.nonzero(static)[0]} | {bodies[i].id for pair in pairs for i in pair}
        return [b for b in moved if b.id in hit]

    def _ended(self, body: nav.RoverBody, ended: nav.Ended) -> list[Out]:
        rid = body.id
        action_id = self.actions.running_id(rid)
        status = m.NavigationStatus(stamp=self.sim_time, action=ended.action, remaining=0.0, outcome=ended.outcome,
                                    action_id=action_id)
        out: list[Out] = [(self.keys.rover(rid, ks.NAVIGATION_STATUS), status)]
        if ended.outcome != "completed" and ended.start is not None:
            x, z, angle = body.relative_to_start(ended.start)
            out.append((self.keys.rover(rid, ks.CANCEL_RESULT),
                        m.CancelResult(x=x, z=z, angle_deg=angle, reason=ended.outcome, action_id=action_id)))
        self.actions.end(rid, out)
        return out

    def _sensors(self) -> list[Out]:
        bodies = list(self.bodies.values())
        xs, zs, hs = (np.array([getattr(b, a) for b in bodies]) for a in ("x", "z", "heading"))
        out = self._perceptions(bodies, xs, zs, hs)
        if self.tick % self.gyroscope_period == 0:
            out += self._gyroscopes(bodies, xs, zs, hs)
        for body in bodies:
            if body.busy and self.tick % self.status_period == 0:
                out.append(self._nav_status(body, "move" if isinstance(body.action, nav.Move) else "rotate"))
        if self.tick % self.partners_period == 0:
            out += [(self.keys.rover(b.id, ks.COMM_PARTNERS), m.CommPartners(ids=self.graph.partners(b.id)))
                    for b in bodies]
            out.append((self.keys.lander(ks.COMM_PARTNERS), m.CommPartners(ids=self.graph.partners(ks.LANDER_ID))))
        if self._observer_tick(self.perception_period):
            out.append((self.keys.state, self.observed_state()))
        if self._observer_tick(self.stats_period):
            out.append((self.keys.stats, m.WorldStats(stamp=self.sim_time, report=self.report())))
        return out

    def _observer_tick(self, period: int) -> bool:
        """Ground truth and statistics, which only observers read, go out half a period after the ticks that
        rebuild the radio graph and send every rover its partners. Together, at 100 rovers, those made one tick a
        second cost 15 ms of the world's CPU against 4 for the others, and in real time the ticks after it
        started late."""
        return self.tick % period == period // 2

    def _perceptions(self, bodies, xs, zs, hs) -> list[Out]:
        """Each rover scans once per perception period, the rovers staggered over the period's ticks.

        Staggered in lockstep too, though scanning all on one tick would leave more ticks waiting for nobody:
        rovers that decide on the same tick meet each other's right of way symmetrically, and in the daisy chain
        scenario that cost a rover its goal. Independent rovers do not share a clock phase either."""
        which = np.array([i for i, b in enumerate(bodies) if (self.tick + b.id) % self.perception_period == 0], int)
        scans = self.perceiver.scan(xs, zs, hs, which)
        # Built from checked arrays at 5 Hz per rover: skip re-validation (receivers still validate).
        return [(self.keys.rover(bodies[i].id, ks.PERCEPTION),
                 m.Perception.model_construct(stamp=self.sim_time, angles_deg=np.round(s.angles_deg, 3).tolist(),
                                              distances_m=np.round(s.distances_m, 3).tolist(),
                                              kinds=KIND_NAMES[s.kinds].tolist()))
                for i, s in zip(which, scans, strict=True)]

    def _gyroscopes(self, bodies, xs, zs, hs) -> list[Out]:
        pitch = self.terrain.pitch_deg(xs, zs, hs)
        noise = self.params.perception.gyroscope_noise_std_deg
        if noise > 0:
            pitch = pitch + self.rng.normal(0.0, noise, len(pitch))
        stamp = self.sim_time
        return [(self.keys.rover(b.id, ks.GYROSCOPE), m.Gyroscope(stamp=stamp, pitch_deg=p))
                for b, p in zip(bodies, np.round(pitch, 4).tolist(), strict=True)]

    def _nav_status(self, body: nav.RoverBody, action: str) -> Out:
        status = m.NavigationStatus(stamp=self.sim_time, action=action, remaining=round(body.remaining(), 4),
                                    action_id=self.actions.running_id(body.id))
        return self.keys.rover(body.id, ks.NAVIGATION_STATUS), status

    # ---- ground truth and statistics ----

    def _goal_of(self, rid: int):
        return self.missions.goal(rid, self.status[rid].goal_index)

    def world_state(self) -> m.WorldState:
        rovers = [self._truth(b) for b in self.bodies.values()]
        stalled = frozenset(r.id for r in rovers if r.stalled)
        for rid in sorted(stalled - self.stalled):
            log.warning("t = %.1f s: rover %d counted stuck: no nearer its goal for %g s", self.sim_time, rid,
                        self.params.watchdog.stall_after_s)
        self.stalled = stalled
        lander = (self.lander_status,) if self.lander_status is not None else ()
        counters = m.WorldCounters(rover_collisions=self.rover_collisions, obstacle_collisions=self.obstacle_collisions,
                                   rejected_messages=self.rejected.total, radio_dropped=self.radio_dropped,
                                   radio_lost=self.radio_lost, dropped_messages=self.dropped_messages,
                                   agent_rejected=sum(s.rejected for s in (*self.status.values(), *lander)),
                                   world_resumes=self.resumes, rovers_lost=sum(s.lost for s in self.status.values()),
                                   lander_map_lost=any(s.map_lost for s in lander),
                                   **(self.energy.counters() if self.energy is not None else {}))
        return m.WorldState(stamp=self.sim_time, rovers=rovers, comm_links=self.graph.links(),
                            relays=self.graph.relays(), counters=counters, completed_at=self.completed_at)

    def _truth(self, b: nav.RoverBody) -> m.RoverTruth:
        status = self.status[b.id]
        distance = round(stats.distance_to_goal(self.scenario, self._goal_of(b.id), b.x, b.z), 3)
        power = self.energy.truth(b.id) if self.energy is not None else {}
        waiting = status.state in FINISHED_STATES or status.state == "charging" or power.get("powered") is False
        stalled = self.progress.observe(b.id, status.goal_index, distance, self.sim_time, waiting)
        # validated: with few lists and six fields left to their defaults, faster than model_construct
        return m.RoverTruth(id=b.id, x=round(b.x, 4), z=round(b.z, 4), heading_deg=round(b.heading, 3),
                            action=self._action_name(b), state=status.state, goal_index=status.goal_index,
                            distance_to_goal_m=distance, distance_covered_m=round(b.distance_covered, 3),
                            alive=self.alive[b.id], stalled=stalled, **power)

    def observed_state(self) -> m.WorldState:
        """The state to publish, counted into the statistics: they are computed from what is published."""
        state = self.world_state()
        self.mission_stats.observe(state)
        return state

    @staticmethod
    def _action_name(body: nav.RoverBody) -> str:
        if isinstance(body.action, nav.Move):
            return "cancel" if body.action.cancelling else "move"
        return "rotate" if isinstance(body.action, nav.Rotate) else "idle"

    def _check_complete(self) -> None:
        self.completion.check(self.sim_time, self.status, {b.id: b.busy for b in self.bodies.values()},
                              self._reaches_lander, self.stalled)

    def _reaches_lander(self) -> dict[int, bool]:
        return dict(zip(self.graph.ids.tolist(), self.graph.connected_to_lander().tolist(), strict=True))

    @property
    def completed_at(self) -> float | None:
        return self.completion.at

    @property
    def complete(self) -> bool:
        return self.completed_at is not None

    def report(self) -> m.MissionReport:
        """Statistics as of the last published state (``lunarsim report`` gets the same from a recording)."""
        if self.mission_stats.last is None:
            self.observed_state()
        return self.mission_stats.report()
