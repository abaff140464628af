"""The hardware swap: the unchanged rover agent drives an emulated serial rover base through the driver bridge.

Real parts throughout: the emulated device answers on a real pseudo-terminal, the serial driver opens it with
pyserial, the bridge and the rover agent are their own processes on a real Zenoh router. The driver checker
passes the reference driver and names the bugs of a faulty one; the line protocol survives noise and silence.
"""

from __future__ import annotations

import os
import re
import select
import signal
import threading
import time
from collections import defaultdict

import pytest
import serial
import zenoh
from procs import REPO, lunarsim, module, stop, wait_for, wait_for_output

from bus.zenoh_config import build_config
from hardware import protocol as p
from hardware.bridge import Bridge
from hardware.clock import MissionClock
from hardware.device_model import DeviceModel
from hardware.driver import ActionRefused, DriverTimeout
from hardware.drivers import UnknownDriver, load_driver
from hardware.emulator import DeviceServer, EmulatedRadio, Emulator
from hardware.serial_driver import LineClient, SerialDriver, expect_ok
from schemas import codec
from schemas import keyspace as ks
from schemas import messages as m
from schemas.keyspace import Keyspace


@pytest.fixture
def emulator():
    emu = Emulator(DeviceServer(DeviceModel(), EmulatedRadio([0]))).start()
    yield emu
    emu.close()


# ---- the unchanged rover agent on an emulated rover ----


class Listener:
    """Latest message per rover topic, and every navigation status, seen on the router."""

    def __init__(self, session: zenoh.Session, keys: Keyspace) -> None:
        self.all: dict[str, list[m.Message]] = defaultdict(list)
        self.sub = session.declare_subscriber(keys.rovers("**"), self._on)

    def _on(self, sample: zenoh.Sample) -> None:
        key = str(sample.key_expr)
        model = m.model_for_key(key)
        if model is not None:
            self.all[key.rsplit("/", 1)[1]].append(codec.decode(model, sample.payload.to_bytes()))

    def last(self, topic: str) -> m.Message | None:
        return self.all[topic][-1] if self.all[topic] else None


@pytest.mark.e2e
def test_the_rover_agent_drives_the_emulated_rover_to_its_waypoint(router, emulator):
    keys = Keyspace("bench")
    common = ["--world", "bench", "--connect", router]
    bridge = lunarsim("bridge", "--id", "1", "--driver", f"serial://{emulator.path}", "--clock", *common)
    agent = module("rover_agent", "--id", "1", *common)
    truth = emulator.server.model
    direction = m.MissionDirection(goal_index=0, goals_total=1, kind="waypoint", bearing_deg=0.0, distance_m=9.0)
    calibration = codec.encode(m.Calibration(x=0.0, z=0.0, heading_deg=0.0))
    try:
        with zenoh.open(build_config(connect=[router])) as session:
            seen = Listener(session, keys)
            wait_for(lambda: seen.last(ks.PERCEPTION) and seen.last(ks.GYROSCOPE), 30,
                     "the bridge to publish perception and pitch")
            last_sent = [0.0]

            def under_way() -> bool:
                """The lander's radio repeats itself: calibration over the emulated radio, the direction on its key."""
                if time.monotonic() - last_sent[0] > 0.5:
                    emulator.server.radio.inject(ks.LANDER_ID, "calibration", calibration)
                    session.put(keys.rover(1, ks.MISSION_DIRECTION), codec.encode(direction))
                    last_sent[0] = time.monotonic()
                return truth.z > 0.5

            wait_for(under_way, 30, "the agent to start walking the emulated rover")
            wait_for(lambda: getattr(seen.last(ks.STATUS), "state", "") == "done", 30,
                     "the agent to reach its waypoint")
            assert 4.0 <= truth.z <= 9.5 and abs(truth.x) < 2.0, (truth.x, truth.z)
            wait_for(lambda: abs(seen.last(ks.TELEMETRY).z - truth.z) < 0.05, 5, "telemetry of the rover's pose")
            statuses = seen.all[ks.NAVIGATION_STATUS]
            assert statuses[-1].remaining == 0 and statuses[-1].outcome == "completed"
            assert [s.stamp for s in statuses] == sorted(s.stamp for s in statuses)

            session.put(keys.rover(1, ks.COMM_OUT), codec.encode(m.OutboundComm(targets=[0], payload=b"ping")))
            # any echo: the agent's own radio traffic (its map reports) is echoed too, before or after ours
            wait_for(lambda: any(msg.payload == b"ping" for msg in seen.all[ks.COMM_IN]), 10,
                     "the emulated lander to echo a transmission back over the radio")

            session.put(keys.rover(1, ks.SPEED_ACTION), codec.encode(m.SpeedAction(level=1)))
            session.put(keys.rover(1, ks.MOVE_ACTION), codec.encode(m.MoveAction(x=0.0, z=8.0)))
            wait_for(lambda: truth.busy and truth.velocity > 0, 10, "a long move under way")
            cancels = len(seen.all[ks.CANCEL_RESULT])
            agent.send_signal(signal.SIGKILL)
            wait_for(lambda: len(seen.all[ks.CANCEL_RESULT]) > cancels, 10,
                     "the bridge to stop the rover of a dead agent")
            assert seen.last(ks.NAVIGATION_STATUS).outcome == "cancelled" and not truth.busy
            assert 0 < seen.last(ks.CANCEL_RESULT).z < 8.0
    finally:
        stop(agent, bridge)
    assert bridge.returncode == 0, bridge.stderr.read()


@pytest.mark.e2e
def test_without_its_own_clock_the_bridge_follows_the_world_clock(router, emulator):
    keys = Keyspace("twin")
    bridge = lunarsim("bridge", "--id", "2", "--driver", f"serial://{emulator.path}", "--world", "twin",
                      "--connect", router)
    try:
        with zenoh.open(build_config(connect=[router])) as session:
            seen = Listener(session, keys)
            wait_for(lambda: len(seen.all[ks.TELEMETRY]) >= 3, 30, "telemetry, which needs no clock")
            assert not seen.all[ks.PERCEPTION] and not seen.all[ks.GYROSCOPE]  # agents act on a running clock only
            tick = [0]

            def world_clock_running() -> bool:
                tick[0] += 1
                clock = m.Clock(tick=tick[0], sim_time=100.0 + tick[0] * 0.05, time_scale=1.0)
                session.put(keys.clock, codec.encode(clock))
                return len(seen.all[ks.PERCEPTION]) >= 2 and len(seen.all[ks.GYROSCOPE]) >= 2

            wait_for(world_clock_running, 20, "sensors once the world's clock runs", interval=0.05)
            assert all(s.stamp >= 100.0 for s in seen.all[ks.PERCEPTION] + seen.all[ks.GYROSCOPE])
            assert seen.all[ks.TELEMETRY][-1].stamp >= 100.0
    finally:
        stop(bridge)
    assert bridge.returncode == 0, bridge.stderr.read()


def test_the_mission_clock_follows_the_world_never_goes_back_and_notices_a_silent_world():
    now = [10.0]
    clock = MissionClock(own=False, monotonic=lambda: now[0])
    assert not clock.running() and clock.now() == 0.0
    clock.on_clock(m.Clock(tick=1, sim_time=50.0, time_scale=2.0))
    now[0] += 0.5
    assert clock.running() and clock.now() == pytest.approx(51.0)
    clock.on_clock(m.Clock(tick=2, sim_time=50.9, time_scale=2.0))  # a sample a little behind our estimate
    assert clock.now() == pytest.approx(51.0)
    now[0] += 3.0
    assert not clock.running()  # the world went quiet
    own = MissionClock(own=True, monotonic=lambda: now[0])
    now[0] += 1.5
    assert own.running() and own.next_tick() == m.Clock(tick=1, sim_time=1.5, time_scale=1.0)


# ---- the driver checker ----


def test_check_driver_passes_the_reference_driver_on_the_emulated_device():
    device = lunarsim("emulate-device", "--garble-every", "7")
    try:
        path = wait_for_output(device, "emulated device on", 20).split()[-1]
        check = lunarsim("check-driver", f"serial://{path}?timeout=0.5", "--radio-echo", "0")
        out, err = check.communicate(timeout=60)
        assert check.returncode == 0, out + err
        assert "driver contract: ok" in out and "violation" not in out
        assert "garbled line" in err  # the noise was there, and survived
    finally:
        stop(device)


def test_check_driver_names_the_bugs_of_a_faulty_driver(emulator):
    env = {**os.environ, "PYTHONPATH": str(REPO / "tests" / "support")}
    check = lunarsim("check-driver", f"hardware_faulty:OldFirmwareDriver?port={emulator.path}", env=env)
    out, err = check.communicate(timeout=60)
    assert check.returncode == 1, out + err
    violations = [line for line in out.splitlines() if line.startswith("violation:")]
    assert any("speed level 0 is refused" in v and "accepted" in v for v in violations), out
    assert any("speed level 4 is refused" in v for v in violations), out
    assert any("ends cancelled: saw completed" in v for v in violations), out
    assert any("a cancel with nothing running is refused" in v for v in violations), out
    assert "driver contract: " in out and "violation(s)" in out
    assert not any("move 1.5 m ahead" in v for v in violations), out  # what works is not blamed


def test_a_driver_url_that_names_nothing_is_a_usage_error():
    with pytest.raises(UnknownDriver, match=r"package\.module:Class"):
        load_driver("nonsense")
    with pytest.raises(UnknownDriver, match="not a subclass"):
        load_driver("schemas.messages:Clock")
    check = lunarsim("check-driver", "serial://")
    _, err = check.communicate(timeout=30)
    assert check.returncode == 2 and "names no serial port" in err


# ---- the bridge's semantics, without a router ----


def test_the_bridge_keeps_the_worlds_action_rules(emulator):
    driver = load_driver(f"serial://{emulator.path}")
    try:
        bridge = Bridge(driver, Keyspace("unit"), 1, MissionClock(own=True))
        cancel = bridge.handle(ks.CANCEL_ACTION, codec.encode(m.CancelAction()))
        assert [msg.reason for _, msg in cancel] == ["no_action"]
        started = bridge.handle(ks.MOVE_ACTION, codec.encode(m.MoveAction(x=0.0, z=1.0)))
        assert started[0][1] == m.NavigationStatus(stamp=started[0][1].stamp, action="move", remaining=1.0)
        again = bridge.handle(ks.ROTATE_ACTION, codec.encode(m.RotateAction(degrees=10)))
        assert [msg.reason for _, msg in again] == ["action_in_progress"]
        out: list[m.Message] = []

        def ended() -> bool:
            out.extend(msg for _, msg in bridge.poll())
            return bridge.flight is None

        wait_for(ended, 10, "the move to end")
        statuses = [msg for msg in out if isinstance(msg, m.NavigationStatus)]
        assert statuses[-1].remaining == 0 and statuses[-1].outcome == "completed"
        assert all(s.outcome == "running" and 0 < s.remaining < 1.0 for s in statuses[:-1])
        assert any(isinstance(msg, m.Gyroscope) for msg in out) and any(isinstance(msg, m.Perception) for msg in out)
        refused = bridge.handle(ks.MOVE_ACTION, codec.encode(m.MoveAction(x=0.0, z=-3.0)))
        assert [msg.reason for _, msg in refused] == ["out_of_view"]
        assert bridge.handle(ks.COMM_OUT, codec.encode(m.OutboundComm(targets=[2], payload=b"x",
                                                                      channel="mission_direction"))) == []
        assert bridge.rejected.by_topic[ks.COMM_OUT] == 1
        assert bridge.handle(ks.MOVE_ACTION, b"\x93garbage") == [] and bridge.rejected.by_topic[ks.MOVE_ACTION] == 1
        assert not any(isinstance(msg, m.CancelResult) for msg in out)  # a completed move has no CancelResult
    finally:
        driver.close()


def test_the_bridge_counts_readings_the_interface_does_not_allow_as_driver_failures(emulator):
    """The bridge builds its messages from the driver's values (a Struct checks nothing when built), so it checks
    each: a nan pitch or an unknown kind of hit is the driver's failure, counted, never a sample sent."""
    driver = load_driver(f"hardware_faulty:GarbledSensorsDriver?port={emulator.path}")
    try:
        bridge = Bridge(driver, Keyspace("unit"), 1, MissionClock(own=True))
        out: list[m.Message] = []

        def both_failed() -> bool:
            out.extend(msg for _, msg in bridge.poll())
            return bridge.errors["gyroscope"] >= 1 and bridge.errors["perception"] >= 1

        wait_for(both_failed, 10, "the bridge to count the garbled gyroscope and perception")
        assert not any(isinstance(msg, m.Gyroscope | m.Perception) for msg in out)
        assert any(isinstance(msg, m.Telemetry) for msg in out)  # the rest of the driver still reaches the rover
    finally:
        driver.close()


# ---- the line protocol ----


def test_parse_reply_accepts_answers_and_names_what_is_wrong_with_garbage():
    assert p.parse_reply(b"12 OK 0.500 1.25\r\n") == p.Reply(12, True, ("0.500", "1.25"))
    err = p.parse_reply(b"3 ERR busy action 1 is still running\n")
    assert (err.ok, err.code, err.detail) == (False, "busy", "action 1 is still running")
    for line, why in ((b"OK 1\n", "no sequence number"), (b"5 MAYBE\n", "expected OK or ERR"),
                      (b"5 OK \xff\n", "not ASCII"), (b"5 OK \x1b[2J\n", "control characters"),
                      (b"5 ERR melted\n", "unknown error code"), (b"0 OK\n", "no sequence number"),
                      (b"5 OK " + b"x" * p.MAX_LINE + b"\n", "longer than")):
        with pytest.raises(p.GarbledLine, match=why):
            p.parse_reply(line)
    with pytest.raises(ValueError, match="spaces"):
        p.format_request(1, "TX", "comm in")


@pytest.fixture
def pty_pair():
    """A serial port (pyserial on a pty) whose device end the test writes by hand."""
    master, slave = os.openpty()
    port = serial.Serial(os.ttyname(slave), timeout=0.05)
    yield master, port
    port.close()
    os.close(master)
    os.close(slave)


def feed(master: int, data: bytes) -> threading.Thread:
    """Write device output from a thread: more than the pty holds blocks until the port reads it."""
    def write() -> None:
        view = memoryview(data)
        while view:
            view = view[os.write(master, view):]

    thread = threading.Thread(target=write, daemon=True)
    thread.start()
    return thread


def test_the_line_client_skips_garbled_lines_and_late_answers(pty_pair):
    master, port = pty_pair
    client = LineClient(port, 2.0, "test-port")
    feed(master, b"\x07\xff noise\n" + b"x" * (p.MAX_LINE + 10) + b" tail\n" + b"99 OK late\n" + b"1 OK 42\n")
    reply = client.request("IMU?")
    assert reply == p.Reply(1, True, ("42",))
    assert (client.garbled, client.stale) == (2, 1)
    assert select.select([master], [], [], 5.0)[0], "the request never reached the device end"
    assert os.read(master, 100) == b"1 IMU?\n"


def test_a_silent_device_times_out_with_a_clear_error(pty_pair):
    master, port = pty_pair
    client = LineClient(port, 0.3, "test-port")
    start = time.monotonic()
    with pytest.raises(DriverTimeout, match=r"no answer to SCAN\? within 0\.3 s"):
        client.request("SCAN?")
    assert 0.25 < time.monotonic() - start < 1.0
    os.write(master, b"1 OK 0.0\n2 ERR busy action 4 is running\n")
    with pytest.raises(ActionRefused) as refused:
        expect_ok(client.request("MOVE", "0", "1"), "MOVE")
    assert refused.value.reason == "action_in_progress" and client.stale == 1


def test_the_serial_driver_refuses_a_port_where_nothing_answers():
    master, slave = os.openpty()
    try:
        with pytest.raises(DriverTimeout, match=re.escape(f"{os.ttyname(slave)} does not answer HELLO?")):
            SerialDriver(os.ttyname(slave), timeout_s=0.3)
    finally:
        os.close(master)
        os.close(slave)
