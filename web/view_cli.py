"""``lunarsim view``: a live world (or a replay) in the browser; ``--foxglove``: served to the Foxglove app.

Plain ``lunarsim view`` serves the web digital twin (``web``) at http://127.0.0.1:8080/: 3D view,
statistics, ground commands and the scenario editor. With ``--foxglove`` it serves Foxglove instead:

Subscribes to the world state, the rover photos and the lander's map of ``--world`` and serves the same channels as
``lunarsim export-foxglove`` (``/scene``, ``/tf``, ``/rover_<id>/photo``, ``/map``), so a live run and a recording
look alike. Open the Foxglove app, "Open connection", ``ws://localhost:8765``, and add a 3D panel.
The static scene (terrain, obstacles, lander, goals) is drawn from ``--scenario`` and sent again to
each client that subscribes, since a WebSocket server keeps no history for late joiners.
"""

from __future__ import annotations

import argparse
import queue
import threading
import time
from pathlib import Path
from typing import TYPE_CHECKING

from bus import process
from bus.zenoh_config import add_zenoh_arguments

if TYPE_CHECKING:
    import foxglove

    from schemas.scenario import Scenario
    from sessions.format import Sample

ROUTER_TIMEOUT_HELP = ("exit (code 3) if no router has been reachable S seconds after starting (default: wait for "
                       "one, however long, serving the page meanwhile; a router lost later is waited for again)")
QUEUE_SAMPLES = 256
"""Samples waiting to be converted; a viewer that falls behind drops the oldest, live is what matters."""


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--foxglove", action="store_true",
                        help="serve the Foxglove WebSocket protocol instead of the web page")
    parser.add_argument("--scenario", type=Path, metavar="FILE", help="the scenario the world runs: terrain, "
                        "obstacles, lander and goals (needed with --foxglove; the web page also shows what it "
                        "launches)")
    parser.add_argument("--world", default="default", help="world name in the keyspace (default: default)")
    parser.add_argument("--port", type=int, help="port (default 8080 for the web page, 8765 for --foxglove)")
    parser.add_argument("--host", default="127.0.0.1", help="address to serve on (default 127.0.0.1; "
                        "0.0.0.0 for other machines: the web page then asks for a token)")
    parser.add_argument("--no-trails", action="store_true", help="do not draw the rovers' recent paths")
    add_zenoh_arguments(parser, agent=True, timeout_help=ROUTER_TIMEOUT_HELP)
    from web.view import add_web_arguments

    add_web_arguments(parser)


class LiveScene:
    """Foxglove channels of one world in their own context, fed with samples; no Zenoh in here.

    ``handle`` converts a sample and logs it to every connected client; ``send_static`` (re)sends the
    static scene. Both run on one thread (the caller's), so the trails need no lock.
    """

    def __init__(self, scenario: Scenario, trail_points: int = 300, terrain_cells: int = 128) -> None:
        import foxglove
        from foxglove.channels import SceneUpdateChannel

        from sessions import foxglove as fx

        self.fx = fx
        self.scenario = scenario
        self.context = foxglove.Context()
        self.grid = fx.sample_terrain(scenario, cells=terrain_cells)
        self.dynamic = fx.DynamicScene(scenario, self.grid, trail_points)
        self.scene = SceneUpdateChannel(fx.SCENE_TOPIC, context=self.context)
        self.tf = _channel("FrameTransformChannel", fx.TF_TOPIC, self.context)
        self.photos: dict[int, object] = {}
        self.map: object | None = None
        self.static_wanted = threading.Event()
        self.static_wanted.set()

    def send_static(self, ns: int | None = None) -> None:
        ns = time.time_ns() if ns is None else ns
        self.scene.log(self.fx.static_scene(self.scenario, self.grid, ns), log_time=ns)

    def handle(self, sample: Sample) -> bool:
        """Convert and log one sample; False if it is not a world state or photo (or is malformed)."""
        from schemas.codec import DecodeError
        from schemas.messages import LanderMap, Photo, WorldState
        from sessions.format import decode

        fx, ns = self.fx, sample.log_time_ns
        if self.static_wanted.is_set():
            self.static_wanted.clear()
            self.send_static(ns)
        try:
            message = decode(sample)
        except DecodeError:
            return False
        if isinstance(message, WorldState):
            self.scene.log(self.dynamic.update(message, ns), log_time=ns)
            for transform in fx.transforms(message, ns, self.dynamic.ground):
                self.tf.log(transform, log_time=ns)
            return True
        if isinstance(message, Photo) and (rover := fx.rover_of_key(sample.key)) is not None:
            if rover not in self.photos:
                self.photos[rover] = _channel("CompressedImageChannel", fx.photo_topic(rover), self.context)
            self.photos[rover].log(fx.photo_image(message, rover, ns), log_time=ns)
            return True
        if isinstance(message, LanderMap):
            try:
                grid = fx.map_grid(message, ns, fx.map_elevation(self.grid))
            except ValueError:
                return False
            if self.map is None:
                self.map = _channel("GridChannel", fx.MAP_TOPIC, self.context)
            self.map.log(grid, log_time=ns)
            return True
        return False

    def serve(self, host: str = "127.0.0.1", port: int = 8765) -> foxglove.WebSocketServer:
        """Start the WebSocket server; a client subscribing to ``/scene`` gets the static scene again."""
        import foxglove

        return foxglove.start_server(name="lunarsim", host=host, port=port, context=self.context,
                                     server_listener=_Listener(self))

    def close(self) -> None:
        for channel in (self.scene, self.tf, *self.photos.values(), *([self.map] if self.map else [])):
            channel.close()


class _Listener:
    """Only ``on_subscribe`` matters: a new viewer of the scene needs the static part again."""

    def __init__(self, live: LiveScene) -> None:
        self.live = live

    def on_subscribe(self, client: object, channel: object) -> None:
        if getattr(channel, "topic", None) == self.live.fx.SCENE_TOPIC:
            self.live.static_wanted.set()


def _channel(kind: str, topic: str, context: object):
    import foxglove.channels

    return getattr(foxglove.channels, kind)(topic, context=context)


class Feed:
    """Zenoh samples into a bounded queue: the callback only copies, conversion runs on the main thread."""

    def __init__(self) -> None:
        self.queue: queue.Queue[Sample] = queue.Queue(maxsize=QUEUE_SAMPLES)
        self.dropped = 0

    def __call__(self, zenoh_sample) -> None:
        from sessions.format import Sample

        now = time.time_ns()
        sample = Sample(str(zenoh_sample.key_expr), zenoh_sample.payload.to_bytes(), now, now)
        while True:
            try:
                self.queue.put_nowait(sample)
                return
            except queue.Full:
                try:
                    self.queue.get_nowait()
                    self.dropped += 1
                except queue.Empty:
                    pass


def run_from_args(args: argparse.Namespace) -> int:
    from bus.bus import zenoh_callback
    from bus.zenoh_config import config_from_args, describe_endpoints
    from schemas.keyspace import MAP, PHOTO, Keyspace, check_world_name
    from schemas.scenario import load_scenario
    from web.link import RouterLink
    from web.live import Source

    try:
        check_world_name(args.world)
    except ValueError as exc:
        raise process.UsageError(str(exc)) from None
    if args.port is None:
        args.port = 8765 if args.foxglove else 8080
    if not 0 < args.port < 65536:
        raise process.UsageError(f"--port must be between 1 and 65535, got {args.port}")
    if not args.foxglove:
        from web.view import run_web

        return run_web(args)
    if args.scenario is None:
        raise process.UsageError("--foxglove needs --scenario FILE (the terrain, obstacles, lander and goals)")
    scenario = load_scenario(args.scenario)
    keys = Keyspace(args.world)
    live = LiveScene(scenario, trail_points=0 if args.no_trails else 300)
    link = RouterLink(config_from_args(args), Source(describe_endpoints(args), connected=False), args.router_timeout)
    feed = Feed()
    try:
        server = live.serve(args.host, args.port)
    except Exception as exc:  # the SDK raises its own error types for a port in use or a bad address
        raise process.UsageError(f"cannot serve on {args.host}:{args.port}: {exc}") from None
    print(f"serving world {args.world!r} to Foxglove at ws://{args.host}:{server.port} (Ctrl-C stops)", flush=True)
    with process.stop_on_signals() as stop:
        link.when_failed(stop.set)
        link.start(lambda session: [session.declare_subscriber(key, zenoh_callback(feed))
                                    for key in (keys.state, keys.rovers(PHOTO), keys.lander(MAP))])
        try:
            _pump(live, feed, stop)
        finally:
            link.close()
            server.stop()
            live.close()
    link.raise_failure()
    return 0


def _pump(live: LiveScene, feed: Feed, stop: threading.Event) -> None:
    """Convert samples until stopped; wakes at least every 0.2 s to notice the stop and resend the scene."""
    while not stop.is_set():
        try:
            sample = feed.queue.get(timeout=0.2)
        except queue.Empty:
            if live.static_wanted.is_set():
                live.static_wanted.clear()
                live.send_static()
            continue
        live.handle(sample)
