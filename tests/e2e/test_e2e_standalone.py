"""Each process also runs alone: router, world, lander and rovers started one by one, over a real router.

The world must survive malformed samples and unknown rover ids, and say so in its statistics.
"""

from __future__ import annotations

import json

import pytest
import yaml
import zenoh
from procs import REPO, SCENARIOS, lunarsim, module, run_cli_mission, stop, wait_for

from bus.zenoh_config import build_config
from schemas import codec
from schemas import messages as m
from schemas.keyspace import Keyspace

pytestmark = pytest.mark.e2e


def test_processes_started_one_by_one_complete_a_two_rover_mission(router, tmp_path):
    world_name = "standalone"
    keys = Keyspace(world_name)
    common = ["--world", world_name, "--connect", router]
    scenario = tmp_path / "two.yaml"
    (SCENARIOS / "crater_observation.yaml").read_text()
    import yaml

    data = yaml.safe_load((SCENARIOS / "crater_observation.yaml").read_text())
    data["rovers"] = data["rovers"][:2]
    scenario.write_text(yaml.safe_dump(data))
    report_file = tmp_path / "report.json"
    world = module("world_service", str(scenario), *common, "--time-scale", "5", "--exit-when-done",
                   "--report", str(report_file), "--max-sim-time", "300")
    lander = module("lander_agent", str(scenario), *common)
    rovers = [module("rover_agent", "--id", str(i), "--params", str(scenario), *common) for i in (1, 2)]
    conf = build_config(connect=[router])
    try:
        with zenoh.open(conf) as session:
            finals = []
            sub = session.declare_subscriber(keys.stats, lambda s: finals.append(
                codec.decode(m.WorldStats, s.payload.to_bytes())))
            wait_for(lambda: any(not f.final for f in finals), 60, "live statistics from the world")
            session.put(keys.rover(1, "move_action"), b"\x93not a move")
            session.put(keys.rover(99, "move_action"), codec.encode(m.MoveAction(x=0, z=1)))
            session.put(keys.lander("comm_out"), b"garbage")
            wait_for(lambda: world.poll() is not None, 240, "the world to finish the mission")
            sub.undeclare()
        assert world.returncode == 0, world.stdout.read()
        report = json.loads(report_file.read_text())
        assert report["rovers_reached_final_goal"] == 2 and report["complete"] is True
        assert report["rejected_messages"] >= 3
        log = world.stdout.read()
        assert "no rover 99" in log and "payload is not msgpack" in log
    finally:
        stop(world, lander, *rovers)


def test_run_uses_a_running_router_with_connect(router, tmp_path):
    out = tmp_path / "run"
    report, _ = run_cli_mission(out, str(SCENARIOS / "crater_observation.yaml"), "--connect", router, "--rovers",
                                "2", "--world", "connected", "--time-scale", "5", "--max-sim-time", "300", "--quiet")
    assert report["rovers_total"] == 2 and report["rovers_reached_final_goal"] == 2
    assert not (out / "logs" / "router.log").exists()


def test_scenario_import_export_round_trip_from_the_command_line(tmp_path):
    profile = REPO / "tests" / "data" / "profiles" / "fig28_crater_and_return.json"
    yaml_file, json_file = tmp_path / "s.yaml", tmp_path / "s.json"
    for args in (("import", str(profile), "-o", str(yaml_file), "--name", "cr"),
                 ("export", str(yaml_file), "-o", str(json_file)),
                 ("check", str(yaml_file))):
        proc = lunarsim("scenario", *args)
        out, err = proc.communicate(timeout=60)
        assert proc.returncode == 0, out + err
    original, exported = json.loads(profile.read_text()), json.loads(json_file.read_text())
    assert len(exported["roverDataObjects"]) == len(original["roverDataObjects"]) == 5
    assert [g["index"] for g in exported["missionDataObjects"]] == [0, 1]
    assert exported["craterDataObjects"][0]["radius"] == pytest.approx(original["craterDataObjects"][0]["radius"])
    assert "ok: 'cr'" in out


def test_a_killed_agent_stops_its_rover_and_takes_it_again_when_restarted(router, tmp_path):
    import signal

    world_name = "watchdog"
    keys = Keyspace(world_name)
    common = ["--world", world_name, "--connect", router]
    data = yaml.safe_load((SCENARIOS / "crater_observation.yaml").read_text())
    data["rovers"] = data["rovers"][:2]
    scenario = tmp_path / "two.yaml"
    scenario.write_text(yaml.safe_dump(data))
    report_file = tmp_path / "report.json"
    world = module("world_service", str(scenario), *common, "--time-scale", "4", "--exit-when-done",
                   "--report", str(report_file), "--max-sim-time", "400")
    lander = module("lander_agent", str(scenario), *common)

    def rover(rid):
        return module("rover_agent", "--id", str(rid), "--params", str(scenario), "--state",
                      str(tmp_path / f"rover{rid}.json"), *common)

    rovers = {1: rover(1), 2: rover(2)}
    states: list[m.WorldState] = []
    try:
        with zenoh.open(build_config(connect=[router])) as session:
            sub = session.declare_subscriber(keys.state, lambda s: states.append(
                codec.decode(m.WorldState, s.payload.to_bytes())))
            truth = lambda rid: states[-1].rovers[rid - 1]  # noqa: E731
            wait_for(lambda: states and truth(1).distance_covered_m > 20, 90, "rover 1 under way")
            rovers[1].send_signal(signal.SIGKILL)
            rovers[1].wait(timeout=10)
            wait_for(lambda: not truth(1).alive and truth(1).action == "idle", 20, "the world to stop rover 1")
            stopped_at, other = truth(1).distance_covered_m, truth(2).distance_covered_m
            wait_for(lambda: truth(2).distance_covered_m > other + 10, 60, "rover 2 to go on alone")
            assert truth(1).distance_covered_m == stopped_at
            rovers[1] = rover(1)
            wait_for(lambda: truth(1).alive and truth(1).distance_covered_m > stopped_at + 5, 60,
                     "the restarted agent to drive rover 1 again")
            wait_for(lambda: world.poll() is not None, 240, "the mission to finish")
            sub.undeclare()
        report = json.loads(report_file.read_text())
        assert report["complete"] is True and report["rovers_reached_final_goal"] == 2, report
    finally:
        stop(world, lander, *rovers.values())


def test_a_world_that_cannot_listen_says_so_at_once(tmp_path):
    """``--listen`` makes the world the router: a port already taken is a usage error, not a wait for ever."""
    import socket

    with socket.socket() as taken:
        taken.bind(("127.0.0.1", 0))
        taken.listen()
        port = taken.getsockname()[1]
        proc = lunarsim("world", str(SCENARIOS / "crater_observation.yaml"), "--listen", f"tcp/127.0.0.1:{port}")
        _, stderr = proc.communicate(timeout=60)
    assert proc.returncode == 2, stderr
    assert f"cannot start a router listening on tcp/127.0.0.1:{port}" in stderr
