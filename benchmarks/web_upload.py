"""How long ``/api/info`` of the web view takes to answer while the largest scenario it accepts is uploaded.

Serves the web view (no Zenoh: a viewer with nothing to show) from a child process on loopback, measures
``/api/info`` alone, then again while each upload is read, validated and drawn: the largest YAML text a scenario
file may be (``MAX_SCENARIO_BYTES``), and the largest JSON body the page may send (``MAX_REQUEST_BYTES``), each
filled with rocks (listed, then a rock field up to the model's bound) and the rest with wall corners, asked for
the preview as the page asks. ``--quick`` scales the sizes and the rock bound down alike.
Prints, per case, the upload's size, answer and time, and the latency of ``/api/info`` meanwhile (p50, p95, max).

    python benchmarks/web_upload.py            # the largest accepted sizes
    python benchmarks/web_upload.py --quick    # an eighth of the sizes and rocks: a smoke check
"""

from __future__ import annotations

import argparse
import asyncio
import json
import socket
import subprocess
import sys
import time
from pathlib import Path

import aiohttp
import yaml

sys.path.insert(0, str(Path(__file__).resolve().parent))
import host

ROOT = Path(__file__).resolve().parents[1]
SCENARIO = ROOT / "scenarios" / "crater_observation.yaml"
INFO_PAUSE_S = 0.02
"""Between two /api/info requests: a page polling hard, not a flood."""


def serve(port: int) -> None:
    """The child: the web view on 127.0.0.1:port until killed."""
    from aiohttp import web

    from web import editor, live
    from web.page_commands import Commands
    from web.server import Viewer, build_app

    work = Path(f"/tmp/web-upload-bench-{port}")
    viewer = Viewer("bench", live.Latest(), Commands(lambda command: None), editor.Workspace(work / "ws"),
                    editor.Launcher(work / "runs", "tcp/127.0.0.1:1", "bench"))
    print("serving", flush=True)
    web.run_app(build_app(viewer), host="127.0.0.1", port=port, print=None, access_log=None)


def _rocks(x: float, z: float, n: int) -> list[dict]:
    return [{"x": x + 5 + i % 300 * 0.5, "z": z + i // 300 * 0.5, "radius_m": 0.2} for i in range(n)]


def _walls(x: float, z: float, points: int, per_wall: int) -> list[dict]:
    walls, row = [], 0
    while points - row * per_wall >= 2:
        n = min(per_wall, points - row * per_wall)
        walls.append({"points": [[round(x - 50 - j * 0.1, 1), z + row] for j in range(n)]})
        row += 1
    return walls


def _fill(scenario: dict, limit: int, size_of, max_rocks: int) -> dict:
    """``scenario`` with rocks listed, a rock field for the rest of ``max_rocks`` (the model's rock bound, or a share
    of it), then wall corners, to just under ``limit`` bytes."""
    from schemas import scenario_limits as limits

    x, z = scenario["lander"]["x"], scenario["lander"]["z"]
    obstacles = scenario["obstacles"]

    def per_item(key: str, sample: list) -> float:
        before = size_of(scenario)
        obstacles[key] = sample
        size = (size_of(scenario) - before) / 1000
        obstacles[key] = []
        return size

    rock, point = per_item("rocks", _rocks(x, z, 1000)), per_item("walls", _walls(x, z, 1000, 1000))
    obstacles["rocks"] = _rocks(x, z, min(max_rocks, int((limit - size_of(scenario)) * 0.97 / rock)))
    if len(obstacles["rocks"]) < max_rocks:  # the rest of the rock bound scattered: the costliest preview
        obstacles["rock_fields"] = [{"x": x - 60, "z": z, "radius_m": 50,
                                     "count": max_rocks - len(obstacles["rocks"])}]
    points = int((limit - size_of(scenario)) * 0.97 / point)
    while True:  # corners far along a wall take more digits than the sample's
        obstacles["walls"] = _walls(x, z, points, limits.MAX_WALL_POINTS)
        if size_of(scenario) <= limit:
            return scenario
        points = int(points * 0.97)


def cases(scale: float) -> list[tuple[str, bytes]]:
    """(name, request body): the largest YAML file as text, the largest page JSON, each at ``scale`` (of the sizes
    and of the rock bound)."""
    from schemas.scenario import load_scenario
    from schemas.scenario_limits import MAX_ROCKS, MAX_SCENARIO_BYTES
    from web.uploads import MAX_REQUEST_BYTES

    dumper = getattr(yaml, "CSafeDumper", yaml.SafeDumper)

    def as_yaml(data: dict) -> int:
        return len(yaml.dump(data, Dumper=dumper, default_flow_style=None, sort_keys=False).encode())

    def as_json(data: dict) -> int:
        return len(json.dumps({"scenario": data, "scene": True}, separators=(",", ":")).encode())

    base = load_scenario(SCENARIO).model_dump(mode="json")
    rocks = int(MAX_ROCKS * scale)
    text = yaml.dump(_fill(json.loads(json.dumps(base)), int(MAX_SCENARIO_BYTES * scale), as_yaml, rocks),
                     Dumper=dumper, default_flow_style=None, sort_keys=False)
    page = _fill(json.loads(json.dumps(base)), int(MAX_REQUEST_BYTES * scale), as_json, rocks)
    return [("yaml file", json.dumps({"scenario": text, "scene": True}).encode()),
            ("page json", json.dumps({"scenario": page, "scene": True}, separators=(",", ":")).encode())]


def percentiles(values: list[float]) -> dict:
    ordered = sorted(values) or [float("nan")]
    pick = lambda q: ordered[min(len(ordered) - 1, int(q * len(ordered)))]  # noqa: E731
    return {"n": len(values), "p50_ms": round(1000 * pick(0.5), 2), "p95_ms": round(1000 * pick(0.95), 2),
            "max_ms": round(1000 * ordered[-1], 2)}


async def info_latency(client: aiohttp.ClientSession, until: asyncio.Future | None, count: int) -> list[float]:
    """/api/info round trips: ``count`` of them, or as many as fit before ``until`` is done."""
    out: list[float] = []
    while (until is None and len(out) < count) or (until is not None and not until.done()):
        start = time.perf_counter()
        async with client.get("/api/info") as res:
            await res.read()
            if res.status != 200:
                raise RuntimeError(f"/api/info answered {res.status}")
        out.append(time.perf_counter() - start)
        await asyncio.sleep(INFO_PAUSE_S)
    return out


async def upload(client: aiohttp.ClientSession, body: bytes) -> tuple[int, bytes, float]:
    """(status, answer, seconds); the answer is decoded by the caller once /api/info is no longer timed."""
    start = time.perf_counter()
    async with client.post("/api/scenario/validate", data=body, headers={"Content-Type": "application/json"}) as res:
        answer = await res.read()
    return res.status, answer, time.perf_counter() - start


def said(answer: bytes) -> str:
    data = json.loads(answer)
    return (data.get("summary") or data.get("error", ""))[:120]


async def measure(port: int, scale: float, baseline: int) -> dict:
    figures: dict = {}
    async with aiohttp.ClientSession(f"http://127.0.0.1:{port}", timeout=aiohttp.ClientTimeout(total=600)) as client:
        await upload(client, json.dumps({"scenario": "name: warm-up"}).encode())  # starts the worker process
        figures["idle"] = percentiles(await info_latency(client, None, baseline))
        for name, body in cases(scale):
            task = asyncio.ensure_future(upload(client, body))
            during = await info_latency(client, task, 0)
            status, answer, took = await task
            figures[name] = {"request_mib": round(len(body) / 1024**2, 2), "status": status, "said": said(answer),
                             "upload_s": round(took, 2), "answer_mib": round(len(answer) / 1024**2, 2),
                             "info_during": percentiles(during)}
    return figures


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="an eighth of the sizes and rocks, fewer idle samples")
    parser.add_argument("--json", type=Path, help="also write the figures here")
    parser.add_argument("--serve", type=int, help=argparse.SUPPRESS)  # the child's own mode
    args = parser.parse_args()
    if args.serve:
        serve(args.serve)
        return 0
    print(host.line(host.describe()))
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        port = s.getsockname()[1]
    server = subprocess.Popen([sys.executable, __file__, "--serve", str(port)], cwd=ROOT, stdout=subprocess.PIPE,
                              text=True)
    try:
        if server.stdout.readline().strip() != "serving":
            print("the web view did not start", file=sys.stderr)
            return 1
        figures = asyncio.run(_when_up(port, 0.125 if args.quick else 1.0, 50 if args.quick else 200))
    finally:
        server.terminate()
        server.wait(timeout=30)
    for name, value in figures.items():
        print(f"{name:<10} {json.dumps(value)}")
    if args.json:
        args.json.write_text(json.dumps(figures, indent=2) + "\n")
    return 0


async def _when_up(port: int, scale: float, baseline: int) -> dict:
    """Measure once the port takes connections (the child prints before it binds)."""
    deadline = time.monotonic() + 30
    while True:
        try:
            _, writer = await asyncio.open_connection("127.0.0.1", port)
            writer.close()
            break
        except OSError:
            if time.monotonic() > deadline:
                raise
            await asyncio.sleep(0.05)
    return await measure(port, scale, baseline)


if __name__ == "__main__":
    sys.exit(main())
