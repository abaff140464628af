"""Zenoh configuration, layered as in the zenoh-python examples, and opening a session with a clear error.

Layers, later wins: defaults (client mode, multicast scouting and shared memory off, so no scouting delay), a json5
file from ``--config`` or ``ZENOH_CONFIG``, then ``--connect`` / ``--listen`` endpoints. Only this module and the
command line read the environment; domain code receives a finished ``zenoh.Config``.
Kept light (no NumPy, no pydantic): the rover agent imports it.
"""

from __future__ import annotations

import argparse
import json
import os
import re
import socket
import sys
import threading
import time
from collections.abc import Sequence

import zenoh

from bus.errors import RouterUnreachable, UsageError

DEFAULT_PORT = 7447
DEFAULT_ENDPOINT = f"tcp/127.0.0.1:{DEFAULT_PORT}"
SHARED_MEMORY = "transport/shared_memory/enabled"
"""Off by default. Zenoh (1.x) on a machine's loopback copies every message over 3 KB (a photo, a photo relayed
through the radio, the world's state) into a 16 MiB shared-memory pool, which it makes and mlocks on the first
such message: 36-50 ms of the sending thread's CPU zeroing pages. In the real-time world that first photo held a
tick back by as much, past a gyroscope period, and every agent that relays a photo would lock 16 MiB of its own.
LunarSim's messages are small: a copy costs microseconds. A config file
may switch it back on."""


ONE_SHOT_TIMEOUT_S = 10.0
"""How long a one-shot tool (and ``lunarsim run --connect``) tries to reach its router before giving up."""


def reason(exc: zenoh.ZError) -> str:
    """A Zenoh error without the Rust source location it carries (``... at /root/.cargo/.../x.rs:447.``)."""
    return re.split(r"\s+at\s+\S+\.rs:\d+", str(exc))[0].strip()


def add_zenoh_arguments(parser: argparse.ArgumentParser, listen: bool = False, agent: bool = False,
                        timeout_help: str | None = None) -> None:
    """Zenoh flags of every process. Agents (``agent=True``: world, lander, rovers, recorder, bridges, the view)
    wait for their router for as long as it takes, so a deployment may start in any order; one-shot tools give up.
    ``timeout_help`` says what ``--router-timeout`` does where waiting means more than waiting (the view serves
    its page meanwhile)."""
    group = parser.add_argument_group("zenoh")
    group.add_argument("--connect", "-e", action="append", metavar="ENDPOINT",
                       help=f"router endpoint to connect to (default {DEFAULT_ENDPOINT}); repeatable")
    if listen:
        group.add_argument("--listen", "-l", action="append", metavar="ENDPOINT",
                           help="endpoint to listen on; repeatable")
    group.add_argument("--config", "-c", metavar="FILE", help="Zenoh json5 config file (else $ZENOH_CONFIG)")
    group.add_argument("--scouting", action="store_true",
                       help="switch multicast scouting on (off by default: it fails in most containers)")
    if agent:
        group.add_argument("--router-timeout", type=float, default=None, metavar="S", help=timeout_help or
                           "give up after S seconds without a router (default: wait for it, saying so)")
    else:
        group.add_argument("--router-timeout", type=float, default=ONE_SHOT_TIMEOUT_S, metavar="S",
                           help="seconds to keep trying to reach the router before giving up "
                                f"(default {ONE_SHOT_TIMEOUT_S:g})")


def build_config(mode: str = "client", config_file: str | None = None, connect: Sequence[str] | None = None,
                 listen: Sequence[str] | None = None, environ: dict[str, str] | None = None,
                 scouting: bool = False) -> zenoh.Config:
    environ = os.environ if environ is None else environ
    path = config_file or environ.get("ZENOH_CONFIG")
    conf = _load(path, "--config" if config_file else "ZENOH_CONFIG") if path else zenoh.Config()
    if not path:
        conf.insert_json5("mode", json.dumps(mode))
        conf.insert_json5("scouting/multicast/enabled", "false")
        conf.insert_json5(SHARED_MEMORY, "false")
        if not scouting:  # a router or peer waits this long in zenoh.open for answers to scouting it does not do
            conf.insert_json5("scouting/delay", "0")
    if connect:
        _insert_endpoints(conf, "connect", connect)
    elif not path and mode == "client":
        conf.insert_json5("connect/endpoints", json.dumps([DEFAULT_ENDPOINT]))
    if listen:
        _refuse_any_port(listen)
        _insert_endpoints(conf, "listen", listen)
    if scouting:
        conf.insert_json5("scouting/multicast/enabled", "true")
    return conf


def _insert_endpoints(conf: zenoh.Config, which: str, endpoints: Sequence[str]) -> None:
    """Zenoh parses endpoints here: a typo is the user's, said as such rather than as a Json5 error."""
    try:
        conf.insert_json5(f"{which}/endpoints", json.dumps(list(endpoints)))
    except zenoh.ZError:
        raise UsageError(f"--{which} {' '.join(endpoints)}: not a Zenoh endpoint (the form is "
                         f"<protocol>/<address>, e.g. {DEFAULT_ENDPOINT})") from None


def _refuse_any_port(listen: Sequence[str]) -> None:
    """Port 0 lets the system choose one that Zenoh does not report back, so no client could be told where to
    connect."""
    for endpoint in listen:
        if re.search(r":0+(?:[#?]|$)", endpoint):
            raise UsageError(f"--listen {endpoint}: port 0 would listen on a port no client is told of; name a free "
                             f"port (e.g. {DEFAULT_PORT})")


def _load(path: str, origin: str) -> zenoh.Config:
    if os.path.isdir(path):
        raise UsageError(f"Zenoh config file {path!r} (from {origin}) is a folder, not a json5 file")
    if not os.path.isfile(path):
        raise UsageError(f"Zenoh config file {path!r} (from {origin}) does not exist")
    try:
        return zenoh.Config.from_file(path)
    except zenoh.ZError as exc:
        raise UsageError(f"Zenoh config file {path!r} (from {origin}) is not valid: {reason(exc)}") from None


def config_from_args(args: argparse.Namespace, mode: str = "client") -> zenoh.Config:
    return build_config(mode, args.config, args.connect, getattr(args, "listen", None),
                        scouting=getattr(args, "scouting", False))


def describe_endpoints(args: argparse.Namespace) -> str:
    if args.connect:
        return ", ".join(args.connect)
    if args.config or os.environ.get("ZENOH_CONFIG"):
        return f"the endpoints in {args.config or os.environ['ZENOH_CONFIG']}"
    return DEFAULT_ENDPOINT


WAIT_REMINDER_S = 30.0


def port_in_use(host: str, port: int) -> bool:
    """Whether something listens there (a router, a world serving as one): a plain TCP connect, no Zenoh."""
    with socket.socket() as s:
        s.settimeout(0.2)
        return s.connect_ex((host, port)) == 0


def default_router_missing(args: argparse.Namespace) -> bool:
    """No endpoint was asked for and nothing listens on the default one: a tool that publishes (a replay) may then
    serve as the router there, so viewers started for a run that has ended find it where they look."""
    if args.connect or args.config or os.environ.get("ZENOH_CONFIG"):
        return False
    return not port_in_use("127.0.0.1", DEFAULT_PORT)


ONE_RECEIVING_THREAD = "(rx: (handover: app))"
"""Zenoh's runtimes as ``ZENOH_RUNTIME`` (RON) gives them: receiving runs on the one thread of the application
runtime instead of on two threads of its own (``receive_on_one_thread``)."""


def receive_on_one_thread() -> None:
    """For a process that receives a few samples at a time and answers each at once (one rover's agent): receiving and
    Zenoh's application tasks share one thread, and no second receiving thread wakes to look for work, which on a
    machine shared with the world and a router is much of a round trip (``docs/benchmarks.md``, the lockstep
    section). The world, the lander, routers and a process of many rovers' agents (``--ids``), which receive many
    rovers' traffic, keep Zenoh's default: with the world's receiving on one thread, 1,000 rovers' agents lagged
    2.2 s at p99 against 0.6 s. Sending keeps its own thread: an agent publishes from its receiving callback
    (``Bus.handle_directly``), and a put that waits out congestion must not wait on the thread that would drain the
    queue.

    Zenoh reads the variable once, as the process opens its first session, so this comes before; a value the user
    set wins."""
    os.environ.setdefault("ZENOH_RUNTIME", ONE_RECEIVING_THREAD)


def open_router(conf: zenoh.Config, listen: Sequence[str], config_file: str | None = None) -> zenoh.Session:
    """A session in router mode, listening: fails at once, naming the endpoints, when it cannot listen (another
    router on the port), since waiting would not free the port."""
    where = ", ".join(listen) or f"the endpoints of {config_file}"
    try:
        return zenoh.open(conf)
    except zenoh.ZError as exc:
        raise UsageError(f"cannot start a router listening on {where}: {reason(exc)} "
                         "(is another router already using the port?)") from None


def open_session(conf: zenoh.Config, where: str, timeout_s: float | None = 10.0, who: str = "lunarsim", *,
                 remind_s: float | None = WAIT_REMINDER_S, stop: threading.Event | None = None) -> zenoh.Session:
    """Open a session, retrying until ``timeout_s`` (None: for ever); say plainly on stderr that we are waiting,
    and again every ``remind_s`` (None: once), so a process started before its router is not mistaken for a hung
    one. ``stop`` set ends the wait (``RouterUnreachable``) for a process that has other work (the view's page)."""
    start = time.monotonic()
    next_notice = start
    while True:
        try:
            session = zenoh.open(conf)
        except zenoh.ZError as exc:
            now = time.monotonic()
            if timeout_s is not None and now - start >= timeout_s:
                raise RouterUnreachable(
                    f"{who}: no Zenoh router reachable at {where} after {timeout_s:g} s ({reason(exc)}). "
                    "Start one with 'lunarsim router' or point --connect at a running one."
                ) from None
            if now >= next_notice:
                waited = f" (waiting {now - start:.0f} s)" if now - start >= 1 else ""
                print(f"{who}: waiting for a Zenoh router at {where} ...{waited}", file=sys.stderr, flush=True)
                next_notice = now + remind_s if remind_s is not None else float("inf")
            if stop is None:
                time.sleep(0.5)
            elif stop.wait(0.5):
                raise RouterUnreachable(f"{who}: stopped while waiting for a Zenoh router at {where}") from None
            continue
        if next_notice > start:
            print(f"{who}: connected to the Zenoh router at {where}", file=sys.stderr, flush=True)
        return session
