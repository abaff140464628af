"""A live world served to the Foxglove app (``lunarsim view --foxglove``): the world state, the rover photos and the
lander's map of one world as the same channels ``lunarsim export-foxglove`` writes, so a live run and a recording
look alike. The static scene is sent again to each client that subscribes, since a WebSocket server keeps no
history for late joiners.
"""

from __future__ import annotations

import queue
import threading
import time
from typing import TYPE_CHECKING

from bus import process

if TYPE_CHECKING:
    import foxglove
    import zenoh

    from schemas.keyspace import Keyspace
    from schemas.scenario import Scenario
    from sessions.format import Sample

QUEUE_SAMPLES = 256
"""Samples waiting to be converted; a viewer that falls behind drops the oldest, live is what matters."""


def serve_foxglove(scenario: Scenario, keys: Keyspace, host: str, port: int, trail_points: int,
                   conf: zenoh.Config, endpoints: str, router_timeout: float | None) -> int:
    """Serve on ``host:port`` until SIGINT or SIGTERM, following the world through a router as it comes and goes."""
    from bus.bus import zenoh_callback
    from schemas.keyspace import MAP, PHOTO
    from web.link import RouterLink
    from web.live import Source

    live = LiveScene(scenario, trail_points=trail_points)
    link = RouterLink(conf, Source(endpoints, connected=False), router_timeout)
    feed = Feed()
    try:
        server = live.serve(host, port)
    except Exception as exc:  # the SDK raises its own error types for a port in use or a bad address
        raise process.UsageError(f"cannot serve on {host}:{port}: {exc}") from None
    print(f"serving world {keys.world!r} to Foxglove at ws://{host}:{server.port} (Ctrl-C stops)", flush=True)
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
