"""``lunarsim acl``: the secured router's config, with access control generated from a scenario.

    deploy/security/make-dev-certs.sh secure/certs 5             # a development CA and per-role certs
    lunarsim acl scenarios/crater_observation.yaml -o secure/router.json5
    lunarsim router --config secure/router.json5
    lunarsim rover --id 1 --config secure/clients/rover-1.json5 ...

Real rovers: ``make-dev-certs.sh --bridges all ...`` and ``lunarsim acl ... --bridges all`` (or ids, ``1,3``)
add a ``bridge-<id>`` role per real rover, for ``lunarsim bridge --id <id> --config clients/bridge-<id>.json5``.
ROS 2: ``make-dev-certs.sh --ros2 ...`` and ``lunarsim acl ... --ros2 [DOMAIN]`` add ``ros2`` (``lunarsim ros2``)
and ``ros2-nodes`` (the ROS 2 nodes on rmw_zenoh).

Writes the router config (TLS with mutual authentication, user/password auth, and an ``access_control``
section that gives each role only its own keys: see ``deploy.security.acl``), the router's user/password
dictionary (``credentials.txt`` beside it; passwords already there are kept) and one client config per
role (``world``, ``lander``, ``ground``, ``recorder``, ``view``, ``rover-<id>``, ``bridge-<id>``) in ``--clients``.
"""

from __future__ import annotations

import argparse
from pathlib import Path

from bus import paths, process

DEFAULT_LISTEN = "tls/0.0.0.0:7447"
DEFAULT_CONNECT = "tls/localhost:7447"


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("scenario", type=Path, help="scenario file: its rovers get a role each (rover-1 ...)")
    parser.add_argument("-o", "--output", type=paths.output_file, required=True, metavar="FILE",
                        help="the router's json5 config to write (access control included)")
    parser.add_argument("--world", default="default", help="world name in the keyspace (default: default)")
    parser.add_argument("--rovers", type=int, metavar="N", help="N rovers instead of the scenario's (as run --rovers)")
    parser.add_argument("--bridges", metavar="IDS",
                        help="real rovers, each behind lunarsim bridge: 'all' or ids such as 1,3 (default none). "
                             "Each gets a bridge-<id> role that alone publishes its sensors and telemetry; the "
                             "world may then publish none of them and follows them as a twin")
    parser.add_argument("--bridge-clock", action="store_true",
                        help="the one bridge publishes the clock (lunarsim bridge --clock: a bench, no world) "
                             "instead of the world")
    parser.add_argument("--ros2", type=int, nargs="?", const=0, default=None, metavar="DOMAIN",
                        help="a ROS 2 bridge joins (lunarsim ros2) on this ROS domain (default 0): roles ros2, with "
                             "the ground's say and read access to what it bridges, and ros2-nodes, the ROS 2 nodes, "
                             "which may touch only their domain's topics")
    parser.add_argument("--ros2-truth", action="store_true",
                        help="the ROS 2 bridge may read ground truth (for lunarsim ros2 --truth); off by default")
    parser.add_argument("--ros2-drive", metavar="IDS",
                        help="rovers ROS 2 nodes drive through the bridge (lunarsim ros2 --drive, run --external), "
                             "e.g. 1 or 1,3: the bridge may act for them as their agent")
    parser.add_argument("--certs", type=Path, metavar="DIR",
                        help="folder made by make-dev-certs.sh (default: certs/ beside the output)")
    parser.add_argument("--credentials", type=Path, metavar="FILE",
                        help="user:password dictionary to write (default: credentials.txt beside the output)")
    parser.add_argument("--clients", type=Path, metavar="DIR",
                        help="folder for the per-role client configs (default: clients/ beside the output)")
    parser.add_argument("--listen", action="append", metavar="ENDPOINT",
                        help=f"router endpoint, tls/ only (default {DEFAULT_LISTEN}); repeatable")
    parser.add_argument("--connect", action="append", metavar="ENDPOINT",
                        help=f"endpoint in the client configs (default {DEFAULT_CONNECT}); its host must be one "
                             "the router's certificate names; repeatable")


def _rover_ids(args: argparse.Namespace) -> list[int]:
    from schemas.scenario import load_scenario

    scenario = load_scenario(args.scenario)
    if args.rovers is not None:
        if args.rovers < 1:
            raise process.UsageError(f"--rovers must be 1 or more, got {args.rovers}")
        return list(range(1, args.rovers + 1))
    return list(range(1, len(scenario.rovers) + 1))


def _bridged(given: str | None, rover_ids: list[int]) -> list[int]:
    """The rover ids of ``--bridges``: none, ``all`` or a comma-separated list."""
    if given is None:
        return []
    if given.strip() == "all":
        return rover_ids
    try:
        return [int(part) for part in given.split(",")]
    except ValueError:
        raise process.UsageError(f"--bridges {given}: expected 'all' or rover ids separated by commas (1,3)") from None


def _ros2_access(args: argparse.Namespace):
    """What ``--ros2``, ``--ros2-truth`` and ``--ros2-drive`` grant, or None without ``--ros2``."""
    from deploy.security.acl import Ros2Access
    from ros2_bridge.rmw import DOMAIN_ID_LIMIT

    if args.ros2 is None:
        if args.ros2_truth or args.ros2_drive:
            raise process.UsageError("--ros2-truth and --ros2-drive need --ros2")
        return None
    if not 0 <= args.ros2 <= DOMAIN_ID_LIMIT:
        raise process.UsageError(f"--ros2: the ROS 2 domain id must be 0 to {DOMAIN_ID_LIMIT}, got {args.ros2}")
    driven: tuple[int, ...] = ()
    if args.ros2_drive:
        try:
            driven = tuple(int(part) for part in args.ros2_drive.split(","))
        except ValueError:
            raise process.UsageError(f"--ros2-drive {args.ros2_drive[:40]}: expected rover ids such as 1,3") from None
    return Ros2Access(args.ros2, args.ros2_truth, driven)


def _endpoints(given: list[str] | None, default: str, flag: str) -> list[str]:
    endpoints = given or [default]
    for endpoint in endpoints:
        if not endpoint.startswith("tls/"):
            raise process.UsageError(f"{flag} {endpoint}: a secured router speaks only TLS (use tls/HOST:PORT)")
    return endpoints


def run(args: argparse.Namespace) -> int:
    from deploy.security import acl, configs
    from deploy.security.secured import write_secured
    from schemas.keyspace import Keyspace

    try:
        keys = Keyspace(args.world)
    except ValueError as exc:
        raise process.UsageError(str(exc)) from None
    listen = _endpoints(args.listen, DEFAULT_LISTEN, "--listen")
    connect = _endpoints(args.connect, DEFAULT_CONNECT, "--connect")
    base = args.output.parent
    certs, credentials = args.certs or base / "certs", args.credentials or base / "credentials.txt"
    clients = args.clients or base / "clients"
    rover_ids = _rover_ids(args)
    bridged = _bridged(args.bridges, rover_ids)
    if args.bridge_clock and len(bridged) != 1:
        raise process.UsageError(f"--bridge-clock needs exactly one bridge (--bridges ID: one rover on a bench), got "
                                 f"{len(bridged)}")
    ros2 = _ros2_access(args)
    try:
        roles = acl.roles(keys, rover_ids, bridged, args.bridge_clock, ros2)
    except ValueError as exc:
        raise process.UsageError(f"--bridges or --ros2-drive: {exc}") from None
    names = [r.name for r in roles]
    missing = configs.missing_cert_files(certs, [configs.ROUTER, *names])
    if missing:
        bridges = (f"--bridges {args.bridges} " if bridged else "") + ("--ros2 " if ros2 is not None else "")
        raise process.UsageError(f"{len(missing)} certificate file(s) missing in {certs}, first {missing[0]}: make "
                                 f"them with deploy/security/make-dev-certs.sh {bridges}{certs} {len(rover_ids)}")
    try:
        existing = configs.parse_credentials(credentials.read_text(encoding="utf-8")) if credentials.exists() else {}
    except ValueError as exc:
        raise process.UsageError(f"{credentials}: {exc}") from None
    real = f", real rovers behind bridges: {', '.join(map(str, bridged))}" if bridged else ""
    header = f"Written by: lunarsim acl {args.scenario} (world {args.world!r}, {len(rover_ids)} rovers{real})"
    names = write_secured(args.output, certs, credentials, clients, roles, keys, existing, listen, connect, header)
    print(f"roles: {', '.join(names)}; start the router with: lunarsim router --config {args.output}")
    return 0
