"""The web server: the page, a WebSocket with the live world, and the REST endpoints of commands and editor.

No Zenoh in here: ``view`` feeds ``Viewer.latest`` from its subscriptions and hands in ``publish``, so
the HTTP side can be driven by anything that stores samples. Every request passes ``guard`` first (Host, Origin,
token); scenarios from the page are read in ``uploads``' worker process, never on the event loop.
"""

from __future__ import annotations

import asyncio
import contextlib
import json
import threading
from collections.abc import Callable
from pathlib import Path

from aiohttp import WSMsgType, web

from schemas.scenario import Scenario, ScenarioError
from web import editor, guard, live, uploads
from web.page_commands import CommandError, Commands, command_from_request
from web.scene import empty_scene, scenario_scene

STATIC = Path(__file__).parent / "static"
BUNDLE = STATIC / "bundle.js"
PAGE_TABS = ("live", "editor")
"""The page's tabs; each has its own URL (``/live``, ``/editor``), so a tab can be linked to and survives a reload."""
MAX_COMMAND_BYTES = 64 * 1024
"""Largest body of a request that carries no scenario (a ground command, a stop): read on the event loop."""
VIEWER: web.AppKey[Viewer] = web.AppKey("viewer")
STREAM: web.AppKey[asyncio.Task] = web.AppKey("stream")


class Viewer:
    """State shared by the handlers: latest samples, the scene shown, connected pages, editor and launcher."""

    def __init__(self, world: str, latest: live.Latest, commands: Commands, workspace: editor.Workspace,
                 launcher: editor.Launcher, scenario: Scenario | None = None,
                 source: live.Source | None = None) -> None:
        self.world = world
        self.latest = latest
        self.source = source or live.Source()
        self.commands = commands
        self.workspace = workspace
        self.launcher = launcher
        self.scenario = scenario
        self.scene = scenario_scene(scenario) if scenario is not None else empty_scene()
        self.clients: set[web.WebSocketResponse] = set()
        self.undecodable = 0
        self._counting = threading.Lock()  # ``messages_since`` runs on worker threads, for the stream and new pages
        self.worker = uploads.Worker()

    async def set_scenario(self, scenario: Scenario, scene: dict) -> None:
        """Show another scenario (one launched from the editor): new scene, old run's state forgotten."""
        self.scene = scene
        self.scenario = scenario
        self.latest.forget()
        await self.broadcast(json.dumps({"type": "scene", "scene": self.scene}))

    async def broadcast(self, text: str) -> None:
        for ws in list(self.clients):
            try:
                await asyncio.wait_for(ws.send_str(text), 5.0)
            except (ConnectionError, TimeoutError, RuntimeError):
                self.clients.discard(ws)

    def messages_since(self, seen: dict, seen_photos: dict) -> list[str]:
        """The page's messages of what changed since ``seen``. Decoding them may take a while (a large lander map is
        coarsened, a photo base64-encoded): the server runs this on a worker thread, off its loop."""
        out = []
        for stream, payload in self.latest.newer(seen).items():
            message = live.stream_message(stream, payload)
            if message is None:
                with self._counting:
                    self.undecodable += 1
                continue
            out.append(json.dumps(message))
        for rover, payload in self.latest.newer_photos(seen_photos).items():
            if (message := live.photo_message(rover, payload)) is not None:
                out.append(json.dumps(message))
        return out

    async def stream(self) -> None:
        """The latest of each stream to every page, ``STREAM_HZ`` times a second at most, and where the samples
        come from when that changes (a router reached or lost, a replay started, paused or gone)."""
        seen: dict = {}
        seen_photos: dict = {}
        source = self.source.status()
        while True:
            await asyncio.sleep(1.0 / live.STREAM_HZ)
            if (now := self.source.status()) != source:
                source = now
                await self.broadcast(json.dumps({"type": "source", **source}))
            if not self.clients:
                continue
            for text in await asyncio.to_thread(self.messages_since, seen, seen_photos):
                await self.broadcast(text)


def _error(message: str, status: int = 400) -> web.Response:
    return web.json_response({"ok": False, "error": message}, status=status)


async def _body(request: web.Request) -> dict:
    """The small JSON object a request carries. Only ``application/json`` is read: a page on another site can post
    that to this server only after the browser has asked it (CORS preflight, which it never allows), so such a
    page cannot launch runs or send ground commands through a browser on the viewer's machine even before
    ``guard`` refuses its Origin."""
    _json_only(request)
    if request.content_length is None or request.content_length > MAX_COMMAND_BYTES:
        raise web.HTTPRequestEntityTooLarge(MAX_COMMAND_BYTES, request.content_length or 0, text=json.dumps(
            {"ok": False, "error": f"send at most {MAX_COMMAND_BYTES} bytes, with a Content-Length"}),
            content_type="application/json")
    try:
        data = await request.json()
    except (json.JSONDecodeError, UnicodeDecodeError, RecursionError):
        raise web.HTTPBadRequest(text=json.dumps({"ok": False, "error": "request body is not JSON"}),
                                 content_type="application/json") from None
    if not isinstance(data, dict):
        raise web.HTTPBadRequest(text=json.dumps({"ok": False, "error": "expected a JSON object"}),
                                 content_type="application/json")
    return data


def _json_only(request: web.Request) -> None:
    if request.content_type != "application/json":
        raise web.HTTPUnsupportedMediaType(text=json.dumps({"ok": False, "error": "send the request body as "
                                                            "application/json"}), content_type="application/json")


async def _upload(request: web.Request, job: Callable[..., uploads.Answer], *args: object) -> uploads.Answer:
    """Run ``job`` on the request's JSON body (at most ``uploads.MAX_REQUEST_BYTES``) in the worker process."""
    _json_only(request)
    return await _in_worker(request, job, *args, body=True)


async def _in_worker(request: web.Request, job: Callable[..., uploads.Answer], *args: object,
                     body: bool = False) -> uploads.Answer:
    """Run ``job(*args)`` in the worker process, with the request's body first if ``body``; busy, too large or
    a worker that died become answers too."""
    worker = _viewer(request).worker
    try:
        with worker.admit():
            if body:
                args = (await request.read(), *args)
            return await worker.run(job, *args)
    except uploads.Busy:
        return uploads.error("the editor is busy with other scenarios: try again in a moment", 503)
    except web.HTTPRequestEntityTooLarge:
        return uploads.error(f"the request is larger than the {uploads.mib(uploads.MAX_REQUEST_BYTES)} the editor "
                             "reads", 413)
    except uploads.WorkerDied:
        return uploads.error("the process reading scenarios stopped (out of memory?): try again", 503)


def _respond(answer: uploads.Answer) -> web.Response:
    return web.Response(body=answer.body, status=answer.status, content_type="application/json")


def _viewer(request: web.Request) -> Viewer:
    return request.app[VIEWER]


async def index(request: web.Request) -> web.StreamResponse:
    if not BUNDLE.is_file():
        return web.Response(status=500, text="the web front end was not built: run `npm ci && npm run build` in "
                            "web/frontend (pip install does it when npm is on PATH)")
    return web.FileResponse(STATIC / "index.html")


async def websocket(request: web.Request) -> web.WebSocketResponse:
    viewer = _viewer(request)
    ws = web.WebSocketResponse(heartbeat=20.0)
    await ws.prepare(request)
    # The state's age lets a page that joins after the world stopped say so at once, not after a silence.
    await ws.send_str(json.dumps({"type": "hello", "world": viewer.world, "stream_hz": live.STREAM_HZ,
                                  "state_age_s": viewer.latest.age("state"), "source": viewer.source.status()}))
    await ws.send_str(json.dumps({"type": "scene", "scene": viewer.scene}))
    for text in await asyncio.to_thread(viewer.messages_since, {}, {}):
        await ws.send_str(text)
    viewer.clients.add(ws)
    # Said again now that broadcasts reach this page: a change between the hello and here would be missed.
    await ws.send_str(json.dumps({"type": "source", **viewer.source.status()}))
    try:
        async for msg in ws:
            if msg.type == WSMsgType.ERROR:
                break
    finally:
        viewer.clients.discard(ws)
    return ws


async def info(request: web.Request) -> web.Response:
    viewer = _viewer(request)
    return web.json_response({"world": viewer.world, "scenario": viewer.scene["name"], "clients": len(viewer.clients),
                              "launch": viewer.launcher.status(), "undecodable": viewer.undecodable,
                              "photos_dropped": viewer.latest.photos_dropped,
                              "validating": viewer.worker.running, **viewer.source.status()})


async def favicon(request: web.Request) -> web.FileResponse:
    """Browsers ask for ``/favicon.ico`` whatever the page says; an SVG answers (every current browser draws it)."""
    return web.FileResponse(STATIC / "favicon.svg", headers={"Content-Type": "image/svg+xml"})


async def scene(request: web.Request) -> web.Response:
    return web.json_response(_viewer(request).scene)


async def current(request: web.Request) -> web.Response:
    """The scenario the live view shows (``--scenario``, or the last launched): the editor opens it, not a blank."""
    scenario = _viewer(request).scenario
    return web.json_response({"ok": True, "scenario": None if scenario is None else editor.scenario_json(scenario)})


async def command(request: web.Request) -> web.Response:
    try:
        cmd = command_from_request(await _body(request))
    except CommandError as exc:
        return _error(str(exc))
    viewer = _viewer(request)
    if not (source := viewer.source.status())["connected"]:
        return _error(f"no world to send it to: the view is waiting for a world at {source['router']}", 503)
    result = await viewer.commands.send(cmd)
    return web.json_response({"ok": True, "command": cmd.command, **result})


async def validate(request: web.Request) -> web.Response:
    return _respond(await _upload(request, uploads.validate))


async def save(request: web.Request) -> web.Response:
    return _respond(await _upload(request, uploads.save, _viewer(request).workspace))


async def listing(request: web.Request) -> web.Response:
    return web.json_response({"ok": True, "names": _viewer(request).workspace.names()})


async def load(request: web.Request) -> web.Response:
    return _respond(await _in_worker(request, uploads.load, _viewer(request).workspace, request.query.get("name", "")))


async def launch(request: web.Request) -> web.Response:
    viewer = _viewer(request)
    answer = await _upload(request, uploads.prepare_launch, viewer.workspace)
    if (plan := answer.plan) is None:
        return _respond(answer)
    try:
        out = viewer.launcher.launch(plan.path, plan.path.stem, plan.time_scale)
    except ScenarioError as exc:
        return _error(str(exc))
    await viewer.set_scenario(plan.scenario, plan.scene)
    return web.json_response({"ok": True, "path": str(plan.path), "out": str(out)})


async def launch_status(request: web.Request) -> web.Response:
    return web.json_response({"ok": True, **_viewer(request).launcher.status()})


async def launch_stop(request: web.Request) -> web.Response:
    await _body(request)  # only a JSON request: see _body
    viewer = _viewer(request)
    await asyncio.to_thread(viewer.launcher.stop)
    return web.json_response({"ok": True, **viewer.launcher.status()})


async def profile_import(request: web.Request) -> web.Response:
    return _respond(await _upload(request, uploads.profile_import))


async def profile_export(request: web.Request) -> web.Response:
    return _respond(await _upload(request, uploads.profile_export))


async def _start_stream(app: web.Application) -> None:
    app[VIEWER].commands.loop = asyncio.get_running_loop()
    app[STREAM] = asyncio.create_task(app[VIEWER].stream())


async def _stop(app: web.Application) -> None:
    """The worker process first: closing the pages' sockets may take a while, and a view killed meanwhile must not
    leave a process of its own behind."""
    app[VIEWER].worker.close()
    app[STREAM].cancel()
    with contextlib.suppress(asyncio.CancelledError):
        await app[STREAM]
    for ws in list(app[VIEWER].clients):
        await ws.close()


def build_app(viewer: Viewer, access: guard.Access | None = None) -> web.Application:
    """The view's app; ``access`` (default: loopback names, no token) says who may use it (``guard.access_for``)."""
    app = web.Application(client_max_size=uploads.MAX_REQUEST_BYTES,
                          middlewares=[guard.middleware(access or guard.Access())])
    app[VIEWER] = viewer
    app.router.add_get("/", index)
    for tab in PAGE_TABS:
        app.router.add_get(f"/{tab}", index)
    app.router.add_get("/favicon.ico", favicon)
    app.router.add_get("/ws", websocket)
    app.router.add_get("/api/info", info)
    app.router.add_get("/api/scene", scene)
    app.router.add_post("/api/command", command)
    app.router.add_post("/api/scenario/validate", validate)
    app.router.add_post("/api/scenario/save", save)
    app.router.add_get("/api/scenario/list", listing)
    app.router.add_get("/api/scenario/load", load)
    app.router.add_get("/api/scenario/current", current)
    app.router.add_post("/api/scenario/launch", launch)
    app.router.add_get("/api/launch", launch_status)
    app.router.add_post("/api/launch/stop", launch_stop)
    app.router.add_post("/api/profile/import", profile_import)
    app.router.add_post("/api/profile/export", profile_export)
    app.router.add_static("/static", STATIC)
    app.on_startup.append(_start_stream)
    app.on_shutdown.append(_stop)
    return app
