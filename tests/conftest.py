"""Shared fixtures: a real Zenoh router process on a free loopback port, the default port taken in turn, the flight
environment."""

from __future__ import annotations

import os
import tempfile
from pathlib import Path

import pytest
from procs import free_port, module, stop

from deploy.children import wait_for_port


def _share_bytecode() -> None:
    """The suite starts about a thousand Python processes from the checkout (``python -m deploy.cli`` with the
    repository as working folder); where ``PYTHONDONTWRITEBYTECODE`` is set, as on CI's machines, each compiled
    every module it imported, a tenth of a second of CPU for a world service. They share one bytecode cache in the
    temporary folder instead, which leaves the checkout untouched as that setting asks."""
    if os.environ.pop("PYTHONDONTWRITEBYTECODE", None) is not None:
        cache = Path(tempfile.gettempdir()) / f"lunarsim-tests-pycache-{os.getuid()}"
        os.environ.setdefault("PYTHONPYCACHEPREFIX", str(cache))


_share_bytecode()


@pytest.fixture
def default_zenoh_port():
    """Held while a test uses the default Zenoh port: an exclusive lock on a file beside the temporary folders, so
    such tests take the port in turn across pytest-xdist's workers, and across two runs of the suite."""
    import fcntl

    with open(Path(tempfile.gettempdir()) / "lunarsim-tests-default-zenoh-port.lock", "w") as lock:
        fcntl.flock(lock, fcntl.LOCK_EX)
        yield


@pytest.fixture(autouse=True, scope="session")
def _own_state_home(tmp_path_factory):
    """Processes started alone keep what a restart resumes from under ``$XDG_STATE_HOME``: the tests' own, so no
    test resumes a state another run of the suite left, and none is left in the user's home."""
    os.environ["XDG_STATE_HOME"] = str(tmp_path_factory.mktemp("state-home"))


@pytest.fixture
def router():
    """Endpoint of a fresh router (``python -m deploy.router``), stopped after the test."""
    port = free_port()
    endpoint = f"tcp/127.0.0.1:{port}"
    proc = module("deploy.router", "--listen", endpoint)
    assert wait_for_port("127.0.0.1", port, 15, proc), proc.stdout.read() if proc.poll() is not None else "timeout"
    yield endpoint
    stop(proc)


@pytest.fixture(scope="module")
def shim(tmp_path_factory) -> Path:
    """A ``lunarsim`` that prints its arguments NUL-separated, so a container's shell line runs for real."""
    folder = tmp_path_factory.mktemp("shim")
    script = folder / "lunarsim"
    script.write_text("#!/bin/sh\nfor a in \"$@\"; do printf '%s\\0' \"$a\"; done\n")
    script.chmod(0o755)
    return folder


@pytest.fixture(scope="session")
def flight_env(tmp_path_factory) -> Path:
    """The ``lunarsim-rover`` wheel built and installed into a fresh virtual environment, as on a flight computer;
    built once for the tests of the flight wheel and the flight benchmark's quick run, under pytest-xdist once for
    all workers (the first to need it builds it in their shared temporary folder, the others wait for it)."""
    import fcntl
    import subprocess
    import sys

    from procs import REPO

    from deploy.flight import build_wheel as flight

    base = tmp_path_factory.getbasetemp()
    where = (base.parent if os.environ.get("PYTEST_XDIST_WORKER") else base) / "flight"
    where.mkdir(exist_ok=True)
    venv = where / "venv"
    with open(where / "build.lock", "w") as lock:
        fcntl.flock(lock, fcntl.LOCK_EX)
        if not (where / "built").exists():
            wheel = flight.build(where / "dist", REPO)
            subprocess.run([sys.executable, "-m", "venv", str(venv)], check=True)
            subprocess.run([str(venv / "bin" / "pip"), "install", "--quiet", str(wheel)], check=True, timeout=600)
            (where / "built").touch()
    return venv


@pytest.fixture
def browser():
    """A headless Chromium context of its own (``test_web_browser.browser_context``), closed after the test."""
    from playwright.sync_api import sync_playwright
    from test_web_browser import browser_context

    with tempfile.TemporaryDirectory() as user_data, sync_playwright() as p:
        context = browser_context(p, Path(user_data))
        yield context
        context.close()
