"""``lunarsim view`` (without ``--foxglove``): subscribe to a world on Zenoh and serve it to browsers."""

from __future__ import annotations

import argparse
import asyncio
import contextlib
import os
import signal
import socket
from pathlib import Path

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
    import zenoh

    from bus.bus import zenoh_callback
    from bus.zenoh_config import DEFAULT_ENDPOINT, config_from_args, describe_endpoints, open_session
    from schemas import codec
    from schemas.keyspace import MAP, PHOTO, STATUS, Keyspace
    from schemas.scenario import load_scenario
    from web import editor, live
    from web.commands import Commands
    from web.server import Viewer, build_app

    keys = Keyspace(args.world)
    access, url = web_access(args, dict(os.environ))
    scenario = load_scenario(args.scenario) if args.scenario else None
    session = open_session(config_from_args(args), describe_endpoints(args), args.router_timeout,
                           who="lunarsim view")
    latest = live.Latest()
    commands = Commands(lambda cmd: session.put(keys.ground_command, codec.encode(cmd)))
    streams = {keys.state: "state", keys.stats: "stats", keys.lander(STATUS): "lander",
               keys.lander(MAP): "map"}

    def on_sample(sample: zenoh.Sample) -> None:
        key = str(sample.key_expr)
        if key in streams:
            latest.put(streams[key], sample.payload.to_bytes())
        elif key == keys.ground_command_result:
            commands.on_result(sample.payload.to_bytes())
        else:
            with contextlib.suppress(ValueError):
                latest.put_photo(keys.parse_rover_key(key)[0], sample.payload.to_bytes())

    handler = zenoh_callback(on_sample)
    subscribers = [session.declare_subscriber(key, handler) for key in
                   (*streams, keys.ground_command_result, keys.rovers(PHOTO))]
    endpoint = (args.connect or [DEFAULT_ENDPOINT])[0]
    launcher = editor.Launcher(args.runs, endpoint, args.world)
    viewer = Viewer(args.world, latest, commands, editor.Workspace(args.workspace), launcher, scenario)
    try:
        asyncio.run(_serve(build_app(viewer, access), args, url))
    finally:
        launcher.stop()
        for subscriber in subscribers:
            subscriber.undeclare()
        session.close()
    return 0


async def _serve(app, args: argparse.Namespace, url: str) -> None:
    """Serve until SIGINT or SIGTERM; says where once the port is bound (tests wait for that line)."""
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
        await stop.wait()
    finally:
        await runner.cleanup()
