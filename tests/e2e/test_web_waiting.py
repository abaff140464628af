"""``lunarsim view`` started before any world: it serves its page at once, says it waits for a world at its
endpoint (on its terminal once, and in the page's header), and shows the world when one comes.

Real processes on loopback: the view, then a router (``python -m deploy.router``) and a short run on its endpoint,
or a run whose world is the router itself (as ``lunarsim run`` is by default, on the port the view waits on); the
header is checked in a real headless Chromium (``test_web_browser.browser_context``).
"""

from __future__ import annotations

import asyncio
import json
import socket
import urllib.request
from pathlib import Path

import pytest
from aiohttp import WSMsgType
from aiohttp.test_utils import TestClient, TestServer
from procs import SCENARIOS, free_port, lunarsim, module, stop, wait_for
from test_web_browser import page_value, positions, shot, start_view

from bus.process import EXIT_NO_ROUTER
from deploy.children import wait_for_port
from web import editor, live
from web.page_commands import Commands
from web.server import Viewer, build_app

CRATER = str(SCENARIOS / "crater_observation.yaml")


def test_replay_tokens_are_counted_by_state_and_unknown_states_ignored():
    source = live.Source("tcp/127.0.0.1:7447")
    source.replay_token("lunar/w/alive/replay/playing", True)
    source.replay_token("lunar/w/alive/replay/../../etc", True)  # anyone may declare a token under the key
    assert source.status() == {"router": "tcp/127.0.0.1:7447", "connected": True, "replay": "playing"}
    source.replay_token("lunar/w/alive/replay/paused", True)  # the replay swaps: the new token first
    source.replay_token("lunar/w/alive/replay/playing", False)
    assert source.status()["replay"] == "paused"
    source.replay_token("lunar/w/alive/replay/paused", False)
    source.replay_token("lunar/w/alive/replay/paused", False)  # a second goodbye does not go below none
    source.replay_token("lunar/w/alive/replay/paused", True)
    assert source.status()["replay"] == "paused"


def test_a_view_without_a_router_says_so_refuses_commands_and_tells_pages_when_one_comes(tmp_path: Path):
    sent: list = []
    source = live.Source("tcp/127.0.0.1:7447", connected=False)
    viewer = Viewer("test", live.Latest(), Commands(sent.append), editor.Workspace(tmp_path / "ws"),
                    editor.Launcher(tmp_path / "runs", "tcp/127.0.0.1:7447", "test"), None, source)

    async def go() -> tuple[dict, dict, int, dict, dict]:
        async with TestClient(TestServer(build_app(viewer))) as client:
            info = await (await client.get("/api/info")).json()
            async with client.ws_connect("/ws") as ws:
                hello = json.loads((await ws.receive()).data)
                res = await client.post("/api/command", json={"command": "pause"})
                refused = await res.json()
                source.set_connected(True)
                source.replay_token("lunar/test/alive/replay/playing", True)
                while (msg := await ws.receive(timeout=10)).type == WSMsgType.TEXT:
                    if (data := json.loads(msg.data))["type"] == "source" and data["connected"]:
                        return info, hello, res.status, refused, data
                raise AssertionError(f"the socket ended without a source message: {msg}")

    info, hello, status, refused, changed = asyncio.run(go())
    assert (info["connected"], info["router"], info["replay"]) == (False, "tcp/127.0.0.1:7447", None)
    assert hello["source"] == {"router": "tcp/127.0.0.1:7447", "connected": False, "replay": None}
    assert status == 503 and "waiting for a world at tcp/127.0.0.1:7447" in refused["error"] and not sent
    assert changed == {"type": "source", "router": "tcp/127.0.0.1:7447", "connected": True, "replay": "playing"}


def test_a_run_launched_from_the_editor_routes_itself_where_no_router_listens(tmp_path: Path):
    """The view started alone on a loopback endpoint: the launched run's world becomes the router there."""
    port = free_port()
    assert editor.Launcher(tmp_path, f"tcp/127.0.0.1:{port}", "w").router_args() == ["--port", str(port)]
    with socket.create_server(("127.0.0.1", 0)) as taken:
        endpoint = f"tcp/127.0.0.1:{taken.getsockname()[1]}"
        assert editor.Launcher(tmp_path, endpoint, "w").router_args() == ["--connect", endpoint]
    assert editor.Launcher(tmp_path, "tcp/10.0.0.7:7447", "w").router_args() == ["--connect", "tcp/10.0.0.7:7447"]


def _get(url: str) -> tuple[int, bytes]:
    with urllib.request.urlopen(url, timeout=10) as answer:
        return answer.status, answer.read()


def _info(url: str) -> dict:
    status, body = _get(url + "api/info")
    assert status == 200
    return json.loads(body)


def _waiting_page(browser, url: str, endpoint: str):
    """The page of a view with no router: it answers, and its header says where it waits."""
    status, body = _get(url)
    assert status == 200 and b"bundle.js" in body
    info = _info(url)
    assert (info["connected"], info["router"], info["replay"]) == (False, endpoint, None), info
    page = browser.new_page()
    page.goto(url)
    wait_for(lambda: page_value(page, "lunarsim.run.status") == "no-router", 15, "the header to say it waits")
    assert page.inner_text("#conn") == f"waiting for a world at {endpoint}"
    assert "connects by itself" in page.inner_text("#runinfo")
    return page


def _said_once(view) -> str:
    """The view's terminal: it said once that it waits, and that it connected."""
    stderr = view.stderr.read()
    assert stderr.count("waiting for a Zenoh router at") == 1, stderr
    assert "connected to the Zenoh router" in stderr, stderr
    return stderr


@pytest.mark.e2e
def test_a_view_started_before_its_router_waits_then_shows_the_world(tmp_path, browser):
    """A router, then a short world (``lunarsim world``, no agents: its rovers stand) on the view's endpoint."""
    endpoint = f"tcp/127.0.0.1:{free_port()}"
    world = "early"
    view, url = start_view(endpoint, world, tmp_path, "--scenario", CRATER)
    router = run = None
    try:
        page = _waiting_page(browser, url, endpoint)
        shot(page, "view_waiting_for_a_world")
        router = module("deploy.router", "--listen", endpoint)
        assert wait_for_port("127.0.0.1", int(endpoint.rsplit(":", 1)[1]), 15, router)
        wait_for(lambda: _info(url)["connected"], 30, "the view to reach the router")
        run = lunarsim("world", CRATER, "--connect", endpoint, "--world", world, "--no-lander", "--start-timeout",
                       "0.5", "--time-scale", "5", "--max-sim-time", "20", "--exit-when-done")
        wait_for(lambda: len(positions(page)) == 5, 60, "the world's five rovers on the page")
        wait_for(lambda: page_value(page, "lunarsim.run.status") in ("live", "ended"), 10, "the world on the page")
        shot(page, "view_waited_for_a_world")
        run.communicate(timeout=120)
        assert run.returncode == 0
        wait_for(lambda: page_value(page, "lunarsim.run.status") == "ended", 20, "the world's end on the page")
    finally:
        stop(*(p for p in (run, router) if p is not None), view)
    _said_once(view)


@pytest.mark.e2e
def test_a_run_whose_world_routes_on_the_port_the_view_waits_on_is_shown_to_its_end(tmp_path, browser):
    """The README's tour: the view first on the default endpoint, then ``lunarsim run``, whose world listens on
    that port (so the view must not), and the end of the run stays on the page after its world is gone."""
    port = free_port()
    endpoint = f"tcp/127.0.0.1:{port}"
    view, url = start_view(endpoint, "default", tmp_path, "--scenario", CRATER)
    run = None
    try:
        page = _waiting_page(browser, url, endpoint)
        run = lunarsim("run", CRATER, "--port", str(port), "--time-scale", "5", "--max-sim-time", "40",
                       "--quiet", "--no-record", "--out", str(tmp_path / "run"))
        wait_for(lambda: len(positions(page)) == 5, 90, "the world's five rovers on the page")
        wait_for(lambda: page_value(page, "lunarsim.run.status") in ("live", "ended"), 10, "the run on the page")
        run.communicate(timeout=120)
        assert run.returncode == 0
        wait_for(lambda: page_value(page, "lunarsim.run.status") == "ended", 20, "the run's end on the page")
        wait_for(lambda: not _info(url)["connected"], 20, "the view to notice its router went with the world")
        assert page.inner_text("#conn") == "run ended"
    finally:
        stop(*(p for p in (run,) if p is not None), view)
    _said_once(view)


def _publish_states(endpoint: str, world: str, page) -> None:
    """A world's states from a session of the test's own, until the page shows them live."""
    import zenoh

    from bus.zenoh_config import build_config
    from schemas import codec
    from schemas import messages as m
    from schemas.keyspace import Keyspace

    rover = m.RoverTruth(id=1, x=1.0, z=2.0, heading_deg=0.0, action="move", state="migration", goal_index=0,
                         distance_to_goal_m=10.0, distance_covered_m=1.0, alive=True)
    with zenoh.open(build_config(connect=[endpoint])) as session:
        for i in range(100):
            session.put(Keyspace(world).state, codec.encode(m.WorldState(stamp=0.1 * i, rovers=[rover])))
            if page_value(page, "lunarsim.run.status") == "live":
                return
            page.wait_for_timeout(100)
    raise AssertionError(f"the page never showed the states live: {page_value(page, 'lunarsim.run')}")


@pytest.mark.e2e
def test_a_view_whose_router_goes_says_so_and_shows_the_world_of_the_next_one(tmp_path, browser):
    """The subscriptions made at the first connection keep receiving through a router restarted on the endpoint."""
    port = free_port()
    endpoint, world = f"tcp/127.0.0.1:{port}", "again"
    router = module("deploy.router", "--listen", endpoint)
    view = None
    try:
        assert wait_for_port("127.0.0.1", port, 15, router)
        view, url = start_view(endpoint, world, tmp_path)
        page = browser.new_page()
        page.goto(url)
        _publish_states(endpoint, world, page)
        stop(router)
        wait_for(lambda: page_value(page, "lunarsim.run.status") == "no-router", 20, "the router's loss on the page")
        assert page.inner_text("#conn") == f"waiting for a world at {endpoint}"
        router = module("deploy.router", "--listen", endpoint)
        assert wait_for_port("127.0.0.1", port, 15, router)
        wait_for(lambda: _info(url)["connected"], 30, "the view to reach the new router")
        _publish_states(endpoint, world, page)
    finally:
        stop(*(p for p in (view, router) if p is not None))


@pytest.mark.e2e
def test_a_view_given_a_router_timeout_serves_then_exits_3_when_none_came():
    endpoint = f"tcp/127.0.0.1:{free_port()}"
    port = free_port()
    view = lunarsim("view", "--connect", endpoint, "--port", str(port), "--router-timeout", "1")
    try:
        stdout, stderr = view.communicate(timeout=60)
    finally:
        stop(view)
    assert view.returncode == EXIT_NO_ROUTER, (stdout, stderr)
    assert "serving world 'default'" in stdout
    assert f"no Zenoh router reachable at {endpoint} after 1 s" in stderr and "Traceback" not in stderr
