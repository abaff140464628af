"""Frames per second of the web view in headless Chromium, with 0 and 100 rovers on the page.

Starts a real Zenoh router and a real ``lunarsim view`` (the crater scenario's terrain), publishes a
synthetic ``world/state`` (N rovers driving circles around the lander, each with a radio link, every fifth
relaying) at ``--rate`` Hz from this process, opens the page in Debian's chromium through Playwright and
counts the frames the page draws (``requestAnimationFrame``) over ``--seconds``. The first figure (0 rovers)
is the cost of the terrain alone, so the difference is what the rovers, trails and links cost.

Chromium runs without a GPU here, so WebGL is software (SwiftShader) on the machine's CPUs: the absolute
figure depends mostly on the viewport's pixel count (``--size``); compare rover counts at one size.

``--scales`` compares drawing resolutions in one run: the page's ``?scale=`` pixel ratio (1: full, 0.5: a quarter
of the pixels, scaled up by the browser).

    python benchmarks/viewer_fps.py [--rovers 0 100] [--scales 1 0.5] [--seconds 10] [--size 1280x720]
                                    [--rate 20] [--json FILE]
    python benchmarks/viewer_fps.py --quick    # 0 and 10 rovers, 1 s each, at 640x360
"""

from __future__ import annotations

import argparse
import json
import math
import subprocess
import sys
import tempfile
import threading
import time
from pathlib import Path

import quick

REPO = Path(__file__).resolve().parents[1]
SCENARIO = REPO / "scenarios" / "crater_observation.yaml"
CHROMIUM_ARGS = ["--headless", "--no-sandbox", "--disable-gpu", "--disable-quic", "--no-first-run",
                 "--disable-background-networking", "--disable-component-update", "--disable-sync",
                 "--enable-unsafe-swiftshader", "--use-angle=swiftshader"]
WORLD = "fps"
QUICK = {"rovers": [0, 10], "seconds": 1.0, "size": "640x360"}


def free_port() -> int:
    import socket

    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def synthetic_state(n: int, t: float, lander: tuple[float, float]):
    """N rovers on circles of 10-60 m around the lander, each linked to the lander or the rover before it."""
    from schemas import messages as m

    rovers, links = [], []
    for i in range(1, n + 1):
        radius = 10 + 50 * i / max(n, 1)
        angle = t * 0.2 + i * 2.4
        heading = math.degrees(angle) % 360
        rovers.append(m.RoverTruth(id=i, x=lander[0] + radius * math.sin(angle), z=lander[1] + radius * math.cos(angle),
                                   heading_deg=heading, action="move", state="migration", goal_index=0,
                                   distance_to_goal_m=radius, distance_covered_m=t, alive=True))
        links.append((0 if i % 5 == 1 else i - 1, i))
    return m.WorldState(stamp=t, rovers=rovers, comm_links=links, relays=[i for i in range(1, n + 1) if i % 5 == 0])


def publish(endpoint: str, rovers: list[int], rate: float, stop: threading.Event, current: list[int]) -> None:
    from bus.zenoh_config import build_config, open_session
    from schemas import codec
    from schemas.keyspace import Keyspace
    from schemas.scenario import load_scenario

    scenario = load_scenario(SCENARIO)
    lander = (scenario.lander.x, scenario.lander.z)
    key = Keyspace(WORLD).state
    session = open_session(build_config(connect=[endpoint]), endpoint, 10.0, who="viewer_fps")
    start = time.monotonic()
    while not stop.is_set():
        t = time.monotonic() - start
        session.put(key, codec.encode(synthetic_state(current[0], t, lander)))
        stop.wait(1.0 / rate)
    session.close()


def measure(page, n: int, seconds: float) -> dict:
    deadline = time.monotonic() + 30
    while page.evaluate("(lunarsim.state && lunarsim.state.rovers.length) || 0") != n:
        if time.monotonic() > deadline:
            raise RuntimeError(f"the page never showed {n} rovers")
        time.sleep(0.1)
    time.sleep(1.0)  # let the page settle on the new team
    f0, s0, t0 = page.evaluate("lunarsim.frames"), page.evaluate("lunarsim.states"), time.monotonic()
    time.sleep(seconds)
    f1, s1, t1 = page.evaluate("lunarsim.frames"), page.evaluate("lunarsim.states"), time.monotonic()
    return {"rovers": n, "fps": round((f1 - f0) / (t1 - t0), 1), "states_per_s": round((s1 - s0) / (t1 - t0), 1),
            "render_scale": page.evaluate("lunarsim.renderScale")}


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--rovers", type=int, nargs="+", default=[0, 100])
    parser.add_argument("--scales", nargs="+", type=float, default=[1.0],
                        help="page drawing resolutions (pixel ratio, 0-1) to measure one after the other")
    parser.add_argument("--seconds", type=float, default=10.0)
    parser.add_argument("--size", default="1280x720", help="browser viewport WIDTHxHEIGHT")
    parser.add_argument("--rate", type=float, default=20.0, help="world states published per second")
    parser.add_argument("--chromium", default="/usr/bin/chromium")
    parser.add_argument("--json", type=Path)
    args = quick.parse_args(parser, QUICK)
    if not Path(args.chromium).is_file():
        parser.error(f"--chromium {args.chromium}: no such file (Debian's chromium: apt-get install -y chromium)")
    width, height = (int(v) for v in args.size.split("x"))
    from playwright.sync_api import sync_playwright

    router_port, web_port = free_port(), free_port()
    endpoint = f"tcp/127.0.0.1:{router_port}"
    procs = [subprocess.Popen([sys.executable, "-m", "deploy.router", "--listen", endpoint], cwd=REPO)]
    time.sleep(1.0)
    procs.append(subprocess.Popen([sys.executable, "-m", "deploy.cli", "view", "--scenario", str(SCENARIO), "--connect",
                                   endpoint, "--world", WORLD, "--port", str(web_port)], cwd=REPO,
                                  stdout=subprocess.PIPE, text=True))
    procs[-1].stdout.readline()  # "serving world ..."
    stop, current = threading.Event(), [args.rovers[0]]
    publisher = threading.Thread(target=publish, args=(endpoint, args.rovers, args.rate, stop, current), daemon=True)
    publisher.start()
    results = []
    try:
        with tempfile.TemporaryDirectory() as user_data, sync_playwright() as p:
            context = p.chromium.launch_persistent_context(user_data, executable_path=args.chromium, args=CHROMIUM_ARGS,
                                                           headless=True, viewport={"width": width, "height": height})
            for scale in args.scales:
                page = context.new_page()
                page.goto(f"http://127.0.0.1:{web_port}/?scale={scale:g}")
                for n in args.rovers:
                    current[0] = n
                    results.append({"scale": scale, **measure(page, n, args.seconds)})
                    r = results[-1]
                    print(f"scale {scale:4g}: {n:4d} rovers: {r['fps']:6.1f} frames/s at {r['render_scale']:.3f} "
                          f"resolution, {r['states_per_s']:5.1f} states/s reached the page (viewport {args.size}, "
                          f"states published at {args.rate:g} Hz)", flush=True)
                page.close()
            context.close()
    finally:
        stop.set()
        publisher.join(5)
        for proc in reversed(procs):
            proc.terminate()
            proc.wait(10)
    if args.json:
        args.json.write_text(json.dumps({"size": args.size, "rate_hz": args.rate, "results": results}, indent=2) + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
