"""End to end: ``lunarsim run`` starts real processes on loopback, the world their Zenoh router."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys

import pytest
import yaml
import zenoh
from procs import REPO, SCENARIOS, free_port, lunarsim, processes_mentioning, run_cli_mission, wait_for

from bus.zenoh_config import build_config, port_in_use
from schemas import codec
from schemas import messages as m
from schemas.keyspace import Keyspace

pytestmark = pytest.mark.e2e


def test_five_rovers_reach_the_crater_with_no_collisions(tmp_path):
    port = free_port()
    out = tmp_path / "run"
    report, stdout = run_cli_mission(out, str(SCENARIOS / "crater_observation.yaml"), "--port", str(port),
                                     "--time-scale", "5", "--max-sim-time", "300", "--quiet", timeout=300)
    assert report["rovers_total"] == 5
    assert report["rovers_reached_final_goal"] == 5, report
    assert report["rover_collisions"] == 0 and report["obstacle_collisions"] == 0, report
    assert report["rovers_stuck"] == 0 and report["complete"] is True
    assert 0 < report["mission_duration_s"] < 300 and report["wall_time_s"] > 0
    assert report["average_path_efficiency"] > 0.5
    assert "Mission report" in stdout
    for name in ("world", "lander", *(f"rover{i}" for i in range(1, 6))):
        assert (out / "logs" / f"{name}.log").exists()
    assert not (out / "logs" / "router.log").exists(), "the world is the run's router"
    assert len(list((out / "photos").glob("*.png"))) == 5 * 12  # the world's copy of every photo
    assert len((out / "lander_archive" / "index.jsonl").read_text().splitlines()) == 5 * 12  # sent by radio
    assert processes_mentioning(f"127.0.0.1:{port}") == []


def test_a_typo_in_the_scenario_exits_2_naming_the_field(tmp_path):
    data = yaml.safe_load((SCENARIOS / "crater_observation.yaml").read_text())
    data["craters"][0]["radius_mm"] = data["craters"][0].pop("radius_m")
    bad = tmp_path / "typo.yaml"
    bad.write_text(yaml.safe_dump(data))
    proc = lunarsim("run", str(bad), "--max-sim-time", "5", "--port", str(free_port()), "--out", str(tmp_path / "o"))
    _, stderr = proc.communicate(timeout=60)
    assert proc.returncode == 2
    assert "craters.0.radius_mm: unknown field (did you mean 'radius_m'?)" in stderr
    assert len(stderr.strip().splitlines()) == 1


def test_ctrl_c_stops_every_process_and_keeps_a_report(tmp_path):
    port = free_port()
    out = tmp_path / "run"
    proc = lunarsim("run", str(SCENARIOS / "crater_observation.yaml"), "--out", str(out), "--port", str(port),
                    "--quiet")
    try:
        wait_for(lambda: len(processes_mentioning(f"127.0.0.1:{port}")) >= 8, 60, "all 8 child processes")
        stats = []
        with zenoh.open(build_config(connect=[f"tcp/127.0.0.1:{port}"])) as session:
            sub = session.declare_subscriber(Keyspace().stats, lambda s: stats.append(
                codec.decode(m.WorldStats, s.payload.to_bytes())))
            wait_for(lambda: any(x.stamp >= 2.0 for x in stats), 60, "the mission to be under way")
            sub.undeclare()
        # real time, five rovers, no crowd: the agents keep the world's priority (bus.priority)
        assert _policies(port, "rover_agent") == _policies(port, "lander_agent") == {os.SCHED_OTHER}
        assert _policies(port, "world_service") == {os.SCHED_OTHER}
        proc.send_signal(signal.SIGINT)
        _, stderr = proc.communicate(timeout=60)
    finally:
        proc.kill()
    assert proc.returncode == 130, stderr
    wait_for(lambda: processes_mentioning(f"127.0.0.1:{port}") == [], 15, "no orphan processes")
    report = json.loads((out / "report.json").read_text())
    assert report["complete"] is False and report["rovers_total"] == 5


@pytest.mark.parametrize("moment", ["world_service", "rover_agent"])
def test_a_ctrl_c_as_the_run_starts_ends_it_quietly_with_nothing_left(tmp_path, moment):
    """A Ctrl-C at the terminal reaches every process of the run at once: once the world is forked, then as the
    agents start. The launcher starts nothing more and does not wait for a world that has stopped: status 130, no
    error and no traceback, no process left (the camera's included), whichever ends first."""
    port = free_port()
    proc = lunarsim("run", str(SCENARIOS / "crater_observation.yaml"), "--out", str(tmp_path / "run"), "--port",
                    str(port), "--lockstep", "--no-record", "--quiet", start_new_session=True)
    try:
        world = wait_for(lambda: _run_processes(port, "world_service"), 60, "the world").pop()
        wait_for(lambda: _run_processes(port, moment), 60, f"a {moment} process")
        os.killpg(proc.pid, signal.SIGINT)
        _, stderr = proc.communicate(timeout=60)
    finally:
        proc.kill()
    assert proc.returncode == 130 and "error" not in stderr and "Traceback" not in stderr, stderr
    wait_for(lambda: processes_mentioning(f"127.0.0.1:{port}") == [], 15, "no orphan processes")
    wait_for(lambda: processes_mentioning(f"lunarsim camera of world {world}") == [], 15, "the camera to end")


RUN_PAST_THE_PORT_CHECK = """
import sys
from deploy import launcher
from deploy.cli import main
launcher.check_port_free = lambda port: None  # as if another run took the port just after the check
sys.exit(main())
"""


def test_a_run_whose_port_another_router_took_exits_2_and_starts_no_agent(tmp_path):
    """The port was free at the check and taken before the world listened: the port answers, but not as this run's
    world. The launcher waits for its own world's word that it listens, so its agents never join another run."""
    port = free_port()
    router = subprocess.Popen([sys.executable, "-m", "deploy.router", "--listen", f"tcp/127.0.0.1:{port}"],
                              cwd=REPO, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    try:
        wait_for(lambda: port_in_use("127.0.0.1", port), 60, "the other router")
        done = subprocess.run([sys.executable, "-c", RUN_PAST_THE_PORT_CHECK, "run",
                               str(SCENARIOS / "crater_observation.yaml"), "--port", str(port), "--out",
                               str(tmp_path / "run"), "--lockstep", "--no-record", "--quiet"], cwd=REPO,
                              capture_output=True, text=True, timeout=120)
    finally:
        router.terminate()
        router.wait(30)
    assert done.returncode == 2, done.stderr
    assert "the world could not start: " in done.stderr and "already using the port" in done.stderr
    assert "Traceback" not in done.stderr
    assert not (tmp_path / "run" / "logs" / "rover1.log").exists()


def test_a_lockstep_mission_whose_lander_dies_still_ends(tmp_path):
    """Without its lander the world steps on at full speed, and the rovers' photos can never be delivered: the
    mission ends once the lander has been away ``LANDER_GONE_S`` with every rover finished, rather than never."""
    port = free_port()
    out = tmp_path / "run"
    proc = lunarsim("run", str(SCENARIOS / "crater_observation.yaml"), "--out", str(out), "--port", str(port),
                    "--lockstep", "--no-record", "--quiet", "--seed", "2")
    try:
        lander = wait_for(lambda: _run_processes(port, "lander_agent"), 60, "the lander").pop()
        wait_for(lambda: "t = " in (out / "logs" / "lander.log").read_text(), 60, "the mission to be under way")
        os.kill(lander, signal.SIGTERM)
        stdout, stderr = proc.communicate(timeout=300)
    finally:
        proc.kill()
    assert proc.returncode == 0, stderr
    assert "lander exited" in stdout
    assert json.loads((out / "report.json").read_text())["complete"] is True


def test_an_agent_that_falls_behind_the_world_is_reported(tmp_path):
    """A rover agent stopped (SIGSTOP) for 3 simulated seconds resumes with its backlog: its status then runs
    behind the world's clock, and the launcher says so while running and in its summary."""
    port = free_port()
    proc = lunarsim("run", str(SCENARIOS / "crater_observation.yaml"), "--out", str(tmp_path / "run"), "--port",
                    str(port), "--max-sim-time", "12", "--quiet")
    try:
        rover = wait_for(lambda: _run_processes(port, "rover_agent --id 1"), 60, "rover 1's agent").pop()
        stats = []
        with zenoh.open(build_config(connect=[f"tcp/127.0.0.1:{port}"])) as session:
            sub = session.declare_subscriber(Keyspace().stats, lambda s: stats.append(
                codec.decode(m.WorldStats, s.payload.to_bytes()).stamp))
            wait_for(lambda: stats and stats[-1] >= 2.0, 60, "the mission to be under way")
            os.kill(rover, signal.SIGSTOP)
            try:
                stopped_at = stats[-1]
                wait_for(lambda: stats[-1] >= stopped_at + 3.0, 30, "3 s of the world's clock")
            finally:
                os.kill(rover, signal.SIGCONT)
            sub.undeclare()
        stdout, stderr = proc.communicate(timeout=120)
    finally:
        proc.kill()
    assert proc.returncode == 0, stderr
    assert "warning: rover 1's agent is" in stdout and "behind the world's clock" in stdout
    assert "1 rover agent(s) fell more than 2 s behind the world's clock (rover 1; up to" in stdout


def _run_processes(port: int, command: str) -> set[int]:
    """Pids of this run's processes started as ``python -m COMMAND ...``."""
    return set(processes_mentioning(f"-m {command} ")) & set(processes_mentioning(f"127.0.0.1:{port}"))


def _policies(port: int, module: str) -> set[int]:
    """Scheduling policies of this run's processes of ``module``."""
    return {os.sched_getscheduler(pid) for pid in _run_processes(port, module)}


def test_the_run_says_which_agents_have_connected_before_its_clock_runs(tmp_path):
    proc = lunarsim("run", str(SCENARIOS / "crater_observation.yaml"), "--out", str(tmp_path / "run"), "--port",
                    str(free_port()), "--max-sim-time", "1", "--no-record")
    stdout, stderr = proc.communicate(timeout=120)
    assert proc.returncode == 0, stderr
    lines = stdout.splitlines()
    connected = next(i for i, line in enumerate(lines) if " connected in " in line)
    assert lines[connected].startswith("5/5 rover agents and the lander connected in "), lines[connected]
    assert lines[connected].endswith(" s; clock running")
    assert lines[connected - 1].startswith("connecting: ")  # said at once, before the agents were all there
    assert lines[connected + 1].startswith("t = ")  # then the mission's own lines


def test_port_in_use_is_reported_plainly(tmp_path):
    import socket

    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        s.listen()
        port = s.getsockname()[1]
        proc = lunarsim("run", str(SCENARIOS / "crater_observation.yaml"), "--port", str(port),
                        "--out", str(tmp_path / "o"))
        _, stderr = proc.communicate(timeout=60)
    assert proc.returncode == 2
    assert f"port {port} on 127.0.0.1 is already in use" in stderr
    assert not (tmp_path / "o").exists(), "a run that cannot start leaves no run folder"


def test_no_router_is_said_plainly_within_seconds():
    port = free_port()
    proc = subprocess.run(
        [sys.executable, "-m", "rover_agent", "--id", "1", "--connect", f"tcp/127.0.0.1:{port}",
         "--router-timeout", "2"],
        capture_output=True, text=True, timeout=30, cwd=SCENARIOS.parent)
    assert proc.returncode == 3
    assert f"waiting for a Zenoh router at tcp/127.0.0.1:{port}" in proc.stderr
    assert "no Zenoh router reachable" in proc.stderr


def _noisy_scenario(folder):
    """crater_observation with every source of randomness switched on: slip, heading, gyroscope, radio loss."""
    data = yaml.safe_load((SCENARIOS / "crater_observation.yaml").read_text())
    data["rover_params"] = {"navigation": {"slip_std": 0.03, "heading_noise_std_deg": 1.0},
                            "perception": {"gyroscope_noise_std_deg": 0.2},
                            "communication": {"loss_probability": 0.05}}
    path = folder / "noisy.yaml"
    path.write_text(yaml.safe_dump(data))
    return path


def _lockstep_report(folder, name: str, *extra: str) -> dict:
    report, _ = run_cli_mission(folder / name, str(_noisy_scenario(folder)), "--lockstep", "--seed", "7",
                                "--port", str(free_port()), "--quiet", *extra)
    report.pop("wall_time_s")
    return report


@pytest.fixture(scope="module")
def noisy_lockstep(tmp_path_factory) -> dict:
    """The noisy mission's lockstep report, seed 7, one rover agent a process: what a second run of the same seed,
    and a run with agents sharing processes, must repeat."""
    return _lockstep_report(tmp_path_factory.mktemp("noisy"), "first")


def test_lockstep_runs_with_the_same_seed_give_the_same_report(noisy_lockstep, tmp_path):
    first, second = noisy_lockstep, _lockstep_report(tmp_path, "b")
    assert first == second
    assert first["seed"] == 7 and first["complete"] is True and first["rovers_reached_final_goal"] >= 4


def test_rovers_sharing_processes_run_the_same_lockstep_mission(noisy_lockstep, tmp_path):
    shared = _lockstep_report(tmp_path, "shared", "--agents-per-process", "3")
    assert shared == noisy_lockstep
    assert sorted(p.name for p in (tmp_path / "shared" / "logs").glob("rover*.log")) == ["rovers1-3.log",
                                                                                       "rovers4-5.log"]
    assert len(list((tmp_path / "shared" / "state").glob("rover*.json"))) == 5


def test_batch_runs_seeded_missions_and_summarises_them(tmp_path):
    out = tmp_path / "batch"
    proc = lunarsim("batch", str(SCENARIOS / "crater_observation.yaml"), "--runs", "2", "--rovers", "2",
                    "--lockstep", "--jobs", "2", "--seed", "11", "--out", str(out))
    stdout, stderr = proc.communicate(timeout=300)
    assert proc.returncode == 0, stdout + stderr
    batch = json.loads((out / "batch.json").read_text())
    assert [r["seed"] for r in batch["runs"]] == [11, 12] and batch["failed"] == []
    agg = batch["aggregate"]
    assert agg["runs"] == 2 and agg["rovers_total"] == 4
    assert agg["rovers_reached_final_goal"] == sum(r["rovers_reached_final_goal"] for r in batch["runs"])
    assert batch["runs"][0]["total_distance_covered_m"] != batch["runs"][1]["total_distance_covered_m"]
    for run in batch["runs"]:  # every rover on the rim photographs it once round, and the lander has them all
        assert run["photos_at_lander"] == 12 * run["rovers_reached_final_goal"]
    assert agg["photos_at_lander"] == sum(r["photos_at_lander"] for r in batch["runs"])
    assert agg["worst_rover_connected_fraction"] == min(r["worst_rover_connected_fraction"] for r in batch["runs"])
    assert "all runs" in stdout and "photos" in stdout and (out / "run-001-seed11" / "report.json").exists()


def test_batch_refuses_a_folder_that_holds_another_batch(tmp_path):
    (tmp_path / "run-001-seed1").mkdir()
    proc = lunarsim("batch", str(SCENARIOS / "crater_observation.yaml"), "--runs", "1", "--out", str(tmp_path))
    _, stderr = proc.communicate(timeout=60)
    assert proc.returncode == 2 and "already holds a batch" in stderr
