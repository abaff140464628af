"""A world on Zenoh served to browsers (``lunarsim view`` without ``--foxglove``): the page, its live streams, its
ground commands and the scenario editor."""

from __future__ import annotations

import asyncio
import contextlib
import signal
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import zenoh

from bus import process
from web import guard


@dataclass(frozen=True)
class WebSpec:
    """Where and what the view serves: the options of ``lunarsim view`` (its ``--help`` says what each does)."""

    world: str
    host: str
    port: int
    access: guard.Access
    url: str
    """Where the page is, as printed: with the token when one was made at start."""
    endpoint: str
    """The router missions launched from the editor join."""
    scenario: Path | None = None
    runs: Path = Path("runs")
    workspace: Path = Path("web-scenarios")


def serve_web(spec: WebSpec, conf: zenoh.Config, endpoints: str, router_timeout: float | None) -> int:
    """Serve at once; the Zenoh session opens when a router is reachable (``web.link``), the page says meanwhile
    that it waits for a world, and ``router_timeout`` (if given) ends the wait with exit code 3."""
    from schemas import codec
    from schemas.keyspace import Keyspace
    from schemas.scenario import load_scenario
    from web import editor, live
    from web.link import RouterLink
    from web.page_commands import Commands
    from web.server import Viewer, build_app

    scenario = load_scenario(spec.scenario) if spec.scenario else None
    latest = live.Latest()
    source = live.Source(endpoints, connected=False)
    link = RouterLink(conf, source, router_timeout)
    keys = Keyspace(spec.world)
    commands = Commands(lambda cmd: link.put(keys.ground_command, codec.encode(cmd)))
    launcher = editor.Launcher(spec.runs, spec.endpoint, spec.world)
    viewer = Viewer(spec.world, latest, commands, editor.Workspace(spec.workspace), launcher, scenario, source)
    try:
        asyncio.run(_serve(build_app(viewer, spec.access), spec, link,
                           lambda session: _subscribe(session, keys, viewer), launcher.stop))
    finally:
        launcher.stop()
        link.close()
    link.raise_failure()
    return 0


def _subscribe(session: zenoh.Session, keys, viewer) -> list:
    """The world's streams into ``viewer.latest``, the lander's answers to the commands, replays' tokens into
    ``viewer.source``. Runs when the session opens; the callbacks only store bytes."""
    from bus.bus import zenoh_callback
    from schemas.keyspace import MAP, PHOTO, STATUS

    streams = {keys.state: "state", keys.stats: "stats", keys.lander(STATUS): "lander", keys.lander(MAP): "map"}

    def on_sample(sample: zenoh.Sample) -> None:
        key = str(sample.key_expr)
        if key in streams:
            viewer.latest.put(streams[key], sample.payload.to_bytes())
        elif key == keys.ground_command_result:
            viewer.commands.on_result(sample.payload.to_bytes())
        else:
            with contextlib.suppress(ValueError):
                viewer.latest.put_photo(keys.parse_rover_key(key)[0], sample.payload.to_bytes())

    def on_token(sample: zenoh.Sample) -> None:
        viewer.source.replay_token(str(sample.key_expr), sample.kind == zenoh.SampleKind.PUT)

    handler = zenoh_callback(on_sample)
    declared = [session.declare_subscriber(key, handler) for key in
                (*streams, keys.ground_command_result, keys.rovers(PHOTO))]
    declared.append(session.liveliness().declare_subscriber(keys.alive_replays, zenoh_callback(on_token),
                                                            history=True))
    return declared


async def _serve(app, spec: WebSpec, link, declare, stop_launched: Callable[[], None]) -> None:
    """Serve until SIGINT or SIGTERM, or until the link gives up on its router; says where once the port is bound
    (tests wait for that line), then starts the link, whose waiting for a router is said after it.

    A mission launched from the page is stopped first, before the server's connections are closed: that may take
    a while with a page open, and a view killed meanwhile must not leave the mission running with no one to stop
    it."""
    from aiohttp import web

    runner = web.AppRunner(app, access_log=None)
    await runner.setup()
    try:
        try:
            await web.TCPSite(runner, spec.host, spec.port).start()
        except OSError as exc:
            raise process.UsageError(f"cannot serve on {spec.host}:{spec.port}: {exc.strerror or exc}") from None
        print(f"serving world {spec.world!r} at {spec.url} (Ctrl-C stops)", flush=True)
        stop = asyncio.Event()
        loop = asyncio.get_running_loop()
        for sig in (signal.SIGINT, signal.SIGTERM):
            loop.add_signal_handler(sig, stop.set)
        link.when_failed(lambda: loop.call_soon_threadsafe(stop.set))
        link.start(declare)
        await stop.wait()
    finally:
        await asyncio.to_thread(stop_launched)
        await runner.cleanup()
