"""``lunarsim view`` (without ``--foxglove``): subscribe to a world on Zenoh and serve it to browsers."""

from __future__ import annotations

import argparse
import asyncio
import contextlib
import signal
from pathlib import Path

from bus import process


def add_web_arguments(parser: argparse.ArgumentParser) -> None:
    group = parser.add_argument_group("web view")
    group.add_argument("--workspace", type=Path, default=Path("web-scenarios"), metavar="DIR",
                       help="folder the editor saves scenarios to and loads them from (default web-scenarios/)")
    group.add_argument("--runs", type=Path, default=Path("runs"), metavar="DIR",
                       help="where missions launched from the editor put their run folders (default runs/)")


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
        asyncio.run(_serve(build_app(viewer), args))
    finally:
        launcher.stop()
        for subscriber in subscribers:
            subscriber.undeclare()
        session.close()
    return 0


async def _serve(app, args: argparse.Namespace) -> None:
    """Serve until SIGINT or SIGTERM; says where once the port is bound (tests wait for that line)."""
    from aiohttp import web

    runner = web.AppRunner(app, access_log=None)
    await runner.setup()
    try:
        try:
            await web.TCPSite(runner, args.host, args.port).start()
        except OSError as exc:
            raise process.UsageError(f"cannot serve on {args.host}:{args.port}: {exc.strerror or exc}") from None
        print(f"serving world {args.world!r} at http://{args.host}:{args.port}/ (Ctrl-C stops)", flush=True)
        stop = asyncio.Event()
        loop = asyncio.get_running_loop()
        for sig in (signal.SIGINT, signal.SIGTERM):
            loop.add_signal_handler(sig, stop.set)
        await stop.wait()
    finally:
        await runner.cleanup()
