"""Two hosts on this machine for ``scale.py --two-hosts``: Linux network namespaces joined by a veth pair, the
deploy tests' setup (tests/e2e/test_multihost.py). The world, the lander and a router on one host (the hub), the
rover agents, the witness and a router of their own on the other (the fleet), the fleet's router connected to the
hub's over the link; the benchmark reaches the hub's router over a second link from this machine's own namespace.

The namespaces share this machine's cores: the split adds a router and a hop between hosts, not CPU.
"""

from __future__ import annotations

import os
import shutil
import subprocess
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import dataclass

SUBNET = "10.203"
"""Link 1 joins the fleet to the hub (hub .1.1, fleet .1.2); link 2 this machine to the hub (hub .2.1, here .2.2)."""


@dataclass(frozen=True)
class TwoHosts:
    hub: str
    fleet: str
    hub_from_fleet: str = f"{SUBNET}.1.1"
    hub_from_here: str = f"{SUBNET}.2.1"

    def on(self, namespace: str) -> tuple[str, ...]:
        """The command prefix that runs a process on that host."""
        return ("ip", "netns", "exec", namespace)


def unavailable() -> str | None:
    """Why namespaces cannot be made here, or None."""
    if os.geteuid() != 0:
        return "--two-hosts needs root (ip netns add)"
    if shutil.which("ip") is None:
        return "--two-hosts needs the ip command (iproute2)"
    return None


@contextmanager
def two_hosts() -> Iterator[TwoHosts]:
    """The two namespaces and their links for the time of the block, removed after (also on an error)."""
    tag = os.getpid() % 100000
    hosts = TwoHosts(f"lsb{tag}h", f"lsb{tag}f")
    made: list[str] = []
    outside = f"lsb{tag}x"
    try:
        for namespace in (hosts.hub, hosts.fleet):
            _ip("netns", "add", namespace)
            made.append(namespace)
            _ip("-n", namespace, "link", "set", "lo", "up")
        _veth(f"lsb{tag}a", hosts.hub, f"{SUBNET}.1.1", f"lsb{tag}b", hosts.fleet, f"{SUBNET}.1.2")
        _veth(f"lsb{tag}c", hosts.hub, f"{SUBNET}.2.1", outside, None, f"{SUBNET}.2.2")
        yield hosts
    finally:
        subprocess.run(["ip", "link", "del", outside], capture_output=True)
        for namespace in made:
            subprocess.run(["ip", "netns", "del", namespace], capture_output=True)  # their veth ends go too


def _veth(near: str, near_ns: str, near_ip: str, far: str, far_ns: str | None, far_ip: str) -> None:
    """A veth pair, ``near`` in ``near_ns`` and ``far`` in ``far_ns`` (None: this machine's namespace), /24 each."""
    _ip("link", "add", near, "netns", near_ns, "type", "veth", "peer", "name", far,
        *(("netns", far_ns) if far_ns else ()))
    _ip("-n", near_ns, "addr", "add", f"{near_ip}/24", "dev", near)
    _ip("-n", near_ns, "link", "set", near, "up")
    side = ("-n", far_ns) if far_ns else ()
    _ip(*side, "addr", "add", f"{far_ip}/24", "dev", far)
    _ip(*side, "link", "set", far, "up")


def _ip(*args: str) -> None:
    subprocess.run(["ip", *args], check=True, capture_output=True, text=True)
