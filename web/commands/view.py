"""``lunarsim view``: a live world (or a replay) in the browser; ``--foxglove``: served to the Foxglove app.

Plain ``lunarsim view`` serves the web digital twin (``web``) at http://127.0.0.1:8080/: 3D view,
statistics, ground commands and the scenario editor. With ``--foxglove`` it serves Foxglove instead:

Subscribes to the world state, the rover photos and the lander's map of ``--world`` and serves the same channels as
``lunarsim export-foxglove`` (``/scene``, ``/tf``, ``/rover_<id>/photo``, ``/map``), so a live run and a recording
look alike, and beyond them the world's clock as Foxglove's time, the rovers' scan, IMU and battery, ground commands
from the app and its playback controls (``web.foxglove_extras``). Open the Foxglove app, "Open connection",
``ws://localhost:8765``, and add a 3D panel.
The static scene (terrain, obstacles, lander, goals) is drawn from ``--scenario`` and sent again to
each client that subscribes, since a WebSocket server keeps no history for late joiners.
"""

from __future__ import annotations

import argparse
import os
import socket
from pathlib import Path

from bus import paths, process
from bus.zenoh_config import add_zenoh_arguments
from web import guard

ROUTER_TIMEOUT_HELP = ("exit (code 3) if no router has been reachable S seconds after starting (default: wait for "
                       "one, however long, serving the page meanwhile; a router lost later is waited for again)")


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
    parser.add_argument("--timeline", type=float, default=3600.0, metavar="S",
                        help="--foxglove: simulated seconds Foxglove's playback bar spans, for seeking a replay "
                        "(default 3600)")
    add_zenoh_arguments(parser, agent=True, timeout_help=ROUTER_TIMEOUT_HELP)
    _add_web_arguments(parser)


def _add_web_arguments(parser: argparse.ArgumentParser) -> None:
    group = parser.add_argument_group("web view")
    group.add_argument("--workspace", type=paths.output_folder, default=Path("web-scenarios"), metavar="DIR",
                       help="folder the editor saves scenarios to and loads them from (default web-scenarios/)")
    group.add_argument("--runs", type=paths.output_folder, default=Path("runs"), metavar="DIR",
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


def run(args: argparse.Namespace) -> int:
    from bus.zenoh_config import DEFAULT_ENDPOINT, config_from_args, describe_endpoints
    from schemas.keyspace import Keyspace, check_world_name
    from schemas.scenario import load_scenario

    try:
        check_world_name(args.world)
    except ValueError as exc:
        raise process.UsageError(str(exc)) from None
    if args.port is None:
        args.port = 8765 if args.foxglove else 8080
    process.check_range("--timeline", args.timeline, 1.0, 1e9)
    if not args.foxglove:
        from web.view import WebSpec, serve_web

        access, url = web_access(args, dict(os.environ))
        spec = WebSpec(args.world, args.host, args.port, access, url, (args.connect or [DEFAULT_ENDPOINT])[0],
                       args.scenario, args.runs, args.workspace)
        return serve_web(spec, config_from_args(args), describe_endpoints(args), args.router_timeout)
    from web.foxglove_live import serve_foxglove

    if args.scenario is None:
        raise process.UsageError("--foxglove needs --scenario FILE (the terrain, obstacles, lander and goals)")
    scenario = load_scenario(args.scenario)
    return serve_foxglove(scenario, Keyspace(args.world), args.host, args.port, 0 if args.no_trails else 300,
                          config_from_args(args), describe_endpoints(args), args.router_timeout, args.timeline)
