"""Twin mode: the world follows real rovers from their drivers' telemetry.

Unit tests drive ``TwinWorld`` with scripted samples; the end-to-end test runs the world with ``--twin``
over a real router against two driver processes, records the session and reports from the recording.
"""

from __future__ import annotations

import itertools
import json
import logging
import math
import re
import subprocess
import sys

import pytest
import yaml
import zenoh
from procs import REPO, SCENARIOS, lunarsim, stop, wait_for, wait_for_output

from bus.zenoh_config import build_config
from schemas import codec
from schemas import messages as m
from schemas.keyspace import Keyspace
from schemas.scenario import load_scenario
from sessions.format import read_samples
from shared.pose import Pose
from world_service.served import ServedWorld
from world_service.sim import World
from world_service.twin.rovers import STALE_AFTER_S, TwinRover, compose
from world_service.twin.world import TwinWorld

STARTS = [{"x": -510.0, "z": 100.0, "heading_deg": 180.0}, {"x": -500.0, "z": 100.0, "heading_deg": 90.0}]
"""Two rovers: one facing -z (odometry (x, z) lands at start - (x, z)), one facing +x (at start + (z, -x))."""


def two_rover_scenario(tmp_path, starts: list[dict] = STARTS):
    data = yaml.safe_load((SCENARIOS / "crater_observation.yaml").read_text())
    data["rovers"] = starts
    path = tmp_path / "twin.yaml"
    path.write_text(yaml.safe_dump(data))
    return path


def telemetry(x: float, z: float, heading: float = 0.0, moving: bool = True) -> bytes:
    return codec.encode(m.Telemetry(stamp=0.0, x=x, z=z, heading_deg=heading, moving=moving))


def status(state: str, goal_index: int = 0, photos_pending: int = 0) -> bytes:
    return codec.encode(m.RoverStatus(stamp=0.0, state=state, goal_index=goal_index, photos_pending=photos_pending))


@pytest.fixture
def twin(tmp_path) -> TwinWorld:
    return TwinWorld(load_scenario(two_rover_scenario(tmp_path)), Keyspace("t"))


def steps(world: TwinWorld, seconds: float) -> list:
    return [o for _ in range(round(seconds / world.clock.dt)) for o in world.step()]


def test_the_twin_and_the_simulation_both_offer_what_the_service_loop_drives(twin):
    world = World(twin.scenario, twin.keys)
    assert isinstance(twin, ServedWorld) and isinstance(world, ServedWorld)
    assert twin.clock.message().run != world.clock.message().run  # each run names itself
    assert twin.take_photo_jobs() == [] and list(twin.rover_ids) == list(world.rover_ids) == [1, 2]


# ---- pose composition and distance ----


@pytest.mark.parametrize(("heading", "expected"), [
    (0.0, (11.0, 22.0, 30.0)),     # facing +z: odometry axes are the map's
    (90.0, (12.0, 19.0, 120.0)),   # facing +x: ahead is +x, right is -z
    (180.0, (9.0, 18.0, 210.0)),   # facing -z: both axes flip
    (270.0, (8.0, 21.0, 300.0)),   # facing -x: ahead is -x, right is +z
])
def test_telemetry_is_placed_on_the_map_from_the_start_pose(heading, expected):
    pose = compose(Pose(10.0, 20.0, heading), m.Telemetry(stamp=1.0, x=1.0, z=2.0, heading_deg=30.0))
    assert (pose.x, pose.z, pose.heading) == pytest.approx(expected)


def test_heading_wraps_into_0_to_360():
    pose = compose(Pose(0.0, 0.0, 300.0), m.Telemetry(stamp=0.0, x=0.0, z=0.0, heading_deg=100.0))
    assert pose.heading == pytest.approx(40.0)
    assert compose(Pose(0.0, 0.0, 10.0), m.Telemetry(stamp=0.0, x=0.0, z=0.0, heading_deg=-30.0)).heading \
        == pytest.approx(340.0)


def test_distance_covered_sums_the_odometry_path_not_turns_or_standing():
    rover = TwinRover(1, Pose(0.0, 0.0, 0.0))
    square = [(0, 0), (0, 1), (0, 2), (1, 2), (2, 2), (2, 2), (2, 1), (2, 0), (1, 0), (0, 0)]  # 8 m, one stop
    for t, (x, z) in enumerate(square):
        rover.follow(m.Telemetry(stamp=t, x=x, z=z, heading_deg=90.0 * t), now=0.2 * t)
    assert rover.distance_covered == pytest.approx(8.0)
    assert (rover.pose.x, rover.pose.z) == pytest.approx((0.0, 0.0))


# ---- the twin world from scripted samples ----


def test_world_state_follows_telemetry_status_and_liveliness(twin):
    keys = twin.keys
    for x in (0.0, 1.0, 2.0, 3.0):  # rover 1 drives 3 m ahead (-z on the map), then 4 m right (-x)
        twin.receive(keys.rover(1, "telemetry"), telemetry(0.0, x))
    twin.receive(keys.rover(1, "telemetry"), telemetry(4.0, 3.0, heading=90.0))
    twin.receive(keys.rover(2, "telemetry"), telemetry(0.0, 5.0, heading=-10.0, moving=False))
    twin.receive(keys.rover(1, "status"), status("climbing"))
    twin.set_alive(2, False)
    out = steps(twin, 1.0)
    states = [msg for key, msg in out if key == keys.state]
    clocks = [msg for key, msg in out if key == keys.clock]
    assert len(states) == 5 and len(clocks) == round(1.0 / twin.clock.dt)  # state at the simulated world's 5 Hz
    assert all(c.running and not c.lockstep for c in clocks)
    one, two = states[-1].rovers
    assert (one.x, one.z, one.heading_deg) == pytest.approx((-514.0, 97.0, 270.0))
    assert one.distance_covered_m == pytest.approx(7.0) and one.action == "move" and one.alive
    assert (one.state, one.goal_index) == ("climbing", 0)
    crater = twin.scenario.craters[0]
    assert one.distance_to_goal_m == pytest.approx(abs(math.hypot(-514.0 - crater.x, 97.0 - crater.z)
                                                       - crater.radius_m), abs=1e-3)
    assert (two.x, two.z, two.heading_deg) == pytest.approx((-495.0, 100.0, 80.0))
    assert two.action == "idle" and two.state == "waiting" and not two.alive
    assert two.distance_covered_m == pytest.approx(5.0)  # its first sample: counted from the start pose
    assert twin.report().total_distance_covered_m == pytest.approx(12.0)


def test_radio_reports_give_the_links_and_the_daisy_chain(twin):
    keys = twin.keys
    twin.receive(keys.rover(1, "comm_partners"), codec.encode(m.CommPartners(ids=[0, 2])))
    twin.receive(keys.rover(2, "comm_partners"), codec.encode(m.CommPartners(ids=[1])))
    twin.receive(keys.lander("comm_partners"), codec.encode(m.CommPartners(ids=[1])))
    state = twin.observed_state()
    assert state.comm_links == [(0, 1), (1, 2)] and state.relays == [1]
    assert twin.world_state().comm_links == state.comm_links


def test_the_mission_completes_when_every_rover_has_finished_and_stopped(twin):
    keys = twin.keys
    crater = twin.scenario.craters[0]
    crest = (crater.x, crater.z + crater.radius_m)  # rover 1 (facing -z) drives to the crest's north point
    twin.receive(keys.rover(1, "telemetry"), telemetry(STARTS[0]["x"] - crest[0], STARTS[0]["z"] - crest[1]))
    twin.receive(keys.rover(1, "status"), status("done"))
    twin.receive(keys.rover(2, "status"), status("stuck"))
    steps(twin, 0.4)
    assert not twin.complete  # rover 1's driver still says it moves
    twin.receive(keys.rover(1, "telemetry"), telemetry(STARTS[0]["x"] - crest[0], STARTS[0]["z"] - crest[1],
                                                       moving=False))
    twin.receive(keys.rover(2, "telemetry"), telemetry(0.0, 0.0, moving=False))
    steps(twin, 0.4)
    assert twin.complete
    report = twin.report()
    assert report.complete and report.rovers_reached_final_goal == 1 and report.rovers_stuck == 1


def test_a_photo_on_its_way_to_a_reachable_lander_keeps_the_mission_open(twin):
    keys = twin.keys
    for rid in (1, 2):
        twin.receive(keys.rover(rid, "telemetry"), telemetry(0.0, 0.0, moving=False))
        twin.receive(keys.rover(rid, "status"), status("done", photos_pending=1 if rid == 1 else 0))
    twin.receive(keys.rover(1, "comm_partners"), codec.encode(m.CommPartners(ids=[0])))
    steps(twin, 0.4)
    assert not twin.complete
    twin.receive(keys.rover(1, "comm_partners"), codec.encode(m.CommPartners(ids=[])))  # out of the lander's reach
    steps(twin, 0.4)
    assert twin.complete


def test_malformed_or_unknown_samples_are_rejected_and_counted(twin, caplog):
    keys = twin.keys
    nan = codec.encode(m.Telemetry(stamp=0.0, x=float("nan"), z=0.0, heading_deg=0.0, pitch_deg=0.0,
                                   moving=False))  # built unchecked: a Struct checks nothing until decoded
    bad = [(keys.rover(1, "telemetry"), b"garbage"), (keys.rover(1, "telemetry"), nan),
           (keys.rover(9, "telemetry"), telemetry(0.0, 1.0)),
           (keys.rover(1, "move_action"), codec.encode(m.MoveAction(x=0.0, z=1.0))),
           (keys.rover(2, "comm_partners"), codec.encode(m.CommPartners(ids=[7])))]
    with caplog.at_level(logging.WARNING, "lunarsim.world"):
        for key, payload in bad:
            assert twin.receive(key, payload) == []
    assert twin.observed_state().counters.rejected_messages == len(bad)
    assert (twin.bodies[1].pose, twin.bodies[1].distance_covered) == (twin.bodies[1].start, 0.0)
    assert "no rover 9" in caplog.text and "ids not in the scenario: [7]" in caplog.text


def test_stale_telemetry_is_marked_and_logged_once_per_gap(twin, caplog):
    keys = twin.keys
    with caplog.at_level(logging.WARNING, "lunarsim.world"):
        for _ in range(round((STALE_AFTER_S - 0.4) / 0.2)):  # both drivers report, then rover 2's goes quiet
            twin.receive(keys.rover(1, "telemetry"), telemetry(0.0, 1.0))
            twin.receive(keys.rover(2, "telemetry"), telemetry(0.0, 1.0))
            steps(twin, 0.2)
        for _ in range(round(2 * STALE_AFTER_S / 0.2)):
            twin.receive(keys.rover(1, "telemetry"), telemetry(0.0, 1.0))
            steps(twin, 0.2)
        assert twin.bodies[2].stale and not twin.bodies[1].stale
        assert twin.world_state().rovers[1].action == "idle"  # its last sample said moving: no longer believed
        assert [r.telemetry_stale for r in twin.world_state().rovers] == [False, True]  # viewers see it too
        twin.receive(keys.rover(2, "telemetry"), telemetry(0.0, 2.0))
        steps(twin, 0.2)
    assert not twin.bodies[2].stale and not twin.world_state().rovers[1].telemetry_stale
    assert caplog.text.count("rover 2: no telemetry") == 1 and "rover 1: no telemetry" not in caplog.text
    assert "rover 2: telemetry again" in caplog.text


def test_twin_refuses_lockstep_and_a_scaled_clock(tmp_path):
    scenario = str(two_rover_scenario(tmp_path))
    refusals = ((["--lockstep"], "cannot run --lockstep"), (["--time-scale", "5"], "--time-scale must be 1"))
    for flags, problem in refusals:
        proc = lunarsim("world", scenario, "--twin", *flags, "--connect", "tcp/127.0.0.1:9")
        out, err = proc.communicate(timeout=60)
        assert proc.returncode == 2 and problem in err, out + err


# ---- end to end: driver processes, the twin world, the recorder and the report ----


def driver(router: str, rover_id: int, legs: str, partners: str) -> subprocess.Popen:
    return subprocess.Popen([sys.executable, str(REPO / "tests" / "support" / "twin_driver.py"), "--connect", router,
                             "--world", "twin", "--id", str(rover_id), "--legs", legs, "--partners", partners],
                            cwd=REPO, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)


def on_path(x: float, z: float, corners: list[tuple[float, float]]) -> bool:
    """Whether (x, z) lies on the polyline through ``corners`` (within a millimetre)."""
    for (ax, az), (bx, bz) in itertools.pairwise(corners):
        length = math.hypot(bx - ax, bz - az)
        t = max(0.0, min(1.0, ((x - ax) * (bx - ax) + (z - az) * (bz - az)) / length**2)) if length else 0.0
        if math.hypot(x - (ax + t * (bx - ax)), z - (az + t * (bz - az))) < 1e-3:
            return True
    return False


@pytest.mark.e2e
def test_twin_follows_driver_processes_and_the_recording_reports_their_drive(router, tmp_path):
    scenario, keys = two_rover_scenario(tmp_path), Keyspace("twin")
    session_file, report_file, recorded_file = tmp_path / "twin.mcap", tmp_path / "live.json", tmp_path / "rec.json"
    recorder = lunarsim("record", "-o", str(session_file), "--world", "twin", "--connect", router,
                        "--scenario", str(scenario))
    world = drivers = None
    try:
        wait_for_output(recorder, "recording", 20)
        world = lunarsim("world", str(scenario), "--twin", "--world", "twin", "--connect", router, "--no-lander",
                         "--report", str(report_file), "--start-timeout", "20")
        # rover 1: 4 m ahead, a right turn, 3 m (7 m); rover 2: 5 m ahead. Rover 1 relays rover 2's radio.
        drivers = [driver(router, 1, "drive:4,turn:90,drive:3", "0,2"), driver(router, 2, "drive:5", "1")]
        with zenoh.open(build_config(connect=[router])) as session:
            clocks, finals = [], []
            subs = [session.declare_subscriber(keys.clock, lambda s: clocks.append(
                        codec.decode(m.Clock, s.payload.to_bytes()))),
                    session.declare_subscriber(keys.stats, lambda s: finals.append(
                        codec.decode(m.WorldStats, s.payload.to_bytes()).final))]
            wait_for(lambda: any(c.running for c in clocks), 30, "the twin's clock to run")
            session.put(keys.rover(1, "telemetry"), b"not telemetry")
            session.put(keys.rover(9, "telemetry"), telemetry(0.0, 1.0))
            wait_for(lambda: any(finals), 40, "the twin to see the drive complete (final statistics)")
            for sub in subs:
                sub.undeclare()
        stop(world)  # it serves the final statistics until told to stop
        _, world_log = world.communicate(timeout=10)
        assert world.returncode == 0, world_log
    finally:
        stop(*(drivers or []), *([world] if world else []), recorder)
    live = json.loads(report_file.read_text())
    assert live["complete"] and live["total_distance_covered_m"] == pytest.approx(12.0, abs=1e-3)
    assert live["rejected_messages"] >= 2 and "rejected sample on lunar/twin/rover/1/telemetry" in world_log

    states = [codec.decode(m.WorldState, s.payload) for s in read_samples(session_file) if s.key == keys.state]
    assert len(states) > 20, "the recorder wrote too few world states"
    span = states[-1].stamp - states[0].stamp
    assert len(states) == pytest.approx(span * 5 + 1, abs=3)  # 5 Hz, as the simulated world
    (x1, z1), (x2, z2) = ((s["x"], s["z"]) for s in STARTS)
    paths = {1: [(x1, z1), (x1, z1 - 4), (x1 - 3, z1 - 4)], 2: [(x2, z2), (x2 + 5, z2)]}  # see STARTS
    for state in states:
        for truth in state.rovers:
            assert on_path(truth.x, truth.z, paths[truth.id]), (state.stamp, truth)
    one, two = states[-1].rovers
    assert (one.x, one.z, one.heading_deg) == pytest.approx((x1 - 3, z1 - 4, 270.0), abs=1e-3)
    assert (two.x, two.z, two.heading_deg) == pytest.approx((x2 + 5, z2, 90.0), abs=1e-3)
    assert one.distance_covered_m == pytest.approx(7.0, abs=1e-3) and two.state == "done"
    assert states[-1].comm_links == [(0, 1), (1, 2)] and states[-1].relays == [1]
    assert any(t.action == "move" for s in states for t in s.rovers)

    proc = lunarsim("report", str(session_file), "--json", str(recorded_file), "--no-plot")
    out, err = proc.communicate(timeout=60)
    assert proc.returncode == 0, out + err
    recorded = json.loads(recorded_file.read_text())
    assert recorded["total_distance_covered_m"] == pytest.approx(12.0, abs=1e-3)
    assert recorded["average_distance_covered_m"] == pytest.approx(6.0, abs=1e-3)
    assert recorded["complete"] and recorded["rejected_messages"] == live["rejected_messages"]


@pytest.mark.e2e
def test_twin_follows_a_rover_driven_through_the_driver_bridge_on_an_emulated_device(router, tmp_path):
    """The real chain: emulated serial device -> serial driver -> ``lunarsim bridge`` -> telemetry -> the twin."""
    (start,) = starts = [STARTS[1]]  # facing +x: odometry (x, z) lands at start + (z, -x)
    scenario, keys = two_rover_scenario(tmp_path, starts), Keyspace("bench")
    common = ["--world", "bench", "--connect", router]
    device = lunarsim("emulate-device", "--rocks", "none")
    world = bridge = None
    try:
        port = wait_for_output(device, "emulated device on", 20).split()[-1]
        world = lunarsim("world", str(scenario), "--twin", "--no-lander", "--start-timeout", "1", *common)
        bridge = lunarsim("bridge", "--id", "1", "--driver", f"serial://{port}", *common)
        with zenoh.open(build_config(connect=[router])) as session:
            states: list[m.WorldState] = []
            sub = session.declare_subscriber(keys.state, lambda s: states.append(
                codec.decode(m.WorldState, s.payload.to_bytes())))
            wait_for(lambda: states and states[-1].comm_links == [(0, 1)], 30,
                     "the twin to show the radio link the emulated device reports")
            session.put(keys.rover(1, "move_action"), codec.encode(m.MoveAction(x=0.0, z=4.0)))  # as an agent would
            wait_for(lambda: any(s.rovers[0].action == "move" for s in states), 10, "the twin to see the move")
            wait_for(lambda: states[-1].rovers[0].action == "idle", 20, "the move to end")
            sub.undeclare()
    finally:
        stop(*(p for p in (bridge, world) if p), device)
    final = re.search(r"final pose x=(\S+) z=(\S+) heading=(\S+)", device.stdout.read())
    assert final, "the emulated device did not say where it ended"
    x, z, heading = map(float, final.groups())
    assert z == pytest.approx(4.0, abs=0.2) and abs(x) < 0.05  # the device really drove
    truth = states[-1].rovers[0]
    assert (truth.x, truth.z) == pytest.approx((start["x"] + z, start["z"] - x), abs=0.02)
    assert truth.heading_deg == pytest.approx((90.0 + heading) % 360.0, abs=0.5)
    assert truth.distance_covered_m == pytest.approx(math.hypot(x, z), abs=0.05)
