"""The view's Zenoh session, opened on a thread of its own so the page is served before any router is reachable.

``lunarsim view`` is often started first (the editor alone, or to watch a run not yet begun), and a world started
by ``lunarsim run`` is the run's router: until it comes there is nothing to connect to, and the view must not
listen on the router's port itself. Zenoh opens a client session only once a router answers (with
``connect/timeout_ms: -1`` the open itself blocks until then), so the opening is retried here, on a thread, and the
subscriptions are declared when it succeeds. Once open, a client session reconnects by itself when its router
goes and another comes on the same endpoint, and its subscriptions carry over; this thread then only watches
whether a router is there, for the page's header.
"""

from __future__ import annotations

import contextlib
import threading
from collections.abc import Callable

import zenoh

from bus.errors import RouterUnreachable
from bus.zenoh_config import open_session
from web.live import Source

WATCH_S = 0.25
"""How often the link looks whether its router is still there (a local look-up, no traffic)."""
JOIN_S = 5.0
"""How long closing waits for an attempt to open under way (a TCP connect to an address that never answers)."""


class RouterLink:
    """Opens the session (``start``), keeps ``source.connected`` true while a router is reachable, publishes
    (``put``) while open, and says when it gave up (``when_failed``) after ``timeout_s`` without a router."""

    def __init__(self, conf: zenoh.Config, source: Source, timeout_s: float | None, who: str = "lunarsim view") -> None:
        self.conf, self.source, self.timeout_s, self.who = conf, source, timeout_s, who
        self.session: zenoh.Session | None = None
        self.failure: RouterUnreachable | None = None
        self._declared: list = []
        self._stop = threading.Event()
        self._lock = threading.Lock()
        self._on_fail: Callable[[], None] | None = None
        self._thread: threading.Thread | None = None

    def start(self, declare: Callable[[zenoh.Session], list]) -> None:
        """Open on a thread; ``declare(session)`` makes the subscriptions (returns them, to undeclare on close)."""
        self._thread = threading.Thread(target=self._run, args=(declare,), name="view-router-link", daemon=True)
        self._thread.start()

    def when_failed(self, callback: Callable[[], None]) -> None:
        """``callback`` runs (on the link's thread, or now if it already failed) when no router came in time."""
        with self._lock:
            self._on_fail = callback
            failed = self.failure is not None
        if failed:
            callback()

    def put(self, key: str, payload: bytes) -> bool:
        """Publish if open; False while the view still waits for its first router."""
        session = self.session
        if session is None:
            return False
        with contextlib.suppress(zenoh.ZError):  # closing under way
            session.put(key, payload)
            return True
        return False

    def raise_failure(self) -> None:
        if self.failure is not None:
            raise self.failure

    def close(self) -> None:
        self._stop.set()
        if self._thread is not None:
            self._thread.join(JOIN_S)
        with self._lock:
            session, self.session = self.session, None
            declared, self._declared = self._declared, []
        for entity in declared:
            with contextlib.suppress(zenoh.ZError):
                entity.undeclare()
        if session is not None:
            session.close()

    def _run(self, declare: Callable[[zenoh.Session], list]) -> None:
        try:
            session = open_session(self.conf, self.source.where, self.timeout_s, self.who, remind_s=None,
                                   stop=self._stop)
        except RouterUnreachable as exc:
            if not self._stop.is_set():
                self._fail(exc)
            return
        with self._lock:
            if self._stop.is_set():
                session.close()
                return
            self._declared = declare(session)
            self.session = session
        self._watch(session)

    def _watch(self, session: zenoh.Session) -> None:
        while True:
            with contextlib.suppress(zenoh.ZError):  # a session being closed
                self.source.set_connected(bool(list(session.info.routers_zid()) or list(session.info.peers_zid())))
            if self._stop.wait(WATCH_S):
                return

    def _fail(self, exc: RouterUnreachable) -> None:
        with self._lock:
            self.failure = exc
            callback = self._on_fail
        if callback is not None:
            callback()
