"""Who may use the web view: the Host it is asked for, the Origin of the page asking, and its token.

The view sends ground commands and shows ground truth, so a page on another site must not reach it through a
browser on the viewer's machine. Three checks, on every request (WebSocket upgrades included):

- **Host**: a request must name one of the hosts the view is served as. A DNS rebinding page runs under its own
  name (``evil.example``), which the browser sends as Host even once that name points at this machine, so it
  fails here. A wildcard bind (``0.0.0.0``, ``::``) serves every address of the machine: any IP address passes
  then, since a rebinding page always has a DNS name.
- **Origin**: a request that carries one (browsers send it with every POST, fetch and WebSocket) must come from
  the view's own origin: same host and port as its Host.
- **Token**: bound beyond loopback, every request but the small login page needs the view's token, as the cookie
  a first visit with ``?token=`` sets or as ``Authorization: Bearer``.
"""

from __future__ import annotations

import hashlib
import hmac
import html
import ipaddress
import re
import secrets
import socket
from collections.abc import Awaitable, Callable, Iterable
from dataclasses import dataclass
from typing import TYPE_CHECKING

from schemas.errors import LunarSimError

# aiohttp loads only where a response is made: every lunarsim command imports this module (its checks and
# constants) to build its parser, and most never serve a page.
if TYPE_CHECKING:
    from aiohttp import web

LOOPBACK_NAMES = frozenset({"127.0.0.1", "localhost", "::1"})
WILDCARDS = frozenset({"0.0.0.0", "::", ""})
TOKEN_ENV = "LUNARSIM_VIEW_TOKEN"
"""The environment variable ``lunarsim view`` takes a token from when ``--token`` is not given."""
TOKEN_FORM = re.compile(r"[A-Za-z0-9._~-]{16,256}")
"""A token fits a URL and a cookie unescaped, and is long enough not to be guessed."""
PAGE_PATHS = frozenset({"/", "/live", "/editor"})
"""Where a browser without the token is shown the login page instead of a bare refusal."""
_NAME = re.compile(r"[a-z0-9_]([a-z0-9_-]*[a-z0-9_])?(\.[a-z0-9_]([a-z0-9_-]*[a-z0-9_])?)*")
ECHO_CHARS = 100


class HostError(LunarSimError, ValueError):
    """A host name or Host header that is not one (the message says why)."""


def split_host(authority: str) -> tuple[str, int | None]:
    """``name``, ``name:port``, ``[v6]`` or ``[v6]:port`` as (lower-case name without brackets, port or None)."""
    text = authority.strip().lower()
    if text.startswith("["):
        name, bracket, rest = text[1:].partition("]")
        port = rest.removeprefix(":") if rest.startswith(":") else None
        if not bracket or (rest and port is None):
            raise HostError(f"{_clip(authority)!r} is not host[:port]")
        name = str(_ip(name))
    else:
        name, colon, port = text.rpartition(":") if ":" in text else (text, "", None)
        if colon and ":" in name:
            raise HostError(f"{_clip(authority)!r}: put an IPv6 address in brackets")
        name = name.removesuffix(".")
        if not _NAME.fullmatch(name) or len(name) > 253:
            raise HostError(f"{_clip(authority)!r} is not a host name or address")
    if port is None:
        return name, None
    if not port.isdigit() or not 0 < int(port) < 65536:
        raise HostError(f"{_clip(authority)!r} has no valid port")
    return name, int(port)


def _ip(name: str) -> ipaddress.IPv4Address | ipaddress.IPv6Address:
    try:
        return ipaddress.ip_address(name)
    except ValueError:
        raise HostError(f"{_clip(name)!r} is not an IP address") from None


def host_name(text: str) -> str:
    """A host as a user names it (``name``, ``name:port``, an IP address, bracketed or not), as Host compares."""
    bare = text.strip().strip("[]").lower()
    return str(ipaddress.ip_address(bare)) if is_ip(bare) else split_host(text)[0]


def is_ip(name: str) -> bool:
    try:
        ipaddress.ip_address(name)
    except ValueError:
        return False
    return True


def is_loopback(bind: str) -> bool:
    """Whether serving on ``bind`` reaches this machine only; a name other than localhost counts as beyond."""
    name = bind.strip("[]").lower()
    return name == "localhost" or (is_ip(name) and ipaddress.ip_address(name).is_loopback)


@dataclass(frozen=True)
class Access:
    """The hosts the view answers as and the token it asks for (None: none needed)."""

    hosts: frozenset[str] = LOOPBACK_NAMES
    any_address: bool = False
    token: str | None = None

    def host_allowed(self, name: str) -> bool:
        return name in self.hosts or (self.any_address and is_ip(name))

    @property
    def cookie(self) -> str:
        """Named after the token, so two views on one host name (cookies ignore ports) keep their own."""
        digest = hashlib.sha256((self.token or "").encode()).hexdigest()[:12]
        return f"lunarsim_view_{digest}"


def access_for(bind: str, allow_hosts: Iterable[str] = (), token: str | None = None) -> Access:
    """The Access of a view served on ``bind``: loopback names when the bind reaches them, the bound address, the
    machine's name beyond loopback, and ``allow_hosts`` (names a user reaches it by, e.g. through a proxy)."""
    name = bind.strip("[]").lower()
    hosts = {host_name(h) for h in allow_hosts}
    if is_loopback(name):
        hosts |= LOOPBACK_NAMES | {name}
    elif name in WILDCARDS:
        hosts |= LOOPBACK_NAMES | {socket.gethostname().lower()}
    else:
        hosts |= {host_name(name), socket.gethostname().lower()}
    return Access(frozenset(hosts), any_address=name in WILDCARDS, token=token)


def choose_token(bind: str, given: str | None) -> tuple[str | None, bool]:
    """(the token, whether it was made here). A given token is always asked for; beyond loopback one is made."""
    if given is not None:
        if not TOKEN_FORM.fullmatch(given):
            raise ValueError("the token must be 16 to 256 letters, digits or '._~-'")
        return given, False
    if is_loopback(bind):
        return None, False
    return secrets.token_urlsafe(24), True


def refusal(request: web.Request, access: Access) -> web.StreamResponse | None:
    """The response refusing ``request``, or None if it may go on to its handler."""
    try:
        host, port = split_host(request.headers.get("Host", ""))
    except HostError:
        return _json(403, "refused: the request has no valid Host header")
    if not access.host_allowed(host):
        return _json(403, f"refused: host {_clip(host)!r} is not one this view is served as (lunarsim view "
                          "--allow-host adds one)")
    origin = request.headers.get("Origin")
    if origin is not None and not _same_origin(origin, host, port):
        return _json(403, f"refused: a page from {_clip(origin)!r} may not use this view (cross-origin)")
    if access.token is None or _presented(request, access):
        return None
    given = request.query.get("token")
    if given is not None and request.method == "GET" and hmac.compare_digest(given.encode(), access.token.encode()):
        return _enter(request, access)
    if request.method == "GET" and request.path in PAGE_PATHS:
        return _login(wrong=given is not None)
    return _json(401, "this view needs its token: open the URL lunarsim view printed, or send "
                      "'Authorization: Bearer TOKEN'")


def _same_origin(origin: str, host: str, port: int | None) -> bool:
    scheme, sep, authority = origin.partition("://")
    if not sep or scheme.lower() not in ("http", "https") or "/" in authority:
        return False
    try:
        return split_host(authority) == (host, port)
    except HostError:
        return False


def _presented(request: web.Request, access: Access) -> bool:
    token = (access.token or "").encode()
    bearer = request.headers.get("Authorization", "")
    if bearer[:7].lower() == "bearer " and hmac.compare_digest(bearer[7:].strip().encode(), token):
        return True
    cookie = request.cookies.get(access.cookie)
    return cookie is not None and hmac.compare_digest(cookie.encode(), token)


def _enter(request: web.Request, access: Access) -> web.Response:
    """The right ``?token=``: set the cookie and send the browser on without the token in its address bar."""
    from aiohttp import web

    rest = request.rel_url.with_query([(k, v) for k, v in request.query.items() if k != "token"])
    response = web.Response(status=303, headers={"Location": str(rest), "Cache-Control": "no-store"})
    response.set_cookie(access.cookie, access.token or "", httponly=True, samesite="Lax", path="/")
    return response


def _login(wrong: bool) -> web.Response:
    from aiohttp import web

    note = "That is not the token of this view." if wrong else "This view asks for the token it printed at start."
    page = (f"<!doctype html><html><head><meta charset=utf-8><title>LunarSim: token</title></head><body>"
            f"<h1>LunarSim view</h1><p>{html.escape(note)}</p><form method=get>"
            f"<input name=token type=password autocomplete=off placeholder=token autofocus> "
            f"<button>Open</button></form></body></html>")
    return web.Response(status=401, text=page, content_type="text/html", headers={
        "Content-Security-Policy": "default-src 'none'; form-action 'self'; frame-ancestors 'none'"})


def _json(status: int, message: str) -> web.Response:
    from aiohttp import web

    return web.json_response({"ok": False, "error": message}, status=status)


def _clip(text: str) -> str:
    return text if len(text) <= ECHO_CHARS else text[:ECHO_CHARS] + "..."


def middleware(access: Access) -> Callable:
    """The aiohttp middleware applying ``refusal``; every answer also forbids framing by other sites."""
    from aiohttp import web

    @web.middleware
    async def guard(request: web.Request, handler: Callable[[web.Request], Awaitable[web.StreamResponse]]
                    ) -> web.StreamResponse:
        response = refusal(request, access)
        if response is None:
            response = await handler(request)
        if not response.prepared:  # a WebSocket answer is already sent
            response.headers.setdefault("X-Frame-Options", "DENY")
        return response

    return guard
