"""Helpers for tests that run real LunarSim processes over a real Zenoh router on loopback."""

from __future__ import annotations

import os
import signal
import socket
import subprocess
import sys
import time
from collections.abc import Callable
from pathlib import Path

import pytest

from bus.process import SHUTDOWN_DEADLINE_S

REPO = Path(__file__).resolve().parents[2]
SCENARIOS = REPO / "scenarios"
USES_DEFAULT_PORT = pytest.mark.usefixtures("default_zenoh_port")
"""For a test that starts what listens on or looks at the default Zenoh port (a run without ``--port``, a replay
serving as the router there): such tests take the port in turn (the ``default_zenoh_port`` fixture)."""


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def wait_for(predicate: Callable[[], object], timeout: float, what: str, interval: float = 0.05):
    """Poll until ``predicate`` returns something truthy; fail naming ``what`` after ``timeout`` seconds."""
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        value = predicate()
        if value:
            return value
        time.sleep(interval)
    raise AssertionError(f"timed out after {timeout:g} s waiting for {what}")


def lunarsim(*args: str, **kwargs) -> subprocess.Popen:
    """Start ``lunarsim ARGS`` (through the installed package's CLI module) in the repository folder."""
    return subprocess.Popen([sys.executable, "-m", "deploy.cli", *args], cwd=REPO, stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True, **kwargs)


def module(name: str, *args: str, env: dict[str, str] | None = None) -> subprocess.Popen:
    """Start ``python -m NAME ARGS``: each LunarSim process also runs alone."""
    return subprocess.Popen([sys.executable, "-m", name, *args], cwd=REPO, stdout=subprocess.PIPE,
                            stderr=subprocess.STDOUT, text=True, env=env)


def stop(*procs: subprocess.Popen) -> None:
    for p in procs:
        if p.poll() is None:
            p.send_signal(signal.SIGTERM)
    for p in procs:
        try:
            p.wait(timeout=SHUTDOWN_DEADLINE_S + 5)  # past its own deadline: a hang prints its stacks
        except subprocess.TimeoutExpired:
            p.kill()
            p.wait()


def processes_mentioning(text: str) -> list[int]:
    """Pids of live processes whose command line contains ``text`` (to check for orphans)."""
    pids = []
    for entry in Path("/proc").iterdir():
        if not entry.name.isdigit() or int(entry.name) == os.getpid():
            continue
        try:
            cmdline = (entry / "cmdline").read_bytes().replace(b"\0", b" ").decode(errors="replace")
            state = (entry / "stat").read_text().split()[2]
        except OSError:
            continue
        if text in cmdline and state != "Z":
            pids.append(int(entry.name))
    return pids


def run_cli_mission(out: Path, *args: str, timeout: float = 240) -> tuple[dict, str]:
    """``lunarsim run ARGS --out OUT``, waited for; it must exit 0. Returns (report.json, stdout)."""
    import json

    proc = lunarsim("run", *args, "--out", str(out))
    try:
        stdout, stderr = proc.communicate(timeout=timeout)
    finally:
        proc.kill()
    assert proc.returncode == 0, f"exit {proc.returncode}\n{stdout}\n{stderr}"
    return json.loads((out / "report.json").read_text()), stdout


def wait_for_output(proc: subprocess.Popen, text: str, timeout: float) -> str:
    """Read ``proc``'s stdout until a line contains ``text``; fail after ``timeout`` seconds or at its exit."""
    return next(line for line in read_until(proc, (text,), timeout).splitlines(keepends=True) if text in line)


def read_until(proc: subprocess.Popen, texts: tuple[str, ...], timeout: float) -> str:
    """Read ``proc``'s stdout until every one of ``texts`` has shown up, and return all it read; fail after
    ``timeout`` seconds or at its exit. A process handles samples when it gets to them: wait for its word."""
    import threading

    read: list[str] = []
    done = threading.Event()

    def reader() -> None:
        for line in proc.stdout:
            read.append(line)
            if all(any(text in seen for seen in read) for text in texts):
                done.set()
                return

    threading.Thread(target=reader, daemon=True).start()
    missing = [] if done.wait(timeout) else [t for t in texts if not any(t in seen for seen in read)]
    assert not missing, f"no line with {missing!r} from the process within {timeout:g} s (exit code {proc.poll()})"
    return "".join(read)


def two_rover_scenario(tmp_path: Path) -> Path:
    """The crater mission with its first two rovers only, written into ``tmp_path``: a small real mission."""
    import yaml

    data = yaml.safe_load((SCENARIOS / "crater_observation.yaml").read_text())
    data["rovers"] = data["rovers"][:2]
    path = tmp_path / "two.yaml"
    path.write_text(yaml.safe_dump(data))
    return path
