"""Deployment on a network: rover ids without hand-editing, start-up in any order, the Zenoh config files,
and the world telling an agent that comes back how its action ended while it was away."""

from __future__ import annotations

import json
import os
import resource
import subprocess
import sys

import pytest
import zenoh
from procs import REPO, SCENARIOS, free_port, module, stop, two_rover_scenario, wait_for, wait_for_output

from bus.world_watch import ClockWatch
from bus.zenoh_config import SHARED_MEMORY, build_config
from deploy.children import wait_for_port
from rover_agent.identity import id_from_hostname, parse_id
from schemas import codec
from schemas import messages as m
from schemas.keyspace import Keyspace
from schemas.scenario import load_scenario
from world_service.rover_ids import RESERVE_S, IdDesk
from world_service.sim import World

ZENOH_DIR = REPO / "deploy" / "zenoh"


# ---- rover ids ----


@pytest.mark.parametrize(("text", "expected"), [("3", 3), (" 12 ", 12), ("auto", "auto"), ("ordinal", "ordinal")])
def test_parse_id_accepts_numbers_from_one_and_the_two_modes(text, expected):
    assert parse_id(text) == expected


@pytest.mark.parametrize("text", ["0", "-1", "two", "", "1.5", "٣"])
def test_parse_id_refuses_anything_else_naming_it(text):
    with pytest.raises(ValueError, match="rover id must be"):
        parse_id(text)


@pytest.mark.parametrize(("host", "rover"), [("rover-0", 1), ("rover-11", 12), ("lunar-rover-3.rovers.ns.svc", 4)])
def test_statefulset_ordinal_counts_rovers_from_one(host, rover):
    assert id_from_hostname(host) == rover


def test_ordinal_needs_a_numbered_host_name():
    with pytest.raises(ValueError, match="StatefulSet"):
        id_from_hostname("3f2a9c1b7d")


def test_id_desk_hands_out_the_lowest_free_id_once_and_again_to_the_same_requester():
    now = [0.0]
    desk = IdDesk([1, 2, 3], clock=lambda: now[0])
    desk.note_alive(1, True)  # an agent started with an explicit --id 1
    assert desk.grant("a").id == 2
    assert desk.grant("b").id == 3
    assert desk.grant("a").id == 2  # asked again (its reply was lost): the same id
    refused = desk.grant("c")
    assert refused.id is None and "all 3 rovers" in refused.detail
    desk.note_alive(2, True)
    desk.note_alive(2, False)  # rover 2's agent died: its id is free again
    assert desk.grant("c").id == 2


def test_id_desk_frees_a_grant_whose_agent_never_came():
    now = [0.0]
    desk = IdDesk([1], clock=lambda: now[0])
    assert desk.grant("a").id == 1
    assert desk.grant("b").id is None
    now[0] = RESERVE_S + 1
    assert desk.grant("b").id == 1


# ---- the world and an agent that comes back ----


def _one_rover_world() -> World:
    return World(load_scenario(SCENARIOS / "crater_observation.yaml").with_overrides(rovers=1), Keyspace("t"))


def _published(out, topic: str) -> list:
    return [msg for key, msg in out if key == Keyspace("t").rover(1, topic)]


def test_clock_watch_says_when_it_waits_finds_and_loses_the_world(capsys):
    now = [0.0]
    watch = ClockWatch("rover 4", "lunar/w/world/clock", now=lambda: now[0])
    watch.check()
    assert capsys.readouterr().err == ""
    now[0] = 3.5
    watch.check()
    watch.check()
    assert capsys.readouterr().err.count("rover 4: waiting for the world service") == 1
    watch.heard()
    assert "world service found" in capsys.readouterr().err
    now[0] = 9.0
    watch.check()
    assert "lost the world service" in capsys.readouterr().err
    watch.heard()
    assert "found" in capsys.readouterr().err


# ---- Zenoh config files ----


def _exchange(a: zenoh.Session, b: zenoh.Session, key: str) -> None:
    got: list[bytes] = []
    sub = b.declare_subscriber(key, lambda s: got.append(s.payload.to_bytes()))
    pub = a.declare_publisher(key)
    wait_for(lambda: pub.put(b"hello") or got, 10, f"a sample on {key} between the two sessions", interval=0.2)
    sub.undeclare()


def test_router_and_client_config_files_work_with_only_the_endpoints_changed():
    port = free_port()
    endpoint = f"tcp/127.0.0.1:{port}"
    router = module("deploy.router", "--config", str(ZENOH_DIR / "router.json5"), "--listen", endpoint)
    try:
        assert wait_for_port("127.0.0.1", port, 15, router)
        conf = lambda: build_config(config_file=str(ZENOH_DIR / "client.json5"), connect=[endpoint])  # noqa: E731
        with zenoh.open(conf()) as a, zenoh.open(conf()) as b:
            assert json.loads(conf().get_json("scouting/multicast/enabled")) is False
            _exchange(a, b, "lunar/cfg/test")
    finally:
        stop(router)


def test_peer_config_files_talk_without_a_router():
    port = free_port()
    first = build_config(config_file=str(ZENOH_DIR / "peer.json5"), listen=[f"tcp/127.0.0.1:{port}"])
    second = build_config(config_file=str(ZENOH_DIR / "peer.json5"), listen=[f"tcp/127.0.0.1:{free_port()}"],
                          connect=[f"tcp/127.0.0.1:{port}"])
    with zenoh.open(first) as a, zenoh.open(second) as b:
        _exchange(a, b, "lunar/peer/test")


def test_a_missing_or_broken_config_file_is_named(tmp_path):
    from bus.process import UsageError

    with pytest.raises(UsageError, match="does not exist"):
        build_config(config_file=str(tmp_path / "nope.json5"))
    broken = tmp_path / "broken.json5"
    broken.write_text("{ mode: 'client', connect: { endpoints: [ }")
    with pytest.raises(UsageError, match=r"broken\.json5.*not valid"):
        build_config(config_file=str(broken))
    with pytest.raises(UsageError, match="ZENOH_CONFIG"):
        build_config(environ={"ZENOH_CONFIG": str(tmp_path / "gone.json5")})


def test_scouting_is_off_unless_asked_for():
    assert json.loads(build_config().get_json("scouting/multicast/enabled")) is False
    assert json.loads(build_config(scouting=True).get_json("scouting/multicast/enabled")) is True


LARGE_PUT = """
import json, sys, threading, time
import zenoh
from bus.zenoh_config import build_config

endpoint, config = sys.argv[1], sys.argv[2] or None
received = []
with zenoh.open(build_config("router", config, listen=[endpoint])) as world, \\
        zenoh.open(build_config("client", config, connect=[endpoint])) as rover:
    rover.declare_subscriber("lunar/shm/rover/1/photo", lambda sample: received.append(1))
    deadline = time.monotonic() + 20
    while len(received) < 5:  # several, not the first: the first may cross before the transport agrees on memory
        if time.monotonic() > deadline:
            sys.exit(f"the client session received {len(received)} of 5 photo-sized puts in 20 s")
        world.put("lunar/shm/rover/1/photo", bytes(20_000))  # a photo's size: over Zenoh's 3 KB threshold
        time.sleep(0.05)
    status = dict(line.split(":", 1) for line in open("/proc/self/status"))
print(json.dumps({"locked_kib": int(status["VmLck"].split()[0])}))
"""


def _locked_after_a_photo(config: str = "") -> int:
    """KiB the process has locked after a router session sent a client session on loopback a photo-sized put."""
    done = subprocess.run([sys.executable, "-c", LARGE_PUT, f"tcp/127.0.0.1:{free_port()}", config], cwd=REPO,
                          capture_output=True, text=True, timeout=60)
    assert done.returncode == 0, done.stderr
    return json.loads(done.stdout.splitlines()[-1])["locked_kib"]


@pytest.mark.parametrize("path", sorted((REPO / "deploy").glob("*/*.json5")), ids=lambda p: p.name)
def test_shipped_config_files_keep_shared_memory_off(path):
    assert json.loads(zenoh.Config.from_file(str(path)).get_json(SHARED_MEMORY)) is False


def test_shared_memory_is_off_by_default_so_a_photo_locks_no_pool():
    """On Zenoh's default a first photo-sized put makes and locks a 16 MiB pool (36-50 ms of the sender's CPU in
    the real-time world); LunarSim's sessions copy it instead."""
    assert json.loads(build_config().get_json(SHARED_MEMORY)) is False
    assert _locked_after_a_photo() == 0


def _may_lock(size: int) -> bool:
    soft = resource.getrlimit(resource.RLIMIT_MEMLOCK)[0]
    return os.geteuid() == 0 or soft == resource.RLIM_INFINITY or soft >= size


@pytest.mark.skipif(not _may_lock(16 << 20), reason="this user may not lock the 16 MiB a shared-memory pool takes")
def test_a_config_file_may_switch_shared_memory_on_and_the_pool_shows(tmp_path):
    """The other side of the check above: with shared memory on, the same put locks the pool."""
    on = tmp_path / "shm.json5"
    on.write_text("{ scouting: { multicast: { enabled: false } }, transport: { shared_memory: { enabled: true } } }")
    assert json.loads(build_config(config_file=str(on)).get_json(SHARED_MEMORY)) is True
    assert _locked_after_a_photo(str(on)) >= 16 << 10


# ---- processes ----


@pytest.mark.e2e
def test_rovers_started_with_id_auto_get_distinct_ids_and_a_surplus_one_is_refused(router, tmp_path):
    keys = Keyspace("autoid")
    common = ["--world", keys.world, "--connect", router]
    scenario = two_rover_scenario(tmp_path)
    rovers = [module("rover_agent", "--id", "auto", *common) for _ in range(2)]  # before the world: they wait
    world = module("world_service", str(scenario), *common, "--no-lander", "--max-sim-time", "20",
                   "--time-scale", "2")
    states: list[m.WorldState] = []
    try:
        granted = sorted(int(wait_for_output(r, "id handed out", 40).split("rover ")[1].split(":")[0])
                         for r in rovers)
        assert granted == [1, 2]
        with zenoh.open(build_config(connect=[router])) as session:
            session.declare_subscriber(keys.state, lambda s: states.append(codec.decode(m.WorldState,
                                                                                          s.payload.to_bytes())))
            wait_for(lambda: states and all(r.alive for r in states[-1].rovers), 20, "both rovers alive")
        surplus = module("rover_agent", "--id", "auto", *common)
        out, _ = surplus.communicate(timeout=30)
        assert surplus.returncode == 2 and "no rover id left" in out, out
    finally:
        stop(world, *rovers)


@pytest.mark.e2e
def test_an_agent_started_first_waits_for_the_router_then_for_the_world(tmp_path):
    port = free_port()
    endpoint = f"tcp/127.0.0.1:{port}"
    common = ["--world", "order", "--connect", endpoint]
    rover = module("rover_agent", "--id", "1", *common)
    router = world = None
    try:
        wait_for_output(rover, "waiting for a Zenoh router", 20)
        router = module("deploy.router", "--listen", endpoint)
        wait_for_output(rover, "connected to the Zenoh router", 30)
        wait_for_output(rover, "waiting for the world service", 20)
        world = module("world_service", str(two_rover_scenario(tmp_path)), *common, "--no-lander")
        wait_for_output(rover, "world service found", 30)
        assert rover.poll() is None
    finally:
        stop(*[p for p in (rover, world, router) if p is not None])


def test_a_one_shot_tool_still_gives_up_without_a_router():
    proc = subprocess.run([*module_argv("deploy.cli"), "command", "stop", "--rover", "1", "--connect",
                           f"tcp/127.0.0.1:{free_port()}", "--router-timeout", "1"],
                          cwd=REPO, capture_output=True, text=True, timeout=60)
    assert proc.returncode == 3 and "no Zenoh router reachable" in proc.stderr


def module_argv(name: str) -> list[str]:
    import sys

    return [sys.executable, "-m", name]
