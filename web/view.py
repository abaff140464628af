"""``lunarsim view`` (without ``--foxglove``): subscribe to a world on Zenoh and serve it to browsers."""

from __future__ import annotations

import argparse
import asyncio
import contextlib
import os
import signal
import socket
from pathlib import Path

import zenoh

from bus import process
from web import guard


def add_web_arguments(parser: argparse.ArgumentParser) -> None:
    group = parser.add_argument_group("web view")
    group.add_argument("--workspace", type=Path, default=Path("web-scenarios"), metavar="DIR",
                       help="folder the editor saves scenarios to and loads them from (default web-scenarios/)")
    group.add_argument("--runs", type=Path, default=Path("runs"), metavar="DIR",
                       help="where missions launched from the editor put their run folders (default runs/)")
    group.add_argument("--allow-host", action="append", default=[], metavar="NAME",
                       help="a host name the page may be opened by besides the loopback names and --host (a proxy's "
                            "or DNS name; repeat for more); requests naming any other host are refused")
    group.add_argument("--token", metavar="TOKEN",
                       help=f"the token the page asks for (16 to 256 letters, digits or '._~-'; default "
                            f"${guard.TOKEN_ENV}, else one made at start when --host is beyond loopback, none on "
                            "loopback)")


def web_access(args: argparse.Namespace, environ: dict[str, str]) -> tuple[guard.Access, str]:
    """Who may use the view (``guard.Access``) and the URL to print: with the token when one was made here."""
    given = args.token or environ.get(guard.TOKEN_ENV) or None
    try:
        token, made = guard.choose_token(args.host, given)
    except ValueError as exc:
        raise process.UsageError(f"{'--token' if args.token else guard.TOKEN_ENV}: {exc}") from None
    try:
        access = guard.access_for(args.host, args.allow_host, token)
    except guard.HostError as exc:
        raise process.UsageError(f"--host/--allow-host: {exc}") from None
    host = socket.gethostname() if args.host in guard.WILDCARDS else args.host
    host = f"[{host}]" if ":" in host else host
    url = f"http://{host}:{args.port}/"
    if made:
        url += f"?token={token}"
    elif token is not None:
        url += " (with the token given)"
    return access, url


def run_web(args: argparse.Namespace) -> int:
    """Serve at once; the Zenoh session opens when a router is reachable (``web.link``), the page says meanwhile
    that it waits for a world, and ``--router-timeout`` (if given) ends the wait with exit code 3."""
    from bus.zenoh_config import DEFAULT_ENDPOINT, config_from_args, describe_endpoints
    from schemas import codec
    from schemas.keyspace import Keyspace
    from schemas.scenario import load_scenario
    from web import editor, live
    from web.commands import Commands
    from web.link import RouterLink
    from web.server import Viewer, build_app

    access, url = web_access(args, dict(os.environ))
    scenario = load_scenario(args.scenario) if args.scenario else None
    latest = live.Latest()
    source = live.Source(describe_endpoints(args), connected=False)
    link = RouterLink(config_from_args(args), source, args.router_timeout)
    keys = Keyspace(args.world)
    commands = Commands(lambda cmd: link.put(keys.ground_command, codec.encode(cmd)))
    endpoint = (args.connect or [DEFAULT_ENDPOINT])[0]
    launcher = editor.Launcher(args.runs, endpoint, args.world)
    viewer = Viewer(args.world, latest, commands, editor.Workspace(args.workspace), launcher, scenario, source)
    try:
        asyncio.run(_serve(build_app(viewer, access), args, url, link,
                           lambda session: _subscribe(session, keys, viewer)))
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


async def _serve(app, args: argparse.Namespace, url: str, link, declare) -> None:
    """Serve until SIGINT or SIGTERM, or until the link gives up on its router; says where once the port is bound
    (tests wait for that line), then starts the link, whose waiting for a router is said after it."""
    from aiohttp import web

    runner = web.AppRunner(app, access_log=None)
    await runner.setup()
    try:
        try:
            await web.TCPSite(runner, args.host, args.port).start()
        except OSError as exc:
            raise process.UsageError(f"cannot serve on {args.host}:{args.port}: {exc.strerror or exc}") from None
        print(f"serving world {args.world!r} at {url} (Ctrl-C stops)", flush=True)
        stop = asyncio.Event()
        loop = asyncio.get_running_loop()
        for sig in (signal.SIGINT, signal.SIGTERM):
            loop.add_signal_handler(sig, stop.set)
        link.when_failed(lambda: loop.call_soon_threadsafe(stop.set))
        link.start(declare)
        await stop.wait()
    finally:
        await runner.cleanup()
