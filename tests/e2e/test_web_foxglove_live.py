"""``lunarsim view --foxglove``'s live additions (``web.foxglove_extras``), through the real Foxglove SDK server and a
WebSocket client speaking the Foxglove protocol (``foxglove.sdk.v1``): the world's clock as the server's time, the
rovers' scan, IMU and battery in simulated time, ground commands a client publishes, playback controls as replay
commands, and what a client sends that is refused, counted."""

from __future__ import annotations

import asyncio
import base64
import json
import math
import struct

import aiohttp
import pytest
import zenoh
from procs import SCENARIOS, free_port, lunarsim, stop, wait_for, wait_for_output
from protobuf_schemas import message_class

from bus.zenoh_config import build_config
from schemas import codec
from schemas import messages as m
from schemas.keyspace import Keyspace
from schemas.scenario import load_scenario
from sessions.format import Sample
from web.foxglove_live import LiveScene

KEYS = Keyspace("fox")
SUBPROTOCOL = "foxglove.sdk.v1"
PLAYBACK_CONTROL, PLAYBACK_STATE, MESSAGE_DATA, TIME = 3, 5, 1, 2


def _sample(key: str, message: m.Message) -> Sample:
    return Sample(key, codec.encode(message), 0, 0)


def _scan() -> m.Perception:
    """Two hits on the stock 50-ray, 210-degree layout, on its end rays: a rover 105 deg to the right, the lander
    105 deg to the left."""
    return m.Perception(stamp=7.25, angles_deg=[105.0, -105.0], distances_m=[3.0, 4.5], kinds=["rover", "lander"])


class Client:
    """A Foxglove protocol client over aiohttp: JSON ops and binary opcodes, as the app sends and reads them."""

    def __init__(self, ws: aiohttp.ClientWebSocketResponse) -> None:
        self.ws = ws
        self.channels: dict[str, dict] = {}
        self.binary: list[bytes] = []
        self.statuses: list[dict] = []

    async def pump(self, until, timeout: float = 10.0, meanwhile=None) -> None:
        """Read until ``until()`` holds, calling ``meanwhile()`` each time nothing came for a while."""
        deadline = asyncio.get_running_loop().time() + timeout
        while not until():
            left = deadline - asyncio.get_running_loop().time()
            assert left > 0, "the server did not send what was waited for"
            try:
                msg = await self.ws.receive(timeout=min(left, 0.2) if meanwhile else left)
            except TimeoutError:
                assert meanwhile is not None, "the server did not send what was waited for"
                meanwhile()
                continue
            if msg.type == aiohttp.WSMsgType.TEXT:
                data = json.loads(msg.data)
                if data["op"] == "advertise":
                    self.channels.update({c["topic"]: c for c in data["channels"]})
                elif data["op"] == "status":
                    self.statuses.append(data)
            elif msg.type == aiohttp.WSMsgType.BINARY:
                self.binary.append(msg.data)

    def of(self, opcode: int) -> list[bytes]:
        return [b[1:] for b in self.binary if b[0] == opcode]


async def _session(live: LiveScene, port: int, steps) -> None:
    async with aiohttp.ClientSession() as http, http.ws_connect(f"ws://127.0.0.1:{port}",
                                                                protocols=(SUBPROTOCOL,)) as ws:
        info = json.loads((await ws.receive(timeout=5)).data)
        await steps(Client(ws), info)


def _served(steps) -> LiveScene:
    live = LiveScene(load_scenario(SCENARIOS / "crater_observation.yaml"), terrain_cells=8)
    port = free_port()
    server = live.serve("127.0.0.1", port, timeline_s=900)
    try:
        asyncio.run(_session(live, port, lambda client, info: steps(live, client, info)))
    finally:
        server.stop()
        live.close()
    return live


def test_time_follows_the_worlds_clock_and_the_senses_are_logged_in_simulated_time():
    seen: dict = {}

    async def steps(live: LiveScene, client: Client, info: dict) -> None:
        seen["capabilities"] = info["capabilities"]
        seen["end"] = info["dataEndTime"]
        clock = _sample(KEYS.clock, m.Clock(tick=125, sim_time=12.5, time_scale=1.0))
        assert live.handle(clock)
        # A clock sent as the client joins may reach the server before the client does, as with the world's own
        # clock (20 a second); the same clock again until one arrives.
        await client.pump(lambda: client.of(TIME), meanwhile=lambda: live.handle(clock))
        seen["time"] = struct.unpack("<Q", client.of(TIME)[-1])[0]
        assert live.handle(_sample(KEYS.rover(1, "gyroscope"), m.Gyroscope(stamp=7.0, pitch_deg=12.0)))
        assert live.handle(_sample(KEYS.rover(1, "perception"), _scan()))
        assert live.handle(_sample(KEYS.rover(1, "battery"), m.Battery(stamp=7.0, charge_wh=30, capacity_wh=60)))
        topics = ("/rover_1/imu", "/rover_1/scan", "/rover_1/battery")
        await client.pump(lambda: all(t in client.channels for t in topics))
        seen["channels"] = {t: client.channels[t] for t in topics}
        await client.ws.send_json({"op": "subscribe", "subscriptions": [
            {"id": i, "channelId": client.channels[t]["id"]} for i, t in enumerate(topics)]})

        def log_again() -> None:  # until the server has taken the subscriptions (it does not answer them)
            assert live.handle(_sample(KEYS.rover(1, "gyroscope"), m.Gyroscope(stamp=8.0, pitch_deg=-4.0)))
            assert live.handle(_sample(KEYS.rover(1, "perception"), _scan()))
            assert live.handle(_sample(KEYS.rover(1, "battery"), m.Battery(stamp=8.5, charge_wh=15, capacity_wh=60)))

        await client.pump(lambda: len({d[:4] for d in client.of(MESSAGE_DATA)}) >= 3, meanwhile=log_again)
        seen["data"] = {struct.unpack("<I", d[:4])[0]: (struct.unpack("<Q", d[4:12])[0], d[12:])
                        for d in client.of(MESSAGE_DATA)}

    live = _served(steps)
    assert {"time", "clientPublish", "playbackControl"} <= set(seen["capabilities"]) and seen["end"]["sec"] == 900
    assert seen["time"] == 12_500_000_000 and live.now_ns == 12_500_000_000
    imu, scan, _ = seen["channels"].values()
    assert imu["encoding"] == "json" and scan["schemaName"] == "foxglove.LaserScan"
    imu_time, imu_data = seen["data"][0]
    assert imu_time == 8_000_000_000 and json.loads(imu_data) == {"stamp": 8.0, "pitch_deg": -4.0}
    scan_time, scan_data = seen["data"][1]
    decoded = message_class(base64.b64decode(scan["schema"]), "foxglove.LaserScan").FromString(scan_data)
    assert scan_time == 7_250_000_000 and decoded.frame_id == "rover_1" and len(decoded.ranges) == 50
    # ROS and Foxglove count counter-clockwise from the right: 105 deg to the right is the first ray
    assert decoded.ranges[0] == 3.0 and decoded.ranges[49] == 4.5 and math.isinf(decoded.ranges[20])
    assert decoded.intensities[0] == 1.0 and decoded.intensities[49] == 4.0  # a rover, the lander
    assert decoded.start_angle == pytest.approx(-math.radians(105))
    assert json.loads(seen["data"][2][1])["fraction"] == 0.25


def _playback(command: int, seek_ns: int | None, request_id: bytes) -> bytes:
    return (bytes([PLAYBACK_CONTROL, command]) + struct.pack("<f", 1.0) + bytes([seek_ns is not None])
            + struct.pack("<Q", seek_ns or 0) + struct.pack("<I", len(request_id)) + request_id)


def test_a_client_publishes_ground_commands_and_controls_playback_and_what_it_may_not_is_counted():
    seen: dict = {}

    async def steps(live: LiveScene, client: Client, info: dict) -> None:
        await client.ws.send_json({"op": "advertise", "channels": [
            {"id": 5, "topic": "/ground/command", "encoding": "json", "schemaName": "lunarsim.GroundCommand"},
            {"id": 6, "topic": "/rover_1/cmd_vel", "encoding": "json", "schemaName": "x"}]})
        for data in (b'{"command": "set-target", "x": 30, "z": 40}', b"not json", b'{"command": "explode"}',
                     b'{"command": "stop"}', b" " * 5000):
            await client.ws.send_bytes(bytes([MESSAGE_DATA]) + struct.pack("<I", 5) + data)
        await client.ws.send_bytes(bytes([MESSAGE_DATA]) + struct.pack("<I", 6) + b'{"linear": 1}')
        await client.ws.send_bytes(_playback(1, 5_000_000_000, b"req-1"))
        await client.pump(lambda: client.of(PLAYBACK_STATE))
        seen["state"] = client.of(PLAYBACK_STATE)[0]
        await client.ws.send_bytes(_playback(0, None, b"req-2"))
        await client.pump(lambda: len(client.of(PLAYBACK_STATE)) >= 2)
        seen["commands"] = live.take_commands()
        target = seen["commands"][0].request_id
        assert not live.handle(_sample(KEYS.ground_command_result, m.CommandResult(request_id="someone-else",
                                                                                   accepted=True)))
        assert live.handle(_sample(KEYS.ground_command_result, m.CommandResult(
            request_id=target, accepted=False, detail="no goal there")))
        await client.pump(lambda: any("set_target" in st["message"] for st in client.statuses))
        seen["status"] = next(st for st in client.statuses if "set_target" in st["message"])

    live = _served(steps)
    commands = [(c.command, c.x, c.z, c.seconds) for c in seen["commands"]]
    assert commands == [("set_target", 30.0, 40.0, None), ("seek", None, None, 5.0), ("pause", None, None, None),
                        ("resume", None, None, None)]
    assert b"req-1" in seen["state"] and seen["state"][0] == 1  # paused
    assert seen["status"]["message"] == "set_target refused by the lander: no goal there"
    assert seen["status"]["level"] == 1  # a warning
    refused = live.ground.rejected.by_topic
    assert refused["/ground/command"] == 4 and refused["advertise"] == 1 and refused["client message"] == 1


@pytest.mark.e2e
def test_lunarsim_view_foxglove_sends_a_clients_command_on_the_ground_key(router, tmp_path):
    port = free_port()
    view = lunarsim("view", "--foxglove", "--scenario", str(SCENARIOS / "crater_observation.yaml"), "--world",
                    KEYS.world, "--connect", router, "--port", str(port))
    got: list[m.GroundCommand] = []
    try:
        wait_for_output(view, "serving world", 30)
        with zenoh.open(build_config(connect=[router])) as session:
            session.declare_subscriber(KEYS.ground_command, lambda s: got.append(
                codec.decode(m.GroundCommand, s.payload.to_bytes())))

            async def publish() -> None:
                async with aiohttp.ClientSession() as http, http.ws_connect(f"ws://127.0.0.1:{port}",
                                                                            protocols=(SUBPROTOCOL,)) as ws:
                    await ws.receive(timeout=5)
                    await ws.send_json({"op": "advertise", "channels": [
                        {"id": 1, "topic": "/ground/command", "encoding": "json", "schemaName": "cmd"}]})
                    deadline = asyncio.get_running_loop().time() + 20
                    while not got and asyncio.get_running_loop().time() < deadline:  # until the view has a router
                        await ws.send_bytes(bytes([MESSAGE_DATA]) + struct.pack("<I", 1)
                                            + b'{"command": "stop", "rover_id": 2}')
                        await asyncio.sleep(0.5)

            asyncio.run(publish())
            wait_for(lambda: got, 5, "the client's command on the ground key")
        assert view.poll() is None
    finally:
        stop(view)
    assert got[0].command == "stop" and got[0].rover_id == 2
