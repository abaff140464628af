"""A locked-down keyspace: TLS with mutual authentication, user/password auth and per-role access control.

Unit tests check the generated rules with a small model of Zenoh's matching (a rule allows a message when
one of its key expressions includes the message's). The rest runs a real router (``lunarsim router
--config``) configured by ``lunarsim acl`` with certificates made by ``make-dev-certs.sh``, and real
clients and processes. Every "did not arrive" is asserted only after something sent later on the same
session did arrive, so it is not a timing artefact: one session's samples reach the router in order.
"""

from __future__ import annotations

import json
import re
import shutil
import subprocess
import urllib.request
from pathlib import Path
from types import SimpleNamespace

import pytest
import yaml
import zenoh
from procs import REPO, SCENARIOS, free_port, lunarsim, module, stop, wait_for, wait_for_output

from bus.zenoh_config import build_config
from deploy.children import wait_for_port
from deploy.security import acl, configs
from schemas import codec
from schemas import keyspace as ks
from schemas import messages as m
from world_service.sim import World

KEYS = ks.Keyspace("secure")
CERT_SCRIPT = REPO / "deploy" / "security" / "make-dev-certs.sh"
needs_openssl = pytest.mark.skipif(shutil.which("openssl") is None,
                                   reason="openssl is not installed: make-dev-certs.sh cannot make certificates")


# ---- the generated rules, checked without a router ----

def allowed(control: dict, role: str, message: str, flow: str, key: str) -> bool:
    """Whether ``role`` may send (ingress) or receive (egress) ``message`` on ``key`` under deny-by-default."""
    policy = next(p for p in control["policies"] if role in p["subjects"])
    rules = [r for r in control["rules"] if r["id"] in policy["rules"]]
    return any(message in r["messages"] and flow in r["flows"] and r["permission"] == "allow"
               and any(zenoh.KeyExpr(k).includes(zenoh.KeyExpr(key)) for k in r["key_exprs"]) for r in rules)


@pytest.fixture(scope="module")
def control() -> dict:
    return acl.access_control(acl.roles(KEYS, [1, 2, 3]), KEYS)


ROLES = ["world", "lander", "ground", "recorder", "view", "rover-1", "rover-2", "rover-3"]


def may_publish(control: dict, key: str) -> set[str]:
    return {r for r in ROLES if allowed(control, r, "put", "ingress", key)}


def may_subscribe(control: dict, key: str) -> set[str]:
    return {r for r in ROLES if allowed(control, r, "declare_subscriber", "ingress", key)
            and allowed(control, r, "put", "egress", key)}


def test_each_rover_publishes_only_its_own_world_inputs(control):
    for topic in (*World.INPUT_TOPICS, ks.ACK):
        for rid in (1, 2, 3):
            assert may_publish(control, KEYS.rover(rid, topic)) == {f"rover-{rid}"}, topic
            assert "world" in may_subscribe(control, KEYS.rover(rid, topic))


def test_only_the_world_publishes_sensors_and_each_rover_reads_only_its_own(control):
    for topic in ks.ROVER_INPUTS:
        for rid in (1, 2, 3):
            assert may_publish(control, KEYS.rover(rid, topic)) == {"world"}, topic
            assert may_subscribe(control, KEYS.rover(rid, topic)) == {f"rover-{rid}", "recorder", "view"}, topic
    for key in (KEYS.clock, KEYS.state, KEYS.stats):
        assert may_publish(control, key) == {"world"}


def test_only_ground_commands_and_rovers_cannot_watch_the_ground_truth(control):
    assert may_publish(control, KEYS.ground_command) == {"ground", "view"}
    assert may_subscribe(control, KEYS.ground_command) == {"world", "lander", "recorder", "view"}
    assert may_subscribe(control, KEYS.state) == {"recorder", "view"}
    assert may_subscribe(control, KEYS.clock) == {"lander", "recorder", "view", "rover-1", "rover-2", "rover-3"}
    for rover in ("rover-1", "rover-2"):
        for key in (KEYS.all, KEYS.rovers(ks.PERCEPTION), f"{KEYS.prefix}/world/*"):
            assert not allowed(control, rover, "declare_subscriber", "ingress", key), key


def test_the_view_reads_what_the_recorder_reads_and_sends_nothing_but_ground_commands(control):
    for key in (KEYS.all, KEYS.state, KEYS.rover(2, ks.PHOTO), KEYS.ground_command_result):
        assert allowed(control, "view", "declare_subscriber", "ingress", key), key
    assert allowed(control, "view", "declare_liveliness_subscriber", "ingress", KEYS.alive_replays)
    published = {k for r in control["rules"] if r["id"] == "view publish" for k in r["key_exprs"]}
    assert published == {KEYS.ground_command}
    for key in (KEYS.rover(1, ks.MOVE_ACTION), KEYS.clock, KEYS.state):
        assert not allowed(control, "view", "put", "ingress", key), key


def test_liveliness_and_the_id_desk_work_for_their_roles_only(control):
    assert allowed(control, "rover-2", "liveliness_token", "ingress", KEYS.alive_rover(2))
    assert not allowed(control, "rover-2", "liveliness_token", "ingress", KEYS.alive_rover(1))
    assert allowed(control, "lander", "liveliness_token", "ingress", KEYS.alive_lander)
    for key in (KEYS.alive_rovers, KEYS.alive_lander):
        assert allowed(control, "world", "declare_liveliness_subscriber", "ingress", key)
    assert allowed(control, "world", "liveliness_token", "egress", KEYS.alive_rover(3))
    assert allowed(control, "world", "declare_queryable", "ingress", KEYS.rover_ids)
    assert allowed(control, "rover-3", "query", "ingress", KEYS.rover_ids)
    assert allowed(control, "rover-3", "reply", "egress", KEYS.rover_ids)
    assert not allowed(control, "ground", "query", "ingress", KEYS.rover_ids)


def test_policies_name_existing_rules_and_subjects_match_certificate_and_user(control):
    rule_ids = [r["id"] for r in control["rules"]]
    assert len(rule_ids) == len(set(rule_ids)) and control["default_permission"] == "deny"
    for policy in control["policies"]:
        assert set(policy["rules"]) <= set(rule_ids) and policy["rules"]
    assert {"id": "rover-2", "cert_common_names": ["rover-2"], "usernames": ["rover-2"]} in control["subjects"]


def test_bad_role_sets_are_refused():
    with pytest.raises(ValueError, match="rover ids must be 1 or more"):
        acl.roles(KEYS, [0, 1])
    with pytest.raises(ValueError, match="unique"):
        acl.access_control([acl.ground_role(KEYS), acl.ground_role(KEYS)], KEYS)


def test_rendered_configs_keep_the_templates_settings_and_load_in_zenoh(tmp_path):
    router = configs.router_config(tmp_path, tmp_path / "c.txt", ["tls/0.0.0.0:1"], acl.access_control(
        acl.roles(KEYS, [1]), KEYS))
    client = configs.client_config("rover-1", "pw", tmp_path, ["tls/localhost:1"])
    for conf in (router, client):
        assert conf["transport"]["link"]["protocols"] == ["tls"]
        assert conf["transport"]["link"]["tls"]["enable_mtls"] is True
        assert conf["transport"]["link"]["tls"]["root_ca_certificate"] == str(tmp_path.resolve() / "ca.pem")
        assert conf["transport"]["shared_memory"] == {"enabled": False}
        zenoh.Config.from_json5(json.dumps(conf))
    assert client["transport"]["link"]["tls"]["verify_name_on_connect"] is True
    assert client["transport"]["auth"]["usrpwd"] == {"user": "rover-1", "password": "pw"}
    assert router["access_control"]["enabled"] is True and router["mode"] == "router"


def test_credentials_keep_existing_passwords_and_reject_broken_lines():
    existing = configs.parse_credentials("world:abc\n\nrover-1:x:y\n")
    assert existing == {"world": "abc", "rover-1": "x:y"}
    passwords = configs.passwords_for(["world", "rover-2"], existing)
    assert passwords["world"] == "abc" and len(passwords["rover-2"]) >= 20
    assert configs.parse_credentials(configs.credentials_text(passwords)) == passwords
    with pytest.raises(ValueError, match="line 2"):
        configs.parse_credentials("a:b\nno-colon\n")


# ---- certificates and the command line ----

def make_certs(folder: Path, rovers: int, *hosts: str, bridges: str | None = None) -> str:
    options = ["--bridges", bridges] if bridges is not None else []
    done = subprocess.run([str(CERT_SCRIPT), *options, str(folder), str(rovers), *hosts], capture_output=True,
                          text=True, timeout=60)
    assert done.returncode == 0, done.stderr
    return done.stdout


@needs_openssl
def test_make_dev_certs_is_idempotent_and_remakes_the_router_for_new_hosts(tmp_path):
    first = make_certs(tmp_path, 1)
    assert first.count("made ") == 8  # ca, router, world, lander, ground, recorder, view, rover-1
    again = make_certs(tmp_path, 2)
    assert again.count("kept ") == 8 and "made  " + str(tmp_path / "rover-2.pem") in again
    new_host = make_certs(tmp_path, 2, "rover-base.local", "10.1.2.3")
    assert "made  " + str(tmp_path / "router.pem") in new_host and new_host.count("made ") == 1
    names = subprocess.run(["openssl", "x509", "-in", str(tmp_path / "router.pem"), "-noout", "-ext",
                            "subjectAltName"], capture_output=True, text=True).stdout
    assert "DNS:rover-base.local" in names and "IP Address:10.1.2.3" in names and "DNS:localhost" in names
    bad = subprocess.run([str(CERT_SCRIPT), str(tmp_path), "zero"], capture_output=True, text=True)
    assert bad.returncode == 2 and "ROVERS must be a whole number" in bad.stderr


def test_acl_command_names_missing_certificates_and_non_tls_endpoints(tmp_path, capsys):
    from deploy.cli import main

    scenario = str(SCENARIOS / "crater_observation.yaml")
    assert main(["acl", scenario, "-o", str(tmp_path / "router.json5")]) == 2
    assert "missing in" in capsys.readouterr().err
    assert main(["acl", scenario, "-o", str(tmp_path / "r.json5"), "--listen", "tcp/0.0.0.0:7447"]) == 2
    assert "speaks only TLS" in capsys.readouterr().err


# ---- a real secured router ----

def secured_router(tmp_path_factory, name: str, *acl_args: str, bridges: str | None = None):
    """A router from ``lunarsim acl`` (2 rovers, world 'secure') with certificates from make-dev-certs.sh;
    yields where it is, and stops it."""
    if shutil.which("openssl") is None:
        pytest.skip("openssl is not installed: make-dev-certs.sh cannot make certificates")
    folder = tmp_path_factory.mktemp(name)
    make_certs(folder / "certs", 2, bridges=bridges)
    made = lunarsim("acl", str(SCENARIOS / "crater_observation.yaml"), "--rovers", "2", *acl_args,
                    "--world", KEYS.world, "-o", str(folder / "router.json5"))
    out, err = made.communicate(timeout=60)
    assert made.returncode == 0, out + err
    port = free_port()
    router = lunarsim("router", "--config", str(folder / "router.json5"), "--listen", f"tls/127.0.0.1:{port}")
    assert wait_for_port("127.0.0.1", port, 15, router), router.communicate(timeout=5) if router.poll() else "timeout"
    yield SimpleNamespace(folder=folder, endpoint=f"tls/localhost:{port}", port=port)
    stop(router)


@pytest.fixture(scope="module")
def secure(tmp_path_factory):
    yield from secured_router(tmp_path_factory, "secure")


def client_conf(secure, role: str, **changes: str) -> zenoh.Config:
    """The role's generated client config pointed at the test router, with json5 ``changes`` applied."""
    conf = build_config(config_file=str(secure.folder / "clients" / f"{role}.json5"), connect=[secure.endpoint])
    for key, value in changes.items():
        conf.insert_json5(key.replace(".", "/"), value)
    return conf


def session(secure, role: str, **changes: str) -> zenoh.Session:
    return zenoh.open(client_conf(secure, role, **changes))


class Inbox:
    """Keys (and payloads) a subscriber received, in order."""

    def __init__(self, zsession: zenoh.Session, key_expr: str) -> None:
        self.items: list[tuple[str, bytes]] = []
        self.sub = zsession.declare_subscriber(key_expr, lambda s: self.items.append(
            (str(s.key_expr), s.payload.to_bytes())))

    def has(self, key: str, payload: bytes | None = None) -> bool:
        return any(k == key and (payload is None or p == payload) for k, p in self.items)

    def keys(self) -> set[str]:
        return {k for k, _ in self.items}


def put_until(zsession: zenoh.Session, key: str, payload: bytes, arrived, what: str) -> None:
    """Put again until ``arrived()``: the first puts may precede the router's knowledge of the subscriber."""
    wait_for(lambda: zsession.put(key, payload) or arrived(), 10, what, interval=0.1)


@pytest.mark.e2e
def test_rover_2_cannot_command_rover_1(secure):
    with session(secure, "world") as world, session(secure, "rover-2") as rover2:
        inbox = Inbox(world, KEYS.rovers(ks.MOVE_ACTION))
        own, other = KEYS.rover(2, ks.MOVE_ACTION), KEYS.rover(1, ks.MOVE_ACTION)
        put_until(rover2, own, b"first", lambda: inbox.has(own), "rover 2's own move_action at the world")
        for _ in range(5):
            rover2.put(other, b"forged")
        rover2.put(own, b"marker")  # after the forged ones, on the same session
        wait_for(lambda: inbox.has(own, b"marker"), 10, "rover 2's marker at the world")
        assert inbox.keys() == {own}


@pytest.mark.e2e
@pytest.mark.parametrize("variant, changes", [
    ("plain tcp, no TLS", None),
    ("TLS without a client certificate", {"transport.link.tls.connect_certificate": "null",
                                          "transport.link.tls.connect_private_key": "null",
                                          "transport.link.tls.enable_mtls": "null"}),
    ("certificate without user and password", {"transport.auth.usrpwd.user": "null",
                                               "transport.auth.usrpwd.password": "null"}),
    ("certificate with a wrong password", {"transport.auth.usrpwd.password": '"guess"'}),
])
def test_a_client_without_certificate_or_credentials_cannot_open_a_session(secure, variant, changes):
    with session(secure, "rover-1"):
        pass  # the same role's full config opens: what fails below is the missing piece
    conf = build_config(connect=[f"tcp/127.0.0.1:{secure.port}"]) if changes is None else client_conf(
        secure, "rover-1", **changes)
    with pytest.raises(zenoh.ZError, match="Unable to connect"):
        zenoh.open(conf)


@pytest.mark.e2e
def test_a_certificate_with_another_roles_password_matches_no_role(secure):
    """Opens (certificate and password are each valid) but is neither rover: it can send and receive nothing."""
    credentials = configs.parse_credentials((secure.folder / "credentials.txt").read_text())
    mixed = {"transport.auth.usrpwd.user": '"rover-1"',
             "transport.auth.usrpwd.password": json.dumps(credentials["rover-1"])}
    with session(secure, "recorder") as recorder, session(secure, "rover-2", **mixed) as impostor, \
            session(secure, "world") as world:
        everything = Inbox(recorder, KEYS.all)
        stolen = Inbox(impostor, KEYS.rover(1, ks.PERCEPTION))
        perception = KEYS.rover(1, ks.PERCEPTION)
        put_until(world, perception, b"seen", lambda: everything.has(perception), "perception at the recorder")
        for topic in (ks.MOVE_ACTION, ks.STATUS):
            impostor.put(KEYS.rover(1, topic), b"forged")
            impostor.put(KEYS.rover(2, topic), b"forged")
        world.put(perception, b"marker")
        wait_for(lambda: everything.has(perception, b"marker"), 10, "the world's marker at the recorder")
        assert everything.keys() == {perception} and stolen.items == []


@pytest.mark.e2e
def test_a_rover_cannot_subscribe_to_the_ground_truth(secure):
    with session(secure, "world") as world, session(secure, "rover-1") as rover1, \
            session(secure, "recorder") as recorder:
        watched = Inbox(recorder, KEYS.state)
        state, everything = Inbox(rover1, KEYS.state), Inbox(rover1, KEYS.all)
        own = Inbox(rover1, KEYS.rover(1, ks.PERCEPTION))
        put_until(world, KEYS.state, b"truth", lambda: watched.has(KEYS.state), "world/state at the recorder")
        for _ in range(5):
            world.put(KEYS.state, b"truth")
        marker = KEYS.rover(1, ks.PERCEPTION)
        put_until(world, marker, b"marker", lambda: own.has(marker), "rover 1's own perception")
        assert state.items == []
        # The router refused the wildcard subscription; the session still hands its wildcard subscriber what
        # the router sends it for the subscriptions it may hold, and nothing else.
        assert everything.keys() == {marker}


@pytest.mark.e2e
def test_only_ground_may_publish_ground_commands(secure):
    with session(secure, "recorder") as recorder, session(secure, "ground") as ground, \
            session(secure, "rover-2") as rover2:
        inbox = Inbox(recorder, KEYS.all)
        command = KEYS.ground_command
        put_until(ground, command, b"ground", lambda: inbox.has(command, b"ground"), "the ground's command")
        for _ in range(5):
            rover2.put(command, b"rover")
        status = KEYS.rover(2, ks.STATUS)
        put_until(rover2, status, b"marker", lambda: inbox.has(status, b"marker"), "rover 2's status marker")
        assert not inbox.has(command, b"rover")


def command_as(secure, role: str, timeout: str) -> tuple[int, str, str]:
    """``lunarsim command stop --rover 1`` with the role's client config: (exit code, stdout, stderr)."""
    config = str(secure.folder / "clients" / f"{role}.json5")
    proc = lunarsim("command", "stop", "--rover", "1", "--world", KEYS.world, "--config", config, "--connect",
                    secure.endpoint, "--timeout", timeout)
    out, err = proc.communicate(timeout=60)
    return proc.returncode, out, err


@pytest.mark.e2e
def test_lunarsim_command_reaches_the_lander_as_ground_and_not_as_a_rover(secure):
    common = ["--world", KEYS.world, "--config", str(secure.folder / "clients" / "lander.json5"), "--connect",
              secure.endpoint]
    lander = module("lander_agent", str(SCENARIOS / "crater_observation.yaml"), *common)
    try:
        code, out, err = command_as(secure, "ground", "20")
        assert code == 0 and "accepted" in out, out + err
        code, out, err = command_as(secure, "rover-2", "3")
        assert code == 4 and "no lander answered" in err, out + err
    finally:
        stop(lander)


@pytest.mark.e2e
def test_lunarsim_view_with_its_own_config_sends_a_command_the_lander_answers(secure):
    clients = secure.folder / "clients"
    common = ["--world", KEYS.world, "--connect", secure.endpoint]
    lander = module("lander_agent", str(SCENARIOS / "crater_observation.yaml"), *common,
                    "--config", str(clients / "lander.json5"))
    port = free_port()
    view = lunarsim("view", "--port", str(port), *common, "--config", str(clients / "view.json5"))
    try:
        assert wait_for_port("127.0.0.1", port, 30, view), view.communicate(timeout=5) if view.poll() else "timeout"
        wait_for(lambda: _get_json(f"http://127.0.0.1:{port}/api/info")["connected"], 30, "the view on the router")
        answer = _post_json(f"http://127.0.0.1:{port}/api/command", {"command": "stop", "rover_id": 1})
        assert answer["ok"] and answer["accepted"], answer
    finally:
        stop(view)
        stop(lander)


def _get_json(url: str) -> dict:
    with urllib.request.urlopen(url, timeout=10) as response:
        return json.loads(response.read())


def _post_json(url: str, body: dict) -> dict:
    request = urllib.request.Request(url, json.dumps(body).encode(), {"Content-Type": "application/json"})
    with urllib.request.urlopen(request, timeout=60) as response:
        return json.loads(response.read())


def run_mission(folder: Path, scenario: Path, connect: str, configs_dir: Path | None) -> tuple[dict, str]:
    """A lockstep mission of world, lander and two rover agents; each gets its role's config if given."""
    def args(role: str) -> list[str]:
        own = ["--config", str(configs_dir / f"{role}.json5")] if configs_dir else []
        return ["--world", KEYS.world, *own, "--connect", connect]

    report = folder / "report.json"
    world = module("world_service", str(scenario), *args("world"), "--lockstep", "--max-sim-time", "20",
                   "--exit-when-done", "--report", str(report), "--start-timeout", "20")
    others = [module("lander_agent", str(scenario), *args("lander"))]
    others += [module("rover_agent", "--id", str(i), "--params", str(scenario), *args(f"rover-{i}")) for i in (1, 2)]
    try:
        world.wait(timeout=120)
        log = world.stdout.read()
        assert world.returncode == 0, log
        return json.loads(report.read_text()), log
    finally:
        stop(world, *others)


@pytest.mark.e2e
def test_a_secured_lockstep_mission_runs_as_on_an_open_router(secure, router, tmp_path):
    """Tokens, clock, acks, actions, sensors and radio all pass the access control: the report is the same."""
    data = yaml.safe_load((SCENARIOS / "crater_observation.yaml").read_text())
    data["rovers"] = data["rovers"][:2]
    scenario = tmp_path / "two.yaml"
    scenario.write_text(yaml.safe_dump(data))
    (tmp_path / "secure").mkdir()
    (tmp_path / "open").mkdir()
    secured, log = run_mission(tmp_path / "secure", scenario, secure.endpoint, secure.folder / "clients")
    assert "starting without" not in log  # every agent's liveliness token reached the world
    assert secured["rejected_messages"] == 0 and secured["total_distance_covered_m"] > 20
    plain, _ = run_mission(tmp_path / "open", scenario, router, None)
    assert secured == plain


# ---- real rovers: driver bridges (lunarsim acl --bridges) and the twin world ----

@pytest.fixture(scope="module")
def bridged() -> dict:
    """Rovers 1 and 2 real, each behind its driver bridge; rover 3 simulated by the world."""
    return acl.access_control(acl.roles(KEYS, [1, 2, 3], bridged=[1, 2]), KEYS)


def publishers(control: dict, key: str) -> set[str]:
    """Every role of ``control`` that may publish on ``key``."""
    return {s["id"] for s in control["subjects"] if allowed(control, s["id"], "put", "ingress", key)}


def subscribers(control: dict, key: str) -> set[str]:
    return {s["id"] for s in control["subjects"] if allowed(control, s["id"], "declare_subscriber", "ingress", key)
            and allowed(control, s["id"], "put", "egress", key)}


def test_a_bridge_alone_publishes_its_own_rovers_sensors_and_telemetry(bridged):
    from world_service.twin.world import TwinWorld

    for topic in (*ks.ROVER_INPUTS, ks.TELEMETRY):
        assert publishers(bridged, KEYS.rover(1, topic)) == {"bridge-1"}, topic
        assert publishers(bridged, KEYS.rover(2, topic)) == {"bridge-2"}, topic
        assert subscribers(bridged, KEYS.rover(1, topic)) >= {"recorder"}
    for topic in ks.ROVER_INPUTS:
        assert publishers(bridged, KEYS.rover(3, topic)) == {"world"}, topic  # rover 3 is still simulated
        assert subscribers(bridged, KEYS.rover(1, topic)) - {"world"} == {"rover-1", "recorder", "view"}, topic
        assert ("world" in subscribers(bridged, KEYS.rover(1, topic))) == (topic in TwinWorld.INPUT_TOPICS), topic
    assert publishers(bridged, KEYS.rover(3, ks.TELEMETRY)) == set()  # no agent forges a driver's pose
    for key in (KEYS.ground_command, KEYS.state, KEYS.stats, KEYS.clock, KEYS.lander(ks.COMM_IN),
                KEYS.rover(1, ks.MOVE_ACTION), KEYS.rover(1, ks.STATUS), KEYS.rover(1, ks.ACK)):
        assert not allowed(bridged, "bridge-1", "put", "ingress", key), key


def test_a_bridge_reads_only_its_own_agents_commands_the_clock_and_its_agents_token(bridged):
    from hardware.bridge import AGENT_TOPICS

    for topic in (*AGENT_TOPICS, ks.COMM_OUT):
        assert "bridge-1" in subscribers(bridged, KEYS.rover(1, topic)), topic
        assert "bridge-1" not in subscribers(bridged, KEYS.rover(2, topic)), topic
        assert publishers(bridged, KEYS.rover(1, topic)) == {"rover-1"}, topic
    assert "bridge-1" in subscribers(bridged, KEYS.clock)
    for key in (KEYS.state, KEYS.stats, KEYS.all, KEYS.rovers(ks.MOVE_ACTION), KEYS.ground_command,
                KEYS.rover(2, ks.PERCEPTION)):
        assert not allowed(bridged, "bridge-1", "declare_subscriber", "ingress", key), key
    assert allowed(bridged, "bridge-1", "declare_liveliness_subscriber", "ingress", KEYS.alive_rover(1))
    assert allowed(bridged, "bridge-1", "liveliness_token", "egress", KEYS.alive_rover(1))
    assert not allowed(bridged, "bridge-1", "declare_liveliness_subscriber", "ingress", KEYS.alive_rover(2))
    assert not allowed(bridged, "bridge-1", "liveliness_token", "ingress", KEYS.alive_rover(1))  # the agent's


class Declared:
    """The keys ``service.declare_io(bus, keys, world)`` declares on its bus, to check them against the rules."""

    def __init__(self) -> None:
        self.subscribed: list[str] = []
        self.watched: list[str] = []

    def subscribe(self, key_expr: str) -> None:
        self.subscribed.append(key_expr)

    def watch_liveliness(self, key_expr: str) -> None:
        self.watched.append(key_expr)


def test_the_world_follows_real_rovers_as_a_twin_and_cannot_speak_for_them(bridged, control):
    from world_service import service
    from world_service.twin.world import TwinWorld

    all_real = acl.access_control(acl.roles(KEYS, [1, 2], bridged=[1, 2]), KEYS)
    twin, simulated = Declared(), Declared()
    service.declare_io(twin, KEYS, TwinWorld)
    service.declare_io(simulated, KEYS, World)
    for rules, declared in ((bridged, twin), (all_real, twin), (bridged, simulated), (control, simulated)):
        for key in declared.subscribed:  # as declared: wildcards over every rover
            assert allowed(rules, "world", "declare_subscriber", "ingress", key), key
        for key in declared.watched:
            assert allowed(rules, "world", "declare_liveliness_subscriber", "ingress", key), key
    for key in (KEYS.clock, KEYS.state, KEYS.stats):
        assert publishers(all_real, key) == {"world"}, key
    for topic in ks.ROVER_INPUTS:
        assert publishers(all_real, KEYS.rover(1, topic)) == {"bridge-1"}, topic
    assert publishers(all_real, KEYS.lander(ks.COMM_IN)) == set()  # no simulated radio left to deliver it
    assert not allowed(all_real, "world", "declare_subscriber", "ingress", KEYS.rovers(ks.MOVE_ACTION))
    assert not allowed(control, "rover-1", "put", "ingress", KEYS.rover(1, ks.TELEMETRY))


def test_on_a_bench_the_one_bridge_is_the_clock_and_bad_bridge_sets_are_refused():
    bench = acl.access_control(acl.roles(KEYS, [1], bridged=[1], bridge_clock=True), KEYS)
    assert allowed(bench, "bridge-1", "put", "ingress", KEYS.clock)
    assert not allowed(bench, "world", "put", "ingress", KEYS.clock)
    assert allowed(bench, "rover-1", "put", "egress", KEYS.clock)
    with pytest.raises(ValueError, match=r"bridged rovers \[3\] are not rovers of this world"):
        acl.roles(KEYS, [1, 2], bridged=[1, 3])
    with pytest.raises(ValueError, match="one bridge"):
        acl.roles(KEYS, [1, 2], bridged=[1, 2], bridge_clock=True)


@needs_openssl
def test_make_dev_certs_makes_bridge_certificates_when_asked(tmp_path):
    made = make_certs(tmp_path, 3, bridges="1,3")
    assert "made  " + str(tmp_path / "bridge-1.pem") in made and "made  " + str(tmp_path / "bridge-3.pem") in made
    assert not (tmp_path / "bridge-2.pem").exists()
    subject = subprocess.run(["openssl", "x509", "-in", str(tmp_path / "bridge-3.pem"), "-noout", "-subject"],
                             capture_output=True, text=True).stdout
    assert "CN = bridge-3" in subject or "CN=bridge-3" in subject
    again = make_certs(tmp_path, 3, bridges="all")
    assert again.count("made ") == 1 and "made  " + str(tmp_path / "bridge-2.pem") in again
    assert make_certs(tmp_path, 3).count("made ") == 0  # without --bridges, as before
    bad = subprocess.run([str(CERT_SCRIPT), "--bridges", "4", str(tmp_path), "3"], capture_output=True, text=True)
    assert bad.returncode == 2 and "rover ids 1..3" in bad.stderr


def test_acl_command_refuses_bridges_that_are_not_rovers(tmp_path, capsys):
    from deploy.cli import main

    scenario = str(SCENARIOS / "crater_observation.yaml")
    out = str(tmp_path / "router.json5")
    assert main(["acl", scenario, "--rovers", "2", "--bridges", "1,3", "-o", out]) == 2
    assert "bridged rovers [3] are not rovers of this world" in capsys.readouterr().err
    assert main(["acl", scenario, "--rovers", "2", "--bridges", "one", "-o", out]) == 2
    assert "expected 'all' or rover ids" in capsys.readouterr().err
    assert main(["acl", scenario, "--rovers", "2", "--bridges", "all", "--bridge-clock", "-o", out]) == 2
    assert "--bridge-clock needs exactly one bridge" in capsys.readouterr().err
    assert main(["acl", scenario, "--rovers", "2", "--bridges", "all", "-o", out]) == 2
    assert "make-dev-certs.sh --bridges all" in capsys.readouterr().err


@pytest.fixture(scope="module")
def real(tmp_path_factory):
    """A router from ``lunarsim acl --bridges all`` (2 real rovers), bridge certificates included."""
    for router in secured_router(tmp_path_factory, "real", "--bridges", "all", bridges="all"):
        assert (router.folder / "clients" / "bridge-2.json5").is_file()
        yield router


@pytest.mark.e2e
def test_bridge_1_feeds_rover_1_and_cannot_forge_rover_2s_sensors(real):
    with session(real, "recorder") as recorder, session(real, "rover-1") as rover1, \
            session(real, "rover-2") as rover2, session(real, "bridge-1") as bridge1:
        everything, own = Inbox(recorder, KEYS.all), Inbox(rover1, KEYS.rover(1, ks.PERCEPTION))
        others = Inbox(rover2, KEYS.rover(2, ks.PERCEPTION))
        perception = KEYS.rover(1, ks.PERCEPTION)
        put_until(bridge1, perception, b"real", lambda: own.has(perception, b"real"), "bridge 1 perception at rover 1")
        forged = [KEYS.rover(2, ks.PERCEPTION), KEYS.rover(2, ks.TELEMETRY), KEYS.state, KEYS.ground_command]
        for _ in range(5):
            for key in forged:
                bridge1.put(key, b"forged")
        bridge1.put(perception, b"marker")  # after the forged ones, on the same session
        wait_for(lambda: everything.has(perception, b"marker"), 10, "bridge 1's marker at the recorder")
        assert everything.keys() == {perception} and others.items == []


@pytest.mark.e2e
def test_the_agent_drives_an_emulated_rover_through_its_bridge_and_the_twin_follows_over_the_secured_router(real):
    """emulate-device, bridge-1, rover-1 and the twin world each on its own role's config; the lander's radio
    (mission direction, calibration) comes in through bridge 1's role, as the bridge would deliver it."""
    clients = real.folder / "clients"

    def role(name: str) -> list[str]:
        return ["--world", KEYS.world, "--config", str(clients / f"{name}.json5"), "--connect", real.endpoint]

    device = lunarsim("emulate-device", "--rocks", "none")
    started = []
    try:
        port = wait_for_output(device, "emulated device on", 20).split()[-1]
        started.append(lunarsim("world", str(SCENARIOS / "crater_observation.yaml"), "--twin", "--rovers", "1",
                                "--no-lander", *role("world")))
        started.append(lunarsim("bridge", "--id", "1", "--driver", f"serial://{port}", *role("bridge-1")))
        agent = lunarsim("rover", "--id", "1", *role("rover-1"))
        started.append(agent)
        with session(real, "recorder") as recorder, session(real, "bridge-1") as radio:
            states: list[m.WorldState] = []
            seen = Inbox(recorder, KEYS.rover(1, ks.CANCEL_RESULT))
            recorder_sub = recorder.declare_subscriber(KEYS.state, lambda s: states.append(
                codec.decode(m.WorldState, s.payload.to_bytes())))
            direction = m.MissionDirection(goal_index=0, goals_total=1, kind="waypoint", bearing_deg=0.0,
                                           distance_m=50.0)  # far enough to be under way when the agent dies
            calibration = m.Calibration(x=0.0, z=0.0, heading_deg=0.0)

            def moved() -> bool:
                radio.put(KEYS.rover(1, ks.CALIBRATION), codec.encode(calibration))
                radio.put(KEYS.rover(1, ks.MISSION_DIRECTION), codec.encode(direction))
                return bool(states) and states[-1].rovers[0].distance_covered_m > 0.5

            wait_for(moved, 40, "the twin to see the agent drive the emulated rover", interval=0.5)
            wait_for(lambda: states[-1].rovers[0].goal_index == 0, 10, "the agent's status at the twin")
            wait_for(lambda: states[-1].comm_links == [(0, 1)], 10, "the twin to show the radio link of rover 1")
            assert states[-1].rovers[0].alive and states[-1].rovers[0].action == "move"
            agent.kill()  # its token goes: the bridge, watching it, stops the rover
            wait_for(lambda: seen.items, 15, "the bridge to stop the rover of a dead agent")
            wait_for(lambda: states[-1].rovers[0].action == "idle", 10, "the twin to see the rover stop")
            recorder_sub.undeclare()
    finally:
        stop(*started, device)
    final = re.search(r"final pose x=(\S+) z=(\S+) heading=(\S+)", device.stdout.read())
    assert final, "the emulated device did not say where it ended"
    z = float(final.group(2))
    assert 0.5 < z < 45.0  # it drove, and stopped well short of the 50 m waypoint
    assert states[-1].rovers[0].distance_covered_m == pytest.approx(z, abs=0.1)
