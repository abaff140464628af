"""Three hosts without Docker: Linux network namespaces joined by veth pairs.

The router runs on one host, the world and the lander on a second, the rovers on a third; they reach each
other only over the veth links, by address. The crater mission completes across them, and also when the
router is killed and restarted mid-mission: every process reconnects by itself and the mission goes on.
"""

from __future__ import annotations

import json
import os
import shutil
import signal
import subprocess
import sys
import time
from dataclasses import dataclass

import pytest
import zenoh
from procs import REPO, SCENARIOS, stop, wait_for

from bus.zenoh_config import build_config
from schemas import codec
from schemas import messages as m
from schemas.keyspace import Keyspace

pytestmark = pytest.mark.e2e
PORT = 7447
SCENARIO = SCENARIOS / "crater_observation.yaml"


def _ip(*args: str) -> None:
    subprocess.run(["ip", *args], check=True, capture_output=True, text=True)


@dataclass
class Hosts:
    router: str
    world: str
    rovers: str
    router_from_world: str  # the router's address on each link
    router_from_rovers: str
    router_from_ground: str  # the test process itself is the ground station, on a fourth link


def _can_make_namespaces() -> str | None:
    if os.geteuid() != 0:
        return "network namespaces need root (ip netns add); run the tests as root to cover several hosts"
    if shutil.which("ip") is None:
        return "the ip command (iproute2) is not installed"
    return None


@pytest.fixture
def hosts():
    reason = _can_make_namespaces()
    if reason:
        pytest.skip(reason)
    tag = f"{os.getpid() % 100000}"
    names = Hosts(f"ls{tag}r", f"ls{tag}w", f"ls{tag}v", "10.201.1.1", "10.201.2.1", "10.201.3.1")
    made: list[str] = []
    made_links: list[str] = []
    try:
        for ns in (names.router, names.world, names.rovers):
            _ip("netns", "add", ns)
            made.append(ns)
            _ip("-n", ns, "link", "set", "lo", "up")
        for link, (peer_ns, subnet) in enumerate(((names.world, "10.201.1"), (names.rovers, "10.201.2")), 1):
            near, far = f"lsr{tag}{link}", f"lsh{tag}{link}"
            _ip("link", "add", near, "netns", names.router, "type", "veth", "peer", "name", far, "netns", peer_ns)
            _ip("-n", names.router, "addr", "add", f"{subnet}.1/24", "dev", near)
            _ip("-n", peer_ns, "addr", "add", f"{subnet}.2/24", "dev", far)
            _ip("-n", names.router, "link", "set", near, "up")
            _ip("-n", peer_ns, "link", "set", far, "up")
        ground, ground_far = f"lsg{tag}", f"lsr{tag}3"
        _ip("link", "add", ground, "type", "veth", "peer", "name", ground_far, "netns", names.router)
        made_links.append(ground)
        _ip("addr", "add", "10.201.3.2/24", "dev", ground)
        _ip("-n", names.router, "addr", "add", "10.201.3.1/24", "dev", ground_far)
        _ip("link", "set", ground, "up")
        _ip("-n", names.router, "link", "set", ground_far, "up")
    except subprocess.CalledProcessError as exc:
        _remove(made, made_links)
        pytest.skip(f"cannot create network namespaces here: {exc.stderr.strip()}")
    yield names
    _remove(made, made_links)


def _remove(namespaces: list[str], links: list[str]) -> None:
    for link in links:
        subprocess.run(["ip", "link", "del", link], capture_output=True)
    for ns in namespaces:
        subprocess.run(["ip", "netns", "del", ns], capture_output=True)  # also removes their veth pairs


def _on(ns: str, module: str, *args: str, log) -> subprocess.Popen:
    """``python -m MODULE ARGS`` on host ``ns`` (``ip netns exec`` replaces itself with the process)."""
    return subprocess.Popen(["ip", "netns", "exec", ns, sys.executable, "-m", module, *args], cwd=REPO,
                            stdout=log, stderr=subprocess.STDOUT, text=True)


class Mission:
    def __init__(self, hosts: Hosts, tmp_path) -> None:
        self.hosts, self.tmp = hosts, tmp_path
        self.logs = tmp_path / "logs"
        self.logs.mkdir()
        self.procs: dict[str, subprocess.Popen] = {}
        self.report = tmp_path / "report.json"

    def start(self, name: str, ns: str, module: str, *args: str) -> subprocess.Popen:
        log = open(self.logs / f"{name}.log", "a")  # noqa: SIM115 (closed with the process by the OS)
        self.procs[name] = _on(ns, module, *args, log=log)
        return self.procs[name]

    def start_router(self) -> None:
        self.start("router", self.hosts.router, "deploy.router", "--listen", f"tcp/0.0.0.0:{PORT}")

    def start_agents(self) -> None:
        h = self.hosts
        to_world_link = ["--connect", f"tcp/{h.router_from_world}:{PORT}"]
        to_rover_link = ["--connect", f"tcp/{h.router_from_rovers}:{PORT}"]
        self.start("world", h.world, "world_service", str(SCENARIO), *to_world_link, "--time-scale", "3",
                   "--exit-when-done", "--report", str(self.report), "--max-sim-time", "600")
        self.start("lander", h.world, "lander_agent", str(SCENARIO), *to_world_link)
        for rid in range(1, 6):
            self.start(f"rover{rid}", h.rovers, "rover_agent", "--id", str(rid), "--params", str(SCENARIO),
                       *to_rover_link)

    def log(self, name: str) -> str:
        return (self.logs / f"{name}.log").read_text()

    def stop(self) -> None:
        stop(*self.procs.values())


def _watch_states(hosts: Hosts, keys: Keyspace, states: list[m.WorldState]) -> zenoh.Session:
    """A viewer on the ground-station link: it reconnects after the restart like every other process."""
    session = zenoh.open(build_config(connect=[f"tcp/{hosts.router_from_ground}:{PORT}"]))
    session.declare_subscriber(keys.state, lambda s: states.append(codec.decode(m.WorldState, s.payload.to_bytes())))
    return session


def test_the_crater_mission_runs_across_three_hosts_and_survives_a_router_restart(hosts, tmp_path):
    mission = Mission(hosts, tmp_path)
    states: list[m.WorldState] = []
    watcher = None
    try:
        mission.start_router()
        mission.start_agents()  # the router may not be listening yet: the agents wait for it
        wait_for(lambda: _router_listening(hosts), 30, "the router on the ground link")
        watcher = _watch_states(hosts, Keyspace(), states)
        wait_for(lambda: states and min(r.distance_covered_m for r in states[-1].rovers) > 5, 120,
                 "every rover under way across the hosts")
        mission.procs["router"].send_signal(signal.SIGKILL)
        mission.procs["router"].wait(timeout=10)
        killed_at = len(states)
        time.sleep(2.0)  # the outage itself: no condition to wait for while nothing can be heard
        mission.start_router()
        wait_for(lambda: len(states) > killed_at + 20, 60, "world states again after the router restart")
        wait_for(lambda: all(r.alive for r in states[-1].rovers), 60, "every rover agent back")
        world = mission.procs["world"]
        wait_for(lambda: world.poll() is not None, 360, "the mission to finish after the restart")
        assert world.returncode == 0, mission.log("world")
        for name, proc in mission.procs.items():
            if name not in ("world", "router"):
                assert proc.poll() is None, f"{name} died:\n{mission.log(name)}"
        report = json.loads(mission.report.read_text())
        assert report["complete"] is True, report
        assert report["rovers_reached_final_goal"] == 5, report
        assert report["rover_collisions"] == 0 and report["rovers_stuck"] == 0, report
    finally:
        if watcher is not None:
            watcher.close()
        mission.stop()


def _router_listening(hosts: Hosts) -> bool:
    import socket

    try:
        with socket.create_connection((hosts.router_from_ground, PORT), timeout=0.5):
            return True
    except OSError:
        return False
