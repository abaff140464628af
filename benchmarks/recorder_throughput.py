"""Can the recorder keep up? 100 simulated rovers' traffic at the report's sensor rates, through a real
router, into ``lunarsim record``; counts what was published, what was written and what was dropped.

The world (``World``, driven as in world_scale.py) publishes every message it produces, in real time,
with one Bus, exactly as the world service would; the recorder is a separate process. Prints messages
and bytes per second, samples published vs written per topic, the recorder's drops, its CPU share and
peak memory, and the file size.

    python benchmarks/recorder_throughput.py [--rovers 100] [--seconds 20] [--json FILE]
    python benchmarks/recorder_throughput.py --quick    # 10 rovers for 3 s
"""

from __future__ import annotations

import argparse
import json
import resource
import signal
import subprocess
import sys
import tempfile
import time
from collections import Counter
from pathlib import Path

import quick
from world_scale import MOVE, SCENARIO, drive

from bus.bus import Bus
from bus.zenoh_config import build_config, open_session
from deploy.children import wait_for_port
from schemas import codec
from schemas import keyspace as ks
from schemas.scenario import load_scenario
from sessions.format import DROPS_METADATA, read_metadata, read_samples
from world_service.sim import World

QUICK = {"rovers": 10, "seconds": 3.0}


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--rovers", type=int, default=100)
    parser.add_argument("--seconds", type=float, default=20.0)
    parser.add_argument("--port", type=int, default=17990)
    parser.add_argument("--json", type=Path)
    args = quick.parse_args(parser, QUICK, argv)
    endpoint = f"tcp/127.0.0.1:{args.port}"
    with tempfile.TemporaryDirectory() as tmp:
        out = Path(tmp) / "bench.mcap"
        router = subprocess.Popen([sys.executable, "-m", "deploy.router", "--listen", endpoint])
        recorder = None
        try:
            if not wait_for_port("127.0.0.1", args.port, 15, router):
                raise SystemExit("the router did not start")
            recorder = subprocess.Popen([sys.executable, "-m", "deploy.cli", "record", "-o", str(out), "--world",
                                         "bench", "--connect", endpoint], stdout=subprocess.PIPE, text=True)
            assert "recording" in recorder.stdout.readline()
            published, nbytes, wall = publish(endpoint, args.rovers, args.seconds)
            recorder.send_signal(signal.SIGINT)
            recorder.wait(timeout=120)
            cpu = resource.getrusage(resource.RUSAGE_CHILDREN)
            result = tally(out, published, nbytes, wall, cpu, args)
        finally:
            for proc in (recorder, router):
                if proc is not None and proc.poll() is None:
                    proc.kill()
    show(result)
    if args.json:
        args.json.write_text(json.dumps(result, indent=2) + "\n")
    return 0


def publish(endpoint: str, rovers: int, seconds: float) -> tuple[Counter[str], int, float]:
    """Run the world in real time for ``seconds`` and publish everything it produces."""
    scenario = load_scenario(SCENARIO).with_overrides(rovers=rovers)
    keys = ks.Keyspace("bench")
    world = World(scenario, keys)
    for rid in world.rover_ids:  # every rover on the move, as in world_scale.py
        world.receive(keys.rover(rid, ks.MOVE_ACTION), MOVE)
    published: Counter[str] = Counter()
    nbytes = 0
    session = open_session(build_config(connect=[endpoint]), endpoint, 10.0, who="benchmark")
    with Bus(session) as bus:
        start = time.monotonic()
        while world.clock.sim_time < seconds:
            out = world.step()
            drive(world, out, keys)
            for key, message in out:
                payload = codec.encode(message)
                bus.put(key, payload)
                published[_topic(key)] += 1
                nbytes += len(payload)
            delay = start + world.clock.sim_time - time.monotonic()
            if delay > 0:
                time.sleep(delay)
        wall = time.monotonic() - start
        time.sleep(1.0)  # let the last samples reach the recorder before it is stopped
    session.close()
    return published, nbytes, wall


def _topic(key: str) -> str:
    return key.rsplit("/", 1)[-1]


def tally(out: Path, published: Counter[str], nbytes: int, wall: float, cpu, args) -> dict:
    written = Counter(_topic(s.key) for s in read_samples(out))
    drops = json.loads(read_metadata(out)[DROPS_METADATA]["per_key"])
    return {
        "rovers": args.rovers, "sim_seconds": args.seconds, "wall_s": round(wall, 2),
        "real_time_factor": round(args.seconds / wall, 3),
        "messages_per_s": round(sum(published.values()) / wall), "megabytes_per_s": round(nbytes / wall / 1e6, 2),
        "published": dict(published), "written": dict(written),
        "missing": {t: published[t] - written.get(t, 0) for t in published if published[t] != written.get(t, 0)},
        "recorder_drops": sum(drops.values()),
        "children_cpu_s": round(cpu.ru_utime + cpu.ru_stime, 2),
        "children_peak_rss_mb": round(cpu.ru_maxrss / 1024, 1),
        "file_mb": round(out.stat().st_size / 1e6, 2),
    }


def show(r: dict) -> None:
    print(f"{r['rovers']} rovers, {r['sim_seconds']:g} s simulated in {r['wall_s']} s (real-time factor "
          f"{r['real_time_factor']}): {r['messages_per_s']} messages/s, {r['megabytes_per_s']} MB/s")
    print(f"{'topic':<20}{'published':>12}{'written':>12}")
    for topic, n in sorted(r["published"].items()):
        print(f"{topic:<20}{n:>12}{r['written'].get(topic, 0):>12}")
    print(f"recorder drops: {r['recorder_drops']}; missing: {sum(r['missing'].values())} {r['missing'] or ''}")
    print(f"router + recorder CPU: {r['children_cpu_s']} s ({r['children_cpu_s'] / r['wall_s']:.0%} of one core); "
          f"peak RSS of the larger: {r['children_peak_rss_mb']} MB; file {r['file_mb']} MB")


if __name__ == "__main__":
    sys.exit(main())
