"""The ROS 2 bridge under a real-time mission: does a ROS 2 subscriber get every sample, how much later than a plain
Zenoh subscriber, and what the bridge costs.

Part 1, five rovers: a router, the bridge (``lunarsim ros2``) and ``lunarsim run`` (world, lander, five agents) on
loopback, real time. A ``zenoh-ros2-sdk`` process (``ros2_sdk_meter.py``) subscribes to every rover's scan and imu
through the bridge, and this process subscribes to the same perception and gyroscope keys in plain Zenoh. Each
sample's trip is timed from the world's publication (its Zenoh timestamp) to each subscriber, side by side:
the bridge's added latency is the ROS 2 trip minus the plain one, both as the difference of the two trips' percentiles
and sample by sample (a sample's ROS 2 arrival minus its own plain arrival, whose percentiles leave out the delays
both trips share, such as the world's own publishing). A third, plain Zenoh subscriber on the bridge's
ROS 2 keys times arrival before decoding: the bridge's share without the SDK's. A trivial relay beside the bridge
(this script with ``--relay``) re-puts the world's samples unchanged from its receiving thread: the floor of any
bridge process, the extra hop through the router and a Python callback. Lost: world samples the SDK never got.

Part 2, twenty rovers: the world alone (``--no-lander``, no agents: every rover's sensors still flow), the bridge and
the SDK subscriber; the bridge's CPU time over a window, as a share of one core.

    python benchmarks/ros2_bridge.py [--quick] [--json FILE]
    python benchmarks/ros2_bridge.py --relay ENDPOINT     (the relay; the benchmark starts it)

Targets (issue): 0 samples lost on loopback; the bridge adds at most 2 ms at p99; 20 rovers under 20 % of a core.
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
import threading
import time
from pathlib import Path

import zenoh
from latency_summary import Summary
from proc_meter import cpu_seconds

from bus.zenoh_config import build_config
from deploy.children import wait_for_port
from schemas import codec
from schemas import messages as m
from schemas.keyspace import Keyspace

REPO = Path(__file__).resolve().parents[1]
SCENARIO = REPO / "scenarios" / "crater_observation.yaml"
WORLD = "rosbench"
TOPICS = {"perception": "scan", "gyroscope": "imu"}
TARGET_ADDED_P99_MS = 2.0
TARGET_CPU_SHARE = 0.20
RELAY_PREFIX = "relay/"


def _free_port() -> int:
    import socket

    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def _python(*args: str, log: Path, **kwargs) -> subprocess.Popen:
    return subprocess.Popen([sys.executable, *args], cwd=REPO, stdout=log.open("wb"), stderr=subprocess.STDOUT,
                            **kwargs)


def _wait_for_log(log: Path, line: str, timeout: float, proc: subprocess.Popen) -> None:
    """Until ``line`` shows in a process's log (the bridge serves the last rover once its first sample came)."""
    deadline = time.monotonic() + timeout
    while line not in log.read_text(errors="replace"):
        if proc.poll() is not None or time.monotonic() > deadline:
            raise RuntimeError(f"no {line.strip()!r} in {log.name} within {timeout:g} s: "
                               f"{log.read_text(errors='replace')[-500:]}")
        time.sleep(0.1)


def _stop(*procs: subprocess.Popen) -> None:
    for p in procs:
        if p.poll() is None:
            p.terminate()
    for p in procs:
        try:
            p.wait(timeout=30)
        except subprocess.TimeoutExpired:
            p.kill()


def _ntp64_ns(ts: zenoh.Timestamp) -> int:
    return ts.get_time_as_ntp64().as_nanos()


class PlainMeter:
    """Plain Zenoh subscribers on the world's perception and gyroscope keys. A callback only notes the arrival, the
    world's timestamp and the bytes; ``seen`` decodes them after the run, so no meter's decoding delays another's
    samples: (topic, stamp ns) -> (sent, got)."""

    def __init__(self, session: zenoh.Session, keys: Keyspace, prefix: str = "") -> None:
        self.raw: list[tuple[str, bytes, int, int]] = []
        self.lock = threading.Lock()
        self.prefix = prefix
        self.subs = [session.declare_subscriber(prefix + keys.rovers(topic), self._on) for topic in TOPICS]

    def _on(self, sample: zenoh.Sample) -> None:
        got = time.time_ns()
        row = (str(sample.key_expr), sample.payload.to_bytes(), _ntp64_ns(sample.timestamp), got)
        with self.lock:
            self.raw.append(row)

    def seen(self) -> dict[tuple[str, int], tuple[int, int]]:
        with self.lock:
            rows = list(self.raw)
        out = {}
        for key, payload, sent, got in rows:
            parts = key.removeprefix(self.prefix).split("/")
            topic = TOPICS[parts[4]]
            stamp = codec.decode(m.Perception if topic == "scan" else m.Gyroscope, payload).stamp
            out[(f"/rover_{parts[3]}/{topic}", round(stamp * 1e9))] = (sent, got)
        return out


class RawRosMeter:
    """Plain Zenoh subscribers on the bridge's scan and imu keys, timing arrival before any decoding: the bridge's
    own share of the ROS 2 trip, without the SDK's. Decoded after the run, as ``PlainMeter``."""

    def __init__(self, session: zenoh.Session) -> None:
        here, saved = str(Path(__file__).resolve().parent), list(sys.path)
        sys.path[:] = [p for p in sys.path if p not in ("", here)]  # this script has the name of the package
        try:
            from ros2_bridge import rmw, ros_types
        finally:
            sys.path[:] = saved

        self.raw: list[tuple[str, bytes, int]] = []
        self.lock = threading.Lock()
        self.types = {"scan": "sensor_msgs/msg/LaserScan", "imu": "sensor_msgs/msg/Imu"}
        self.decode = ros_types.typestore().deserialize_cdr
        self.subs = [session.declare_subscriber(rmw.topic_key(0, f"/*/{name}", ros_type,
                                                              ros_types.type_hash(ros_type)), self._on)
                     for name, ros_type in self.types.items()]

    def _on(self, sample: zenoh.Sample) -> None:
        got = time.time_ns()
        row = (str(sample.key_expr), sample.payload.to_bytes(), got)
        with self.lock:
            self.raw.append(row)

    def seen(self) -> dict[tuple[str, int], int]:
        with self.lock:
            rows = list(self.raw)
        out = {}
        for key, payload, got in rows:
            parts = key.split("/")
            stamp = self.decode(payload, self.types[parts[2]]).header.stamp
            out[(f"/{parts[1]}/{parts[2]}", stamp.sec * 1_000_000_000 + stamp.nanosec)] = got
        return out


def relay(endpoint: str) -> None:
    """Re-put the world's perception and gyroscope samples unchanged under ``RELAY_PREFIX``, as they arrive, until
    SIGTERM: a client of the router, as the bridge is."""
    from bus.bus import zenoh_callback
    from bus.process import stop_on_signals

    conf = build_config(connect=[endpoint])
    conf.insert_json5("mode", '"client"')
    with zenoh.open(conf) as session, stop_on_signals() as stop:
        publishers: dict[str, zenoh.Publisher] = {}

        def forward(sample: zenoh.Sample) -> None:
            key = RELAY_PREFIX + str(sample.key_expr)
            if key not in publishers:
                publishers[key] = session.declare_publisher(key, congestion_control=zenoh.CongestionControl.DROP)
            publishers[key].put(sample.payload.to_bytes())

        subs = [session.declare_subscriber(Keyspace(WORLD).rovers(t), zenoh_callback(forward)) for t in TOPICS]
        stop.wait()
        for sub in subs:
            sub.undeclare()


class SdkMeter:
    def __init__(self, port: int, rovers: int, log: Path) -> None:
        self.proc = subprocess.Popen([sys.executable, str(REPO / "benchmarks" / "ros2_sdk_meter.py"), "--port",
                                      str(port), "--rovers", str(rovers)], cwd=REPO, stdin=subprocess.PIPE,
                                     stdout=subprocess.PIPE, stderr=log.open("wb"), text=True)
        if self.proc.stdout.readline().strip() != "ready":
            raise RuntimeError(f"the SDK meter did not start: {log.read_text()[-500:]}")

    def results(self) -> list[tuple[str, int, int]]:
        out, _ = self.proc.communicate("stop\n", timeout=60)
        return [tuple(row) for row in json.loads(out.strip().splitlines()[-1])]


def five_rovers(folder: Path, seconds: float) -> dict:
    port = _free_port()
    endpoint = f"tcp/127.0.0.1:{port}"
    router = _python("-m", "deploy.router", "--listen", endpoint, log=folder / "router.log")
    procs = [router]
    try:
        assert wait_for_port("127.0.0.1", port, 15, router), "router did not start"
        bridge = _python("-m", "ros2_bridge", "--world", WORLD, "--connect", endpoint, "--params", str(SCENARIO),
                         log=folder / "bridge.log")
        procs.append(bridge)
        procs.append(_python(str(Path(__file__).resolve()), "--relay", endpoint, log=folder / "relay.log"))
        sdk = SdkMeter(port, 5, folder / "sdk.log")
        procs.append(sdk.proc)
        with zenoh.open(build_config(connect=[endpoint])) as session:
            plain = PlainMeter(session, Keyspace(WORLD))
            relayed = PlainMeter(session, Keyspace(WORLD), RELAY_PREFIX)
            raw = RawRosMeter(session)
            mission = _python("-m", "deploy.cli", "run", str(SCENARIO), "--connect", endpoint, "--world", WORLD,
                              "--max-sim-time", str(seconds), "--no-record", "--quiet", "--out", str(folder / "run"),
                              log=folder / "run.log")
            procs.append(mission)
            mission.wait(timeout=seconds * 4 + 120)
            time.sleep(1.0)  # the last samples' way through the bridge
            ros = sdk.results()
            world, bridged, floor = plain.seen(), raw.seen(), relayed.seen()
    finally:
        _stop(*reversed(procs))
    got = {(topic, stamp): at for topic, stamp, at in ros}
    lost = [k for k in world if k not in got]
    plain_ns = [world[k][1] - world[k][0] for k in world if k in got]
    ros_ns = [got[k] - world[k][0] for k in world if k in got]
    raw_ns = [bridged[k] - world[k][0] for k in world if k in bridged]
    relay_ns = [floor[k][1] - world[k][0] for k in world if k in floor]
    # What the extra hop adds to each sample: its arrival there minus the same sample's plain arrival.
    paired_ns = [got[k] - world[k][1] for k in world if k in got]
    paired_relay_ns = [floor[k][1] - world[k][1] for k in world if k in floor]
    return {"world_samples": len(world), "sdk_samples": len(got), "lost": len(lost),
            "lost_by_topic": sorted({k[0].rsplit("/", 1)[1] for k in lost}),
            "plain": Summary.of(plain_ns), "ros2": Summary.of(ros_ns), "ros2_raw": Summary.of(raw_ns),
            "relay": Summary.of(relay_ns), "ros2_added": Summary.of(paired_ns),
            "relay_added": Summary.of(paired_relay_ns)}


def twenty_rovers_cpu(folder: Path, seconds: float, rovers: int = 20) -> dict:
    port = _free_port()
    endpoint = f"tcp/127.0.0.1:{port}"
    router = _python("-m", "deploy.router", "--listen", endpoint, log=folder / "router20.log")
    procs = [router]
    try:
        assert wait_for_port("127.0.0.1", port, 15, router), "router did not start"
        bridge = _python("-m", "ros2_bridge", "--world", WORLD, "--connect", endpoint, "--params", str(SCENARIO),
                         log=folder / "bridge20.log")
        procs.append(bridge)
        sdk = SdkMeter(port, rovers, folder / "sdk20.log")
        procs.append(sdk.proc)
        world = _python("-m", "world_service", str(SCENARIO), "--world", WORLD, "--connect", endpoint, "--rovers",
                        str(rovers), "--no-lander", "--start-timeout", "1", "--max-sim-time", str(seconds + 30),
                        log=folder / "world20.log")
        procs.append(world)
        _wait_for_log(folder / "bridge20.log", f"serving rover {rovers} ", timeout=120.0, proc=bridge)
        time.sleep(1.0)  # the bridge's first declarations settle; its CPU from here on is its steady state
        cpu0, t0 = cpu_seconds(bridge.pid), time.monotonic()
        time.sleep(seconds)
        cpu1, t1 = cpu_seconds(bridge.pid), time.monotonic()
        samples = len(sdk.results())
    finally:
        _stop(*reversed(procs))
    return {"rovers": rovers, "window_s": round(t1 - t0, 1), "bridge_cpu_share": (cpu1 - cpu0) / (t1 - t0),
            "sdk_samples": samples}


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--quick", action="store_true", help="a 3 s mission and a 2 s CPU window")
    parser.add_argument("--json", type=Path, metavar="FILE", help="also write the figures here")
    parser.add_argument("--relay", metavar="ENDPOINT", help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.relay:
        relay(args.relay)
        return 0
    mission_s, window_s = (3.0, 2.0) if args.quick else (60.0, 60.0)
    with tempfile.TemporaryDirectory(prefix="ros2bench-") as tmp:
        folder = Path(tmp)
        five = five_rovers(folder, mission_s)
        cpu = twenty_rovers_cpu(folder, window_s)
    plain, ros, raw, floor = five["plain"], five["ros2"], five["ros2_raw"], five["relay"]
    print(f"machine: {os.cpu_count()} cores, load average {os.getloadavg()[0]:.1f} at the end (other work included)")
    added = ros.p99_ms - plain.p99_ms
    print(f"5 rovers, real time, {mission_s:g} s: world published {five['world_samples']} scan+imu samples, the "
          f"ROS 2 subscriber got {five['sdk_samples']}, lost {five['lost']} {five['lost_by_topic'] or ''}")
    print(f"{'trip from the world':<28}{'p50 ms':>9}{'p90 ms':>9}{'p99 ms':>9}{'max ms':>9}")
    rows = (("plain Zenoh subscriber", plain), ("ROS 2 key, plain Zenoh", raw), ("ROS 2 via the bridge (SDK)", ros),
            ("trivial relay, plain Zenoh", floor))
    for name, s in rows:
        print(f"{name:<28}{s.p50_ms:>9.2f}{s.p90_ms:>9.2f}{s.p99_ms:>9.2f}{s.max_ms:>9.2f}")
    print(f"the bridge adds {added:.2f} ms at p99 to the SDK subscriber's trip, {raw.p99_ms - plain.p99_ms:.2f} ms to "
          f"a plain subscriber's on its keys (target at most {TARGET_ADDED_P99_MS:g} ms); a trivial relay in its place "
          f"adds {floor.p99_ms - plain.p99_ms:.2f} ms (the extra hop's floor)")
    paired, paired_floor = five["ros2_added"], five["relay_added"]
    print(f"sample by sample (its SDK arrival minus its plain arrival): the bridge adds p50 {paired.p50_ms:.2f}, p99 "
          f"{paired.p99_ms:.2f} ms; the trivial relay p50 {paired_floor.p50_ms:.2f}, p99 {paired_floor.p99_ms:.2f} ms")
    print(f"{cpu['rovers']} rovers, real time: the bridge used {cpu['bridge_cpu_share']:.1%} of one core over "
          f"{cpu['window_s']:g} s (target under {TARGET_CPU_SHARE:.0%}); the ROS 2 subscriber got "
          f"{cpu['sdk_samples']} samples")
    if args.json:
        figures = {"five_rovers": {**five, "plain": vars(plain), "ros2": vars(ros), "ros2_raw": vars(raw),
                                   "relay": vars(floor), "added_p99_ms": added,
                                   "ros2_added": vars(five["ros2_added"]), "relay_added": vars(five["relay_added"])},
                   "twenty_rovers": cpu}
        args.json.write_text(json.dumps(figures, indent=2) + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
