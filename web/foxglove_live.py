"""A live world served to the Foxglove app (``lunarsim view --foxglove``): the world state, the rover photos and the
lander's map of one world as the same channels ``lunarsim export-foxglove`` writes, so a live run and a recording
look alike, and beyond them the world's clock as Foxglove's time, the rovers' scan, IMU and battery, ground
commands from the app and its playback controls (``web.foxglove_extras``). The static scene is sent again to each
client that subscribes, since a WebSocket server keeps no history for late joiners.
"""

from __future__ import annotations

import queue
import threading
import time
from collections.abc import Callable
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
DEFAULT_TIMELINE_S = 3600.0
"""Simulated seconds Foxglove's playback bar spans by default."""


def serve_foxglove(scenario: Scenario, keys: Keyspace, host: str, port: int, trail_points: int,
                   conf: zenoh.Config, endpoints: str, router_timeout: float | None,
                   timeline_s: float = DEFAULT_TIMELINE_S) -> int:
    """Serve on ``host:port`` until SIGINT or SIGTERM, following the world through a router as it comes and goes."""
    from bus.bus import zenoh_callback
    from schemas import codec
    from schemas.keyspace import BATTERY, GYROSCOPE, MAP, PERCEPTION, PHOTO
    from web.link import RouterLink
    from web.live import Source

    live = LiveScene(scenario, trail_points=trail_points)
    link = RouterLink(conf, Source(endpoints, connected=False), router_timeout)
    feed = Feed()
    try:
        server = live.serve(host, port, timeline_s)
    except Exception as exc:  # the SDK raises its own error types for a port in use or a bad address
        raise process.UsageError(f"cannot serve on {host}:{port}: {exc}") from None
    print(f"serving world {keys.world!r} to Foxglove at ws://{host}:{server.port} (Ctrl-C stops)", flush=True)
    with process.stop_on_signals() as stop:
        link.when_failed(stop.set)
        senses = (keys.rovers(t) for t in (PHOTO, PERCEPTION, GYROSCOPE, BATTERY))
        served = (keys.state, keys.clock, keys.lander(MAP), keys.ground_command_result, *senses)
        link.start(lambda session: [session.declare_subscriber(key, zenoh_callback(feed)) for key in served])
        try:
            _pump(live, feed, stop, lambda cmd: link.put(keys.ground_command, codec.encode(cmd)))
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
        from sessions.rays import RayLayout
        from web.foxglove_extras import GroundInput

        self.fx = fx
        self.scenario = scenario
        self.context = foxglove.Context()
        self.grid = fx.sample_terrain(scenario, cells=terrain_cells)
        self.dynamic = fx.DynamicScene(scenario, self.grid, trail_points)
        self.scene = SceneUpdateChannel(fx.SCENE_TOPIC, context=self.context)
        self.tf = _channel("FrameTransformChannel", fx.TF_TOPIC, self.context)
        self.photos: dict[int, object] = {}
        self.senses: dict[str, object] = {}
        """``/rover_<id>/scan``, ``imu`` and ``battery`` channels by topic, made on a rover's first sample."""
        self.layout = RayLayout.of(scenario.rover_params.perception)
        self.map: object | None = None
        self.now_ns = 0
        """The world's clock, in Foxglove's nanoseconds: every message is stamped in simulated time."""
        self.server: foxglove.WebSocketServer | None = None
        self.ground = GroundInput()
        self.paused = False
        self.static_wanted = threading.Event()
        self.static_wanted.set()

    def send_static(self, ns: int | None = None) -> None:
        ns = self.now_ns if ns is None else ns
        self.scene.log(self.fx.static_scene(self.scenario, self.grid, ns), log_time=ns)

    def handle(self, sample: Sample) -> bool:
        """Convert and log one sample at its simulated time; False if it is none the view serves (or malformed)."""
        from schemas.codec import DecodeError
        from schemas.messages import Clock, CommandResult, LanderMap, Photo, WorldState
        from sessions.format import decode
        from web.foxglove_extras import sim_ns

        fx = self.fx
        try:
            message = decode(sample)
        except DecodeError:
            return False
        if isinstance(message, Clock):
            ns = sim_ns(message.sim_time)
        else:
            stamp = getattr(message, "stamp", None)
            ns = sim_ns(stamp) if stamp is not None else self.now_ns
        if self.static_wanted.is_set():
            self.static_wanted.clear()
            self.send_static(ns)
        if isinstance(message, CommandResult):
            return self._answered(message)
        if isinstance(message, Clock):
            self.now_ns = ns
            if self.server is not None:
                self.server.broadcast_time(ns)
            return True
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
        return self._sense(sample.key, message, ns)

    def _answered(self, result) -> bool:
        """The lander's answer to a command a client sent, as a status message in the app."""
        from foxglove import StatusLevel

        text = self.ground.answer(result)
        if text is not None and self.server is not None:
            self.server.publish_status(text, StatusLevel.Info if result.accepted else StatusLevel.Warning)
        return text is not None

    def _sense(self, key: str, message: object, ns: int) -> bool:
        """A rover's scan, pitch or battery on its channel."""
        from schemas import messages as m
        from web import foxglove_extras as fl

        rover = self.fx.rover_of_key(key)
        if rover is None:
            return False
        if isinstance(message, m.Perception):
            try:
                out = fl.scan(message, rover, self.layout)
            except ValueError as exc:
                self.ground.rejected.count("perception", exc, key)
                return False
            self._sense_channel(f"/rover_{rover}/scan", "LaserScanChannel").log(out, log_time=ns)
        elif isinstance(message, m.Gyroscope):
            self._sense_channel(f"/rover_{rover}/imu", fl.PITCH_SCHEMA).log(fl.pitch(message), log_time=ns)
        elif isinstance(message, m.Battery):
            self._sense_channel(f"/rover_{rover}/battery", fl.BATTERY_SCHEMA).log(fl.battery(message), log_time=ns)
        else:
            return False
        return True

    def _sense_channel(self, topic: str, kind: str | dict):
        if topic not in self.senses:
            import foxglove

            self.senses[topic] = (_channel(kind, topic, self.context) if isinstance(kind, str) else
                                  foxglove.Channel(topic, schema=kind, message_encoding="json", context=self.context))
        return self.senses[topic]

    def take_commands(self) -> list:
        """The ground commands Foxglove's clients asked for since the last call (their threads queue them)."""
        out, self.ground.outbox = self.ground.outbox, []
        return out

    def serve(self, host: str = "127.0.0.1", port: int = 8765,
              timeline_s: float = DEFAULT_TIMELINE_S) -> foxglove.WebSocketServer:
        """Start the WebSocket server; a client subscribing to ``/scene`` gets the static scene again."""
        import foxglove
        from foxglove.websocket import Capability

        from web.foxglove_extras import sim_ns

        self.server = foxglove.start_server(
            name="lunarsim", host=host, port=port, context=self.context, server_listener=_Listener(self),
            capabilities=[Capability.Time, Capability.ClientPublish, Capability.PlaybackControl],
            supported_encodings=["json"], playback_time_range=(0, sim_ns(timeline_s)))
        return self.server

    def close(self) -> None:
        for channel in (self.scene, self.tf, *self.photos.values(), *self.senses.values(),
                        *([self.map] if self.map else [])):
            channel.close()


class _Listener:
    """A new viewer of the scene needs the static part again; what clients publish and their playback controls
    become ground commands (``web.foxglove_extras.GroundInput``). Runs on the SDK's threads: it only queues."""

    def __init__(self, live: LiveScene) -> None:
        self.live = live

    def on_subscribe(self, client: object, channel: object) -> None:
        if getattr(channel, "topic", None) == self.live.fx.SCENE_TOPIC:
            self.live.static_wanted.set()

    def on_unsubscribe(self, client: object, channel: object) -> None:
        return None

    def on_client_advertise(self, client, channel) -> None:
        self.live.ground.advertised(client.id, channel.id, channel.topic, channel.encoding)

    def on_client_unadvertise(self, client, client_channel_id: int) -> None:
        self.live.ground.unadvertised(client.id, client_channel_id)

    def on_message_data(self, client, client_channel_id: int, data: bytes) -> None:
        self.live.ground.message(client.id, client_channel_id, data)

    def on_playback_control_request(self, request):
        from foxglove.websocket import PlaybackCommand, PlaybackState, PlaybackStatus

        live = self.live
        play = request.playback_command == PlaybackCommand.Play
        live.ground.playback(play, request.seek_time, live.paused)
        live.paused = not play
        now = request.seek_time if request.seek_time is not None else live.now_ns
        return PlaybackState(status=PlaybackStatus.Playing if play else PlaybackStatus.Paused, current_time=now,
                             playback_speed=request.playback_speed, did_seek=request.seek_time is not None,
                             request_id=request.request_id)


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


def _pump(live: LiveScene, feed: Feed, stop: threading.Event, send: Callable[[object], object]) -> None:
    """Convert samples and send the clients' ground commands until stopped; wakes at least every 0.2 s to notice
    the stop and resend the scene."""
    while not stop.is_set():
        for command in live.take_commands():
            send(command)
        try:
            sample = feed.queue.get(timeout=0.2)
        except queue.Empty:
            if live.static_wanted.is_set():
                live.static_wanted.clear()
                live.send_static()
            continue
        live.handle(sample)
