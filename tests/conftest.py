"""Shared fixtures: a real Zenoh router process on a free loopback port."""

from __future__ import annotations

import pytest
from procs import free_port, module, stop

from deploy.children import wait_for_port


@pytest.fixture
def router():
    """Endpoint of a fresh router (``python -m deploy.router``), stopped after the test."""
    port = free_port()
    endpoint = f"tcp/127.0.0.1:{port}"
    proc = module("deploy.router", "--listen", endpoint)
    assert wait_for_port("127.0.0.1", port, 15, proc), proc.stdout.read() if proc.poll() is not None else "timeout"
    yield endpoint
    stop(proc)
