"""Who may use the web view (``web/guard.py``): a real aiohttp server, a real HTTP client, real headers.

A DNS rebinding page sends its own name as Host; a page on another site sends its Origin; a browser beyond
loopback must show the view's token. Loopback needs no token, so the browser tests open the page as they always did.
"""

from __future__ import annotations

import asyncio
import json
import re
from collections.abc import AsyncIterator
from contextlib import asynccontextmanager
from pathlib import Path

import aiohttp
import pytest
from aiohttp import web
from aiohttp.test_utils import TestClient, TestServer
from procs import free_port, lunarsim, stop, wait_for_output

from schemas import messages as m
from web import editor, guard, live
from web.page_commands import Commands
from web.server import Viewer, build_app

PAUSE = {"command": "pause"}
"""A clock command: sent at once, with no lander to answer it."""


def _viewer(tmp_path: Path, sent: list[m.GroundCommand]) -> Viewer:
    return Viewer("test", live.Latest(), Commands(sent.append), editor.Workspace(tmp_path / "ws"),
                  editor.Launcher(tmp_path / "runs", "tcp/127.0.0.1:1", "test"))


def _hosts(port: int, host: str, origin: str | None = None) -> dict[str, str]:
    return {"Host": f"{host}:{port}", **({"Origin": origin} if origin else {})}


def test_a_rebinding_host_and_foreign_origins_are_refused_and_the_views_own_origin_is_not(tmp_path: Path):
    sent: list[m.GroundCommand] = []

    async def go() -> dict[str, tuple[int, str]]:
        async with TestClient(TestServer(build_app(_viewer(tmp_path, sent)))) as client:
            port = client.server.port
            own = f"http://127.0.0.1:{port}"

            async def post(host: str, origin: str | None) -> tuple[int, str]:
                res = await client.post("/api/command", json=PAUSE, headers=_hosts(port, host, origin))
                return res.status, (await res.json())["error" if res.status != 200 else "detail"]

            out = {"rebinding": await post("evil.example", f"http://evil.example:{port}"),
                   "cross-site": await post("127.0.0.1", f"http://evil.example:{port}"),
                   "other port": await post("127.0.0.1", "http://127.0.0.1:1"),
                   "null origin": await post("127.0.0.1", "null")}
            res = await client.get("/api/scene", headers=_hosts(port, "evil.example"))
            out["truth by rebinding"] = res.status, (await res.json())["error"]
            out["sent before"] = len(sent), ""
            out["same origin"] = await post("127.0.0.1", own)
            out["localhost"] = await post("localhost", f"http://localhost:{port}")
            res = await client.get("/api/info")  # no Origin: curl, or a page's own GET
            out["no origin"] = res.status, ""
            with pytest.raises(aiohttp.WSServerHandshakeError) as refused:
                await client.ws_connect("/ws", headers={"Origin": f"http://evil.example:{port}"})
            out["websocket cross-site"] = refused.value.status, ""
            async with client.ws_connect("/ws", headers={"Origin": own}) as ws:
                out["websocket same origin"] = 200, json.loads((await ws.receive()).data)["type"]
            return out

    out = asyncio.run(go())
    assert out["rebinding"][0] == 403 and "host 'evil.example' is not one this view is served as" in out["rebinding"][1]
    for case in ("cross-site", "other port", "null origin"):
        assert out[case][0] == 403 and "cross-origin" in out[case][1], case
    assert out["truth by rebinding"][0] == 403
    assert out["sent before"][0] == 0  # nothing refused reached the bus
    assert out["same origin"] == (200, "pause sent (a replay does not answer)")
    assert out["localhost"][0] == 200 and out["no origin"][0] == 200
    assert [c.command for c in sent] == ["pause", "pause"]
    assert out["websocket cross-site"][0] == 403
    assert out["websocket same origin"] == (200, "hello")


@asynccontextmanager
async def _served(app: web.Application, host: str) -> AsyncIterator[int]:
    runner = web.AppRunner(app, access_log=None)
    await runner.setup()
    port = free_port()
    try:
        await web.TCPSite(runner, host, port).start()
        yield port
    finally:
        await runner.cleanup()


def test_bound_beyond_loopback_every_request_needs_the_token_but_the_login_page(tmp_path: Path):
    """Bound to 0.0.0.0 (every address, loopback included), reached through 127.0.0.1 as a remote browser would
    reach the machine's address: the token comes as ``?token=`` once, then as a cookie, or as a Bearer header."""
    token, made = guard.choose_token("0.0.0.0", None)
    assert made and guard.TOKEN_FORM.fullmatch(token)
    access = guard.access_for("0.0.0.0", ["ground.lab"], token)
    bearer = {"Authorization": f"Bearer {token}"}

    async def go() -> dict[str, object]:
        out: dict[str, object] = {}
        async with _served(build_app(_viewer(tmp_path, []), access), "0.0.0.0") as port, aiohttp.ClientSession(
                f"http://127.0.0.1:{port}", cookie_jar=aiohttp.CookieJar(unsafe=True)) as client:
            for name, path in (("info", "/api/info"), ("scene", "/api/scene"), ("bundle", "/static/bundle.js")):
                async with client.get(path) as res:
                    out[name] = res.status, await res.text()
            async with client.post("/api/command", json=PAUSE) as res:
                out["command"] = res.status
            with pytest.raises(aiohttp.WSServerHandshakeError) as refused:
                await client.ws_connect("/ws")
            out["websocket"] = refused.value.status
            async with client.get("/") as res:
                out["login"] = res.status, res.content_type, await res.text()
            async with client.get("/live?token=not-the-token-at-all") as res:
                out["wrong"] = res.status, await res.text()
            async with client.get("/api/info", headers=bearer) as res:
                out["bearer"] = res.status
            for host in ("evil.example", "ground.lab", "192.0.2.7"):
                async with client.get("/api/info", headers={**bearer, "Host": f"{host}:{port}"}) as res:
                    out[host] = res.status
            assert len(client.cookie_jar) == 0
            async with client.get(f"/live?token={token}&scale=0.5", allow_redirects=False) as res:
                out["enter"] = res.status, res.headers.get("Location"), res.headers.get("Set-Cookie", "")
            async with client.get("/api/info") as res:
                out["cookie"] = res.status
            async with client.ws_connect("/ws", headers={"Origin": f"http://127.0.0.1:{port}"}) as ws:
                out["websocket with cookie"] = json.loads((await ws.receive()).data)["type"]
        return out

    out = asyncio.run(go())
    for name in ("info", "scene", "bundle"):
        status, body = out[name]
        assert status == 401 and "needs its token" in json.loads(body)["error"], name
    assert out["command"] == 401 and out["websocket"] == 401
    status, kind, page = out["login"]
    assert status == 401 and kind == "text/html" and 'name=token' in page and "/static/" not in page
    assert out["wrong"][0] == 401 and "not the token of this view" in out["wrong"][1]
    assert out["bearer"] == 200
    assert (out["evil.example"], out["ground.lab"], out["192.0.2.7"]) == (403, 200, 200)
    status, location, cookie = out["enter"]
    assert status == 303 and location == "/live?scale=0.5"  # the token leaves the address bar
    assert cookie.startswith(f"{access.cookie}={token}") and "HttpOnly" in cookie and "SameSite=Lax" in cookie
    assert out["cookie"] == 200 and out["websocket with cookie"] == "hello"


def test_the_hosts_a_view_answers_as_follow_its_bind_address():
    loopback = guard.access_for("127.0.0.1", ["Ground.Lab:8080"])
    assert loopback.token is None and loopback.hosts >= {"127.0.0.1", "localhost", "::1", "ground.lab"}
    assert not loopback.host_allowed("192.0.2.7") and not loopback.host_allowed("evil.example")
    lan = guard.access_for("192.0.2.7", [], "t" * 16)
    assert lan.host_allowed("192.0.2.7") and not lan.host_allowed("198.51.100.1")
    assert guard.split_host("[::1]:8080") == ("::1", 8080) and guard.split_host("LocalHost.") == ("localhost", None)
    for bad in ("evil example", "[::1", "host:99999", "a:b:c"):
        with pytest.raises(guard.HostError):
            guard.split_host(bad)
    assert guard.choose_token("::1", None) == (None, False)
    with pytest.raises(ValueError, match="16 to 256"):
        guard.choose_token("127.0.0.1", "short")


def test_lunarsim_view_beyond_loopback_prints_its_url_with_a_token_once(router, tmp_path: Path):
    port = free_port()
    view = lunarsim("view", "--connect", router, "--world", "guarded", "--host", "0.0.0.0", "--port", str(port),
                    "--workspace", str(tmp_path / "ws"), "--runs", str(tmp_path / "runs"))
    try:
        line = wait_for_output(view, "serving world", 30)
        token = re.search(r"\?token=([A-Za-z0-9_-]+)", line).group(1)

        async def go() -> tuple[int, int, dict]:
            async with aiohttp.ClientSession(f"http://127.0.0.1:{port}",
                                             cookie_jar=aiohttp.CookieJar(unsafe=True)) as client:
                async with client.get("/api/info") as res:
                    without = res.status
                async with client.get(f"/api/info?token={token}") as res:  # follows the redirect, with the cookie
                    return without, res.status, await res.json()

        without, status, info = asyncio.run(go())
        assert without == 401 and status == 200 and info["world"] == "guarded"
    finally:
        stop(view)
    assert view.stdout.read().count(token) == 0  # printed once, in the line already read
    bad = lunarsim("view", "--connect", router, "--token", "short", "--port", str(free_port()))
    _, err = bad.communicate(timeout=60)
    assert bad.returncode == 2 and err.strip().splitlines() == [
        "error: --token: the token must be 16 to 256 letters, digits or '._~-'"]
