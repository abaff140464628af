"""Control-loop latency over Zenoh: a Perception published by the world -> the rover's MoveAction received back.

Starts a real Zenoh router, one real rover agent (keeping its state in a file, as deployed; ``--no-state``: not) and
a bare Zenoh echo (``benchmarks/zenoh_floor.py``) as separate processes, and plays the world in this process: it
starts the run's clock, calibrates the rover, gives it a waypoint 100 m ahead, then runs ``--loops`` control loops
(after a few uncounted warm-up loops). Each loop publishes a Perception with no hits, times until the MoveAction
arrives, then answers as the world would (NavigationStatus "completed", a fresh Gyroscope) so the rover is idle and
ready to decide on the next Perception. The rover walks 9 m per move with the default parameters, so the world moves
the waypoint on (a new MissionDirection) before the rover can reach it.

Before each control loop, one ping of the same bytes goes through the same router to the echo and back: the
floor that Zenoh alone sets. Interleaved loop by loop, both see the same machine, and the benchmark prints the
ratio of the control loop's p50 and p99 to the floor's.

A third figure runs the same loop against ``RoverAgent.handle`` in this process with no Zenoh at all
(decode + decide + encode of the reply), to show how much of the round trip is transport. Its loops keep the same
``--gap-ms`` of quiet: after one, the agent's code runs from cold caches at several times its cost back to back,
and so does the rover's over Zenoh.

    python benchmarks/control_loop_latency.py [--loops 1000] [--port P] [--no-state] [--json FILE]
    python benchmarks/control_loop_latency.py --quick     # 50 loops: a smoke check in seconds

Targets: p50 under 1 ms and p99 under 5 ms on loopback, and both within 1.2 times the floor.
"""

from __future__ import annotations

import argparse
import contextlib
import queue
import signal
import socket
import sys
import tempfile
import threading
import time
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import quick
import zenoh
from control_loop_world import ScriptedWorld
from latency_summary import Summary, print_table, write_json
from zenoh_floor import FloorLink, start_echo

from bus.zenoh_config import RouterUnreachable, build_config, open_session, port_in_use
from deploy.children import Children, wait_for_port
from rover_agent.agent import RoverAgent
from schemas import codec
from schemas import keyspace as ks
from schemas import messages as m
from schemas.params import RoverParams

WORLD = "bench"
ROVER_ID = 1
HOST = "127.0.0.1"
QUICK = {"loops": 50, "warmup": 10, "timeout": 10.0}
"""``--quick``: the same loops end to end, fewer of them, and patient with a machine busy with other work."""
STARTUP_DEADLINE_S = 20.0


class BenchmarkError(RuntimeError):
    """Something the benchmark cannot measure through; the message says what and where to look."""


# ---- over Zenoh: router and rover as processes ----


def free_port() -> int:
    with socket.socket() as s:
        s.bind((HOST, 0))
        return s.getsockname()[1]


class RoverLink:
    """The benchmark's Zenoh session, playing the world for rover ROVER_ID."""

    def __init__(self, session: zenoh.Session, keys: ks.Keyspace) -> None:
        self.session = session
        self.keys = keys
        self.actions: queue.SimpleQueue[tuple[str, bytes]] = queue.SimpleQueue()
        self.statuses: queue.SimpleQueue[bytes] = queue.SimpleQueue()
        self.alive = threading.Event()
        self._declared: list = []
        self._publishers: dict[str, zenoh.Publisher] = {}
        rover = keys.rover
        self._declared.append(session.declare_subscriber(rover(ROVER_ID, ks.MOVE_ACTION), self._on_action))
        for other in (ks.ROTATE_ACTION, ks.CANCEL_ACTION):  # the benchmark never expects these: report them
            self._declared.append(session.declare_subscriber(rover(ROVER_ID, other), self._on_action))
        self._declared.append(session.declare_subscriber(rover(ROVER_ID, ks.STATUS),
                                                         lambda s: self.statuses.put(s.payload.to_bytes())))
        self._declared.append(session.liveliness().declare_subscriber(keys.alive_rover(ROVER_ID), self._on_alive,
                                                                      history=True))

    def _on_action(self, sample: zenoh.Sample) -> None:
        # only enqueue: the clock is read where the world's loop takes the sample, in the main thread
        topic = str(sample.key_expr).rsplit("/", 1)[-1]
        self.actions.put((topic, sample.payload.to_bytes()))

    def _on_alive(self, sample: zenoh.Sample) -> None:
        if sample.kind == zenoh.SampleKind.PUT:
            self.alive.set()

    def put(self, topic: str, payload: bytes) -> None:
        publisher = self._publishers.get(topic)
        if publisher is None:
            publisher = self._publishers[topic] = self.session.declare_publisher(self.keys.rover(ROVER_ID, topic))
        publisher.put(payload)

    def publish(self, topic: str, message: m.Message) -> None:
        self.put(topic, codec.encode(message))

    def publish_clock(self, clock: m.Clock) -> None:
        self.session.put(self.keys.clock, codec.encode(clock))

    def close(self) -> None:
        for entity in [*reversed(self._declared), *self._publishers.values()]:
            with contextlib.suppress(zenoh.ZError):
                entity.undeclare()
        self._declared.clear()
        self._publishers.clear()
        self.session.close()


def start_processes(children: Children, port: int, keep_state: bool) -> str:
    endpoint = f"tcp/{HOST}:{port}"
    router = children.start("router", "deploy.router", "--listen", endpoint)
    if not wait_for_port(HOST, port, STARTUP_DEADLINE_S, router):
        raise BenchmarkError(f"the Zenoh router did not open {endpoint} within {STARTUP_DEADLINE_S:g} s"
                             + _tail(children, "router"))
    # as deployed, the agent keeps its state in a file; a fresh one, or a state left by an earlier run of the
    # benchmark (same run name) would be resumed
    state = ("--state", str(children.log_dir / "rover1.json")) if keep_state else ("--no-state",)
    children.start("rover", "rover_agent", "--id", str(ROVER_ID), "--world", WORLD, "--connect", endpoint, *state)
    children.procs["floor"] = start_echo(endpoint, children.log_dir / "floor.log")
    return endpoint


def _tail(children: Children, name: str) -> str:
    tail = children.log_tail(name, 10)
    code = children.procs[name].poll() if name in children.procs else None
    state = f"exited with code {code}" if code is not None else "still running"
    return f"\n--- {name} ({state}), last lines of its log:\n{tail or '(empty)'}"


def wait_until_alive(link: RoverLink, children: Children) -> float:
    start = time.monotonic()
    deadline = start + STARTUP_DEADLINE_S
    key = link.keys.alive_rover(ROVER_ID)
    while not link.alive.wait(0.1):
        if children.dead():
            raise BenchmarkError(f"a child process exited before {key} appeared: {children.dead()}"
                                 + _tail(children, "rover") + _tail(children, "router"))
        if time.monotonic() >= deadline:
            raise BenchmarkError(f"rover {ROVER_ID} did not show up: no liveliness token {key} within "
                                 f"{STARTUP_DEADLINE_S:g} s" + _tail(children, "rover"))
    return time.monotonic() - start


def handshake(link: RoverLink, world: ScriptedWorld, children: Children) -> None:
    """Send the setup until the rover answers the MissionDirection with a RoverStatus (it has them all)."""
    deadline = time.monotonic() + STARTUP_DEADLINE_S
    setup = world.setup()
    while True:
        link.publish_clock(world.clock())
        for topic, message in setup:
            link.publish(topic, message)
        try:
            while True:
                status = codec.decode(m.RoverStatus, link.statuses.get(timeout=0.5))
                if status.goal_index == world.goal_index and status.state == "migration":
                    return
        except queue.Empty:
            pass
        if time.monotonic() >= deadline or children.dead():
            raise BenchmarkError(f"rover {ROVER_ID} never acknowledged its calibration and mission direction "
                                 f"within {STARTUP_DEADLINE_S:g} s" + _tail(children, "rover"))


@dataclass
class ZenohRun:
    samples_ns: list[int]
    floor_ns: list[int]
    """The bare Zenoh round trip taken just before each control loop (``benchmarks/zenoh_floor.py``)."""
    missed: int = 0
    """Perceptions the rover never answered (see ``control_loop``); each was followed by a fresh one."""


def measure_zenoh(link: RoverLink, floor: FloorLink, world: ScriptedWorld, args: argparse.Namespace,
                  children: Children) -> ZenohRun:
    """Each loop: one ping to the echo, then one control loop, each after ``--gap-ms`` of quiet, so the floor and
    the loop see the same machine (its load drifts) and the same idle Zenoh threads."""
    run = ZenohRun([], [])
    ping = codec.encode(m.Perception(stamp=0.0, angles_deg=[], distances_m=[], kinds=[]))  # the loop's bytes
    gap_s = args.gap_ms / 1000
    for i in range(args.warmup + args.loops):
        floor_ns = floor.ping(ping, args.timeout)
        if floor_ns is None:
            raise BenchmarkError(f"loop {i}: the bare Zenoh echo did not answer within {args.timeout:g} s"
                                 + _tail(children, "floor"))
        _pause(gap_s)
        loop_ns = control_loop(i, link, world, args, children, run)
        if i >= args.warmup:
            run.floor_ns.append(floor_ns)
            run.samples_ns.append(loop_ns)
        _pause(gap_s)  # let the rover take the action's end in before the next Perception, as between 5 Hz scans
    return run


def _pause(seconds: float) -> None:
    if seconds > 0:
        time.sleep(seconds)


def control_loop(i: int, link: RoverLink, world: ScriptedWorld, args: argparse.Namespace, children: Children,
                 run: ZenohRun) -> int:
    """Time one Perception -> MoveAction round trip, then answer the action as the world would; after
    ``--stall-ms`` without an answer, send a fresh Perception.

    The rover's ``Bus`` subscribes to each key separately and zenoh-python runs each subscriber's callback
    on its own thread, so the rover may take a Perception before the world's NavigationStatus or Gyroscope
    sent just before it. The agent then ignores that Perception (still in flight, or gyroscope too old) and
    waits for the next one, as it would in a real run where the next comes one perception period later.
    Here the world sends a fresh Perception (the late messages have arrived by then) and counts the miss;
    the loop is timed from the Perception that was answered.
    """
    perf = time.perf_counter_ns
    deadline = time.monotonic() + args.timeout
    while True:
        payload = codec.encode(world.perception())
        start = perf()
        link.put(ks.PERCEPTION, payload)
        try:
            topic, reply = link.actions.get(timeout=args.stall_ms / 1000)
            break
        except queue.Empty:
            pass
        if time.monotonic() >= deadline or children.dead():
            raise BenchmarkError(f"loop {i}: no MoveAction within {args.timeout:g} s of the first Perception"
                                 + _tail(children, "rover")) from None
        run.missed += 1
    elapsed = perf() - start
    if topic != ks.MOVE_ACTION:
        raise BenchmarkError(f"loop {i}: the rover sent {topic} ({reply!r}) where a move_action was expected")
    for topic_out, message in world.action_done(codec.decode(m.MoveAction, reply)):
        link.publish(topic_out, message)
    return elapsed


# ---- in process: the agent alone ----


def measure_in_process(loops: int, warmup: int, gap_s: float) -> list[int]:
    """The same loop through ``RoverAgent.handle``: decode the Perception, decide, encode the reply; ``gap_s`` of
    quiet before each, as over Zenoh."""
    world = ScriptedWorld()
    agent = RoverAgent(ROVER_ID, ks.Keyspace(WORLD), RoverParams())
    move_key = agent.keys.rover(ROVER_ID, ks.MOVE_ACTION)
    agent.on_clock(world.clock())
    for topic, message in world.setup():
        agent.handle(topic, codec.encode(message))
    samples: list[int] = []
    perf = time.perf_counter_ns
    for i in range(warmup + loops):
        payload = codec.encode(world.perception())
        _pause(gap_s)
        start = perf()
        out = agent.handle(ks.PERCEPTION, payload)
        for _key, message in out:
            codec.encode(message)  # what the runtime's publish does with each reply
        elapsed = perf() - start
        action = next((message for key, message in out if key == move_key), None)
        if action is None:
            raise BenchmarkError(f"in-process loop {i}: the agent answered {out!r} instead of a MoveAction")
        if i >= warmup:
            samples.append(elapsed)
        for topic, message in world.action_done(action):
            agent.handle(topic, codec.encode(message))
    return samples


# ---- command line ----


def parse_args(argv: list[str] | None = None) -> argparse.Namespace:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--loops", type=int, default=1000, help="timed control loops (default 1000)")
    parser.add_argument("--warmup", type=int, default=50, help="untimed loops first (default 50)")
    parser.add_argument("--port", type=int, default=0, help="router TCP port on 127.0.0.1 (default: a free one)")
    parser.add_argument("--json", type=Path, metavar="FILE", help="also write the figures to FILE as JSON")
    parser.add_argument("--timeout", type=float, default=2.0, metavar="S",
                        help="seconds to wait for each MoveAction before giving up (default 2)")
    parser.add_argument("--stall-ms", type=float, default=100.0, metavar="MS",
                        help="a Perception unanswered this long counts as missed and a fresh one is sent "
                             "(default 100)")
    parser.add_argument("--gap-ms", type=float, default=20.0, metavar="MS",
                        help="pause after answering an action before the next Perception, so the rover is idle "
                             "when it arrives, as between 5 Hz scans (default 20; longer gaps measure the same, "
                             "shorter ones keep Zenoh's threads awake and measure less; 0 sends back to back)")
    parser.add_argument("--no-state", action="store_true",
                        help="run the rover with --no-state: without the state file it keeps as deployed (its "
                             "write, after each action, shares the machine with the action on its way)")
    args = quick.parse_args(parser, QUICK, argv)
    if args.loops < 1 or args.warmup < 0:
        parser.error("--loops must be 1 or more and --warmup 0 or more")
    if args.gap_ms < 0 or args.stall_ms <= 0 or args.timeout <= 0:
        parser.error("--gap-ms must be 0 or more, --stall-ms and --timeout more than 0")
    if not 0 <= args.port <= 65535:
        parser.error("--port must be between 0 and 65535")
    return args


def run(args: argparse.Namespace) -> int:
    port = args.port or free_port()
    if port_in_use(HOST, port):
        raise BenchmarkError(f"port {port} on {HOST} is already in use; pick another --port")
    keys = ks.Keyspace(WORLD)
    with tempfile.TemporaryDirectory(prefix="lunarsim-bench-") as logs:
        children = Children(Path(logs))
        session: zenoh.Session | None = None
        link: RoverLink | None = None
        floor: FloorLink | None = None
        try:
            endpoint = start_processes(children, port, keep_state=not args.no_state)
            session = open_session(build_config(connect=[endpoint]), endpoint, 10.0, who="benchmark")
            link, floor = RoverLink(session, keys), FloorLink(session)
            print(f"router on {endpoint}; waiting for rover {ROVER_ID} ...", file=sys.stderr, flush=True)
            took = wait_until_alive(link, children)
            world = ScriptedWorld()
            handshake(link, world, children)
            if not floor.wait_for_echo(STARTUP_DEADLINE_S):
                raise BenchmarkError(f"the bare Zenoh echo did not answer within {STARTUP_DEADLINE_S:g} s"
                                     + _tail(children, "floor"))
            print(f"rover {ROVER_ID} alive after {took:.2f} s; running {args.warmup} warm-up + {args.loops} loops",
                  file=sys.stderr, flush=True)
            over_zenoh = measure_zenoh(link, floor, world, args, children)
        finally:
            if floor is not None:
                floor.close()
            if link is not None:
                link.close()
            elif session is not None:
                session.close()
            children.stop(grace_s=5.0)  # SIGTERM, then SIGKILL after 5 s
    local = measure_in_process(args.loops, args.warmup, args.gap_ms / 1000)
    z, bare, loc = Summary.of(over_zenoh.samples_ns), Summary.of(over_zenoh.floor_ns), Summary.of(local)
    print_table(z, bare, loc, endpoint, over_zenoh.missed, args, ROVER_ID)
    if args.json:
        write_json(args.json, z, bare, loc, args, endpoint, over_zenoh.missed)
        print(f"figures written to {args.json}")
    return 0


def _interrupt(signum: int, frame: object) -> None:
    raise KeyboardInterrupt


def guarded(run: Callable[[argparse.Namespace], int], args: argparse.Namespace, interrupted: str) -> int:
    """``run(args)`` as a command: a terminated benchmark cleans up as on Ctrl-C, a failure is one ``error:`` line
    and exit 1, an interrupt says ``interrupted`` and exits 130."""
    signal.signal(signal.SIGTERM, _interrupt)
    try:
        return run(args)
    except (BenchmarkError, RouterUnreachable) as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 1
    except KeyboardInterrupt:
        print(interrupted, file=sys.stderr)
        return 130


def main(argv: list[str] | None = None) -> int:
    return guarded(run, parse_args(argv), "interrupted")


if __name__ == "__main__":
    sys.exit(main())
