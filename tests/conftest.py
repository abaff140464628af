"""Shared fixtures (a real Zenoh router process on a free loopback port), and how pytest-xdist splits the suite."""

from __future__ import annotations

from pathlib import Path

import pytest
from procs import free_port, module, stop

from deploy.children import wait_for_port

WIDE_SCOPES = ("module", "package", "session")


@pytest.hookimpl(tryfirst=True)
def pytest_collection_modifyitems(items: list[pytest.Item]) -> None:
    """Under ``pytest -n N --dist loadgroup``, tests that share a fixture built once per module or session run on one
    worker, so it is built once: a module's fixture groups the module's tests, a session fixture (the flight
    environment) the tests across modules that use it. Other tests go to whichever worker is free. A test that must
    not run beside another (one that needs the default Zenoh port) names its group itself."""
    for item in items:
        if item.get_closest_marker("xdist_group") is None and (group := _shared_group(item)):
            item.add_marker(pytest.mark.xdist_group(group))


def _shared_group(item: pytest.Item) -> str | None:
    info = getattr(item, "_fixtureinfo", None)
    shared = [defs[-1] for defs in (info.name2fixturedefs.values() if info else ()) if defs and _ours(defs[-1])]
    for fixture in shared:
        if fixture.scope == "session":
            return fixture.argname
    return item.module.__name__ if shared and item.module is not None else None


def _ours(fixture: pytest.FixtureDef) -> bool:
    """A wide fixture of the suite's own (not pytest's, nor a cheap autouse one like ``_own_state_home``)."""
    return (fixture.scope in WIDE_SCOPES and not fixture.argname.startswith("_")
            and not fixture.func.__module__.startswith(("_pytest", "pytest", "xdist")))


@pytest.fixture(autouse=True, scope="session")
def _own_state_home(tmp_path_factory):
    """Processes started alone keep what a restart resumes from under ``$XDG_STATE_HOME``: the tests' own, so no
    test resumes a state another run of the suite left, and none is left in the user's home."""
    import os

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
    built once for the tests of the flight wheel and the flight benchmark's quick run."""
    import subprocess
    import sys

    from procs import REPO

    from deploy.flight import build_wheel as flight

    where = tmp_path_factory.mktemp("flight")
    wheel = flight.build(where / "dist", REPO)
    venv = where / "venv"
    subprocess.run([sys.executable, "-m", "venv", str(venv)], check=True)
    subprocess.run([str(venv / "bin" / "pip"), "install", "--quiet", str(wheel)], check=True, timeout=600)
    return venv


@pytest.fixture
def browser():
    """A headless Chromium context of its own (``test_web_browser.browser_context``), closed after the test."""
    import tempfile

    from playwright.sync_api import sync_playwright
    from test_web_browser import browser_context

    with tempfile.TemporaryDirectory() as user_data, sync_playwright() as p:
        context = browser_context(p, Path(user_data))
        yield context
        context.close()
