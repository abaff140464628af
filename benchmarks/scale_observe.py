"""What the scale benchmark sees of a running simulation: its own Zenoh session beside the agents, and /proc.

``Observer`` subscribes, through the same router as the agents, to the world's clock and statistics, to every
rover's liveliness token and to the sensors (perception, gyroscope, navigation status) and status of a few
sampled rovers. Callbacks only stamp the arrival time and enqueue; ``pump`` decodes in the caller's thread.

- Delivery latency of a sample: its arrival (wall clock) minus its Zenoh timestamp, which the publisher's
  ``Bus.put`` takes from its session's HLC (Unix-epoch NTP64, the same wall clock on one machine).
- Drops: gaps in the sim-time stamps of a rover's perception (one per perception period) and gyroscope (one per
  tick). Navigation status is sent only while an action runs, so its gaps say nothing: latency only.
- Agent lag: from the world publishing the clock tick a RoverStatus is stamped with to the agent publishing that
  status. An agent whose inbox backs up (too many agents for its process, a busy core) shows it here first.
- Schedule lateness (real time): how far behind its best the world published a perception or gyroscope sample,
  and how late that sample arrived by the world's schedule; latency alone cannot see a world that steps late.

What /proc says of the processes (CPU and memory) is ``proc_meter``'s.
"""

from __future__ import annotations

import bisect
import contextlib
import gc
import itertools
import math
import queue
import time
from collections import defaultdict
from dataclasses import dataclass, field
from typing import NamedTuple

import zenoh
from latency_summary import Summary

from bus.bus import zenoh_callback
from schemas import codec
from schemas import keyspace as ks
from schemas import messages as m

SENSOR_TOPICS = (ks.PERCEPTION, ks.GYROSCOPE, ks.NAVIGATION_STATUS)
GAP_CHECKED = (ks.PERCEPTION, ks.GYROSCOPE)
"""Topics published at a fixed rate whatever the rover does, so a gap in their stamps is a lost sample."""


class Arrival(NamedTuple):
    key: str
    payload: bytes
    published_ns: int | None
    received_ns: int
    alive: bool | None = None


class Reading(NamedTuple):
    """One sampled rover's sensor or status sample: its sim-time stamp and its wall-clock journey."""

    rover: int
    topic: str
    stamp: float
    published_ns: int
    received_ns: int


class ClockMark(NamedTuple):
    tick: int
    sim_time: float
    published_ns: int


@dataclass
class Final:
    stamp: float
    published_ns: int
    report: m.MissionReport


@dataclass
class Observer:
    session: zenoh.Session
    keys: ks.Keyspace
    sampled: list[int]
    alive: set[int] = field(default_factory=set)
    ticks: list[ClockMark] = field(default_factory=list)
    readings: list[Reading] = field(default_factory=list)
    final: Final | None = None
    rejected: int = 0
    first_clock_only: bool = False
    """Stop listening to the clock after its first running tick: a lockstep run is timed from that tick to the
    final statistics, and a clock heard every tick would wake this process every tick, on the cores it times."""
    _clock_subscriber: zenoh.Subscriber | None = None
    _inbox: queue.SimpleQueue[Arrival] = field(default_factory=queue.SimpleQueue)
    _declared: list = field(default_factory=list)

    def __post_init__(self) -> None:
        keys = self.keys
        self._clock_subscriber = self.session.declare_subscriber(keys.clock, zenoh_callback(self._on_sample))
        self._declared.append(self._clock_subscriber)
        data = [keys.stats, *(keys.rover(rid, topic) for rid in self.sampled for topic in (*SENSOR_TOPICS, ks.STATUS))]
        for key in data:
            self._declared.append(self.session.declare_subscriber(key, zenoh_callback(self._on_sample)))
        handler = zenoh_callback(self._on_alive)
        self._declared.append(self.session.liveliness().declare_subscriber(keys.alive_rovers, handler, history=True))

    # ---- Zenoh threads: stamp and enqueue, nothing else ----

    def _on_sample(self, sample: zenoh.Sample) -> None:
        now = time.time_ns()
        stamp = sample.timestamp
        published = stamp.get_time_as_ntp64().as_nanos() if stamp is not None else None
        self._inbox.put(Arrival(str(sample.key_expr), sample.payload.to_bytes(), published, now))

    def _on_alive(self, sample: zenoh.Sample) -> None:
        self._inbox.put(Arrival(str(sample.key_expr), b"", None, time.time_ns(), sample.kind == zenoh.SampleKind.PUT))

    # ---- the benchmark's thread ----

    def pump(self, timeout: float) -> None:
        """Take in everything that has arrived, waiting up to ``timeout`` for the first item."""
        try:
            item = self._inbox.get(timeout=timeout)
        except queue.Empty:
            return
        while True:
            self._take(item)
            try:
                item = self._inbox.get_nowait()
            except queue.Empty:
                return

    def pump_until(self, condition, timeout: float, check=None) -> bool:
        """Pump until ``condition()`` holds (True) or ``timeout`` passes (False); ``check()`` runs every pass."""
        deadline = time.monotonic() + timeout
        while not condition():
            if time.monotonic() >= deadline:
                return False
            self.pump(0.1)
            if check is not None:
                check()
        return True

    def _take(self, item: Arrival) -> None:
        if item.alive is not None:
            rover_id = self.keys.parse_alive_key(item.key)
            (self.alive.add if item.alive else self.alive.discard)(rover_id)
            return
        try:
            if item.key == self.keys.clock:
                self._on_clock(codec.decode(m.Clock, item.payload), item)
            elif item.key == self.keys.stats:
                self._on_stats(codec.decode(m.WorldStats, item.payload), item)
            else:
                self._on_rover(item)
        except codec.DecodeError:
            self.rejected += 1

    def _on_clock(self, clock: m.Clock, item: Arrival) -> None:
        if clock.running and item.published_ns is not None:
            self.ticks.append(ClockMark(clock.tick, clock.sim_time, item.published_ns))
            if self.first_clock_only and self._clock_subscriber is not None:
                self._declared.remove(self._clock_subscriber)
                self._clock_subscriber.undeclare()
                self._clock_subscriber = None

    def _on_stats(self, stats: m.WorldStats, item: Arrival) -> None:
        if stats.final and self.final is None:
            self.final = Final(stats.stamp, item.published_ns or item.received_ns, stats.report)

    def _on_rover(self, item: Arrival) -> None:
        rover_id, topic = self.keys.parse_rover_key(item.key)
        model = m.RoverStatus if topic == ks.STATUS else m.TOPIC_MODELS[topic]
        message = codec.decode(model, item.payload)
        if item.published_ns is not None:
            self.readings.append(Reading(rover_id, topic, message.stamp, item.published_ns, item.received_ns))

    @property
    def started(self) -> bool:
        return bool(self.ticks)

    def close(self) -> None:
        for entity in reversed(self._declared):
            with contextlib.suppress(zenoh.ZError):
                entity.undeclare()
        self._declared.clear()


@contextlib.contextmanager
def no_collector_pauses():
    """The cyclic garbage collector off while an observer watches, and its heap so far frozen out of later scans.

    A callback stamps a sample's arrival only once it holds the GIL, and a full collection of this process's
    heap held it for 110-150 ms: every sample arriving meanwhile was stamped late (all sampled rovers at once,
    at the same point of every 30 s window), a pause of the benchmark, not of the system it measures. A
    measurement makes no reference cycles worth collecting in its minutes; the collector runs again after it."""
    gc.collect()
    gc.freeze()
    gc.disable()
    try:
        yield
    finally:
        gc.enable()
        gc.unfreeze()
        gc.collect()


# ---- what the readings say ----


def sim_rate(ticks: list[ClockMark], start_ns: int, end_ns: int) -> tuple[float, float, float]:
    """(simulated seconds, wall seconds, their ratio) between the first and last clock published in the window."""
    inside = [t for t in ticks if start_ns <= t.published_ns <= end_ns]
    if len(inside) < 2:
        return 0.0, (end_ns - start_ns) / 1e9, 0.0
    sim = inside[-1].sim_time - inside[0].sim_time
    wall = (inside[-1].published_ns - inside[0].published_ns) / 1e9
    return sim, wall, sim / wall if wall > 0 else math.inf


def _period_ns(periods: dict[str, int], topic: str, dt: float, time_scale: float = 1.0) -> float:
    """A sensor topic's period in wall nanoseconds (``periods`` in ticks)."""
    return periods[topic] * dt / time_scale * 1e9


def delivery(readings: list[Reading], start_ns: int, end_ns: int, dt: float, periods: dict[str, int],
             time_scale: float | None) -> dict[str, dict]:
    """Per sensor topic: latency summary, samples later than one period (real time only), drops, reorders."""
    by_topic: dict[str, list[Reading]] = defaultdict(list)
    for r in readings:
        if start_ns <= r.received_ns <= end_ns and r.topic in SENSOR_TOPICS:
            by_topic[r.topic].append(r)
    out = {}
    for topic in SENSOR_TOPICS:
        rows = by_topic.get(topic, [])
        latencies = [r.received_ns - r.published_ns for r in rows]
        period_ns = _period_ns(periods, topic, dt, time_scale) if time_scale else None
        dropped = reordered = None
        if topic in GAP_CHECKED:
            gaps, reordered = _gaps(rows, dt, periods[topic])
            dropped = sum(g[2] for g in gaps)
        out[topic] = {
            "period_s": periods[topic] * dt,
            "received": len(rows),
            "latency_ms": vars(Summary.of(latencies)) if latencies else None,
            "over_one_period": sum(lat > period_ns for lat in latencies) if period_ns else None,
            "dropped": dropped,
            "out_of_order": reordered,
        }
    return out


def _gaps(rows: list[Reading], dt: float, period_ticks: int) -> tuple[list[tuple[int, int, int]], int]:
    """Over one topic's arrivals: the gaps, as (rover, first missing tick, samples missing), and the samples that
    arrived after a later one of the same rover."""
    last: dict[int, int] = {}
    gaps, reordered = [], 0
    for r in rows:  # arrival order
        tick = round(r.stamp / dt)
        previous = last.get(r.rover)
        if previous is not None and tick <= previous:
            reordered += 1
            continue
        if previous is not None and tick - previous > period_ticks:
            gaps.append((r.rover, previous + period_ticks, (tick - previous) // period_ticks - 1))
        last[r.rover] = tick
    return gaps, reordered


def agent_lag(readings: list[Reading], ticks: list[ClockMark], start_ns: int, end_ns: int,
              dt: float, time_scale: float | None) -> dict | None:
    """From the world's tick to the sampled agents' status stamped with it (ms). In real time the world publishes
    its clock every few ticks; a tick in between is placed by the clock before it and the time scale."""
    marks = sorted((t.tick, t.published_ns) for t in ticks)
    lags = []
    for r in readings:
        if r.topic == ks.STATUS and start_ns <= r.received_ns <= end_ns:
            tick = round(r.stamp / dt)
            i = bisect.bisect_right(marks, (tick, math.inf)) - 1
            if i < 0 or (marks[i][0] != tick and not time_scale):
                continue
            mark_tick, mark_ns = marks[i]
            lags.append(r.published_ns - (mark_ns + (tick - mark_tick) * dt / (time_scale or 1.0) * 1e9))
    return vars(Summary.of(lags)) if lags else None


def clock_missing(ticks: list[ClockMark], start_ns: int, end_ns: int, period_ticks: int) -> int:
    """World clock samples that never arrived in the window (in real time the world publishes one every
    ``period_ticks``)."""
    inside = [t.tick for t in ticks if start_ns <= t.published_ns <= end_ns]
    return sum(max(0, (b - a) // period_ticks - 1) for a, b in itertools.pairwise(inside))


def late_events(readings: list[Reading], start_ns: int, end_ns: int, dt: float, periods: dict[str, int],
                limit: int = 50) -> list[tuple[int, str, float, float, float]]:
    """The first ``limit`` sensor samples (real time) that arrived more than one period after they were published:
    (rover, topic, sim time, latency ms, seconds into the window). Late samples of many rovers at one moment
    point at a stall of the world, the router or the machine; one rover's alone at its process."""
    late = []
    for r in readings:
        if r.topic in SENSOR_TOPICS and start_ns <= r.received_ns <= end_ns:
            latency = r.received_ns - r.published_ns
            if latency > _period_ns(periods, r.topic, dt):
                late.append((r.rover, r.topic, round(r.stamp, 3), round(latency / 1e6, 1),
                             round((r.received_ns - start_ns) / 1e9, 3)))
    return late[:limit]


def drop_events(readings: list[Reading], start_ns: int, end_ns: int, dt: float, periods: dict[str, int],
                limit: int = 50) -> list[tuple[int, str, float, int]]:
    """The first ``limit`` gaps of each checked topic: (rover, topic, sim time of the first sample missing, how many
    are missing). The same sim times across rovers point at the world or the router, not at one link."""
    events = []
    for topic in GAP_CHECKED:
        rows = [r for r in readings if r.topic == topic and start_ns <= r.received_ns <= end_ns]
        gaps, _ = _gaps(rows, dt, periods[topic])
        events += [(rover, topic, round(tick * dt, 3), missing) for rover, tick, missing in gaps[:limit]]
    return events


def missing_samples(readings: list[Reading], start_ns: int, end_ns: int, dt: float,
                    periods: dict[str, int]) -> set[tuple[int, str, int]]:
    """Every sample of the checked topics missing in the window, as (rover, topic, tick)."""
    out = set()
    for topic in GAP_CHECKED:
        rows = [r for r in readings if r.topic == topic and start_ns <= r.received_ns <= end_ns]
        gaps, _ = _gaps(rows, dt, periods[topic])
        out |= {(rover, topic, tick + i * periods[topic]) for rover, tick, missing in gaps for i in range(missing)}
    return out


def schedule_lateness(readings: list[Reading], start_ns: int, end_ns: int, dt: float,
                      periods: dict[str, int]) -> dict | None:
    """Real time, against the world's schedule rather than the publisher's stamp: how far behind its best the world
    published each sampled sensor sample (``slip``: its publication minus its sim time, less the smallest such
    difference in the window), and how late it arrived by that schedule (``arrival``: slip plus delivery latency),
    with the samples that arrived more than one period late by it. Delivery latency alone does not see a world
    that steps late: it stamps a sample as it publishes it. Perception and gyroscope only: a navigation status
    also answers a command between ticks, stamped with the tick before."""
    rows = [r for r in readings if r.topic in GAP_CHECKED and start_ns <= r.received_ns <= end_ns]
    if not rows:
        return None
    offsets = [r.published_ns - round(r.stamp * 1e9) for r in rows]
    best = min(offsets)
    slip = [o - best for o in offsets]
    arrival = [s + r.received_ns - r.published_ns for s, r in zip(slip, rows, strict=True)]
    late = sum(a > _period_ns(periods, r.topic, dt) for a, r in zip(arrival, rows, strict=True))
    return {"slip_ms": vars(Summary.of(slip)), "arrival_ms": vars(Summary.of(arrival)), "over_one_period": late}


def combined_latency(readings: list[Reading], start_ns: int, end_ns: int) -> dict | None:
    lat = [r.received_ns - r.published_ns for r in readings
           if r.topic in SENSOR_TOPICS and start_ns <= r.received_ns <= end_ns]
    return vars(Summary.of(lat)) if lat else None


# ---- /proc ----
