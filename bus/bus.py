"""One process's view of Zenoh: cached publishers, and subscriptions that feed a single inbox.

Callbacks only enqueue (no decoding, no Zenoh calls), as the zenoh-python examples advise; the
process's own loop drains the inbox. They run directly on Zenoh's receiving thread
(``Callback(indirect=False)``): by default each subscriber gets its own Python thread, and samples of
different keys then reach the inbox out of order (a perception overtaking the navigation status sent
before it), which costs the agent a perception period. Kept light: the rover agent uses it.
"""

from __future__ import annotations

import ctypes
import logging
import queue
import threading
from collections import Counter
from collections.abc import Callable, Iterable
from typing import TYPE_CHECKING, NamedTuple

import zenoh

from bus.loss import SeededLoss
from schemas import codec
from schemas import keyspace as ks

if TYPE_CHECKING:
    from bus.process import Stop

_ATTACHED: set[int] = set()
log = logging.getLogger("lunarsim.bus")
PER_KEY_LIMIT = 64
"""Samples of one key waiting in an inbox. No legitimate publisher comes near it (the fastest key is 20 Hz and the
world drains its inbox 20 times a second); a flooding one is cut off here, counted, and cannot fill the memory."""
TOTAL_LIMIT = 50_000
"""Samples of all keys waiting in an inbox: against a flood spread over forged keys."""
BYTES_LIMIT = 256 * 2**20
"""Payload bytes waiting in an inbox: against a flood of large samples (a photo may be tens of MB, and fifty
thousand of them would not fit any machine). A legitimate backlog is a few ticks of a thousand rovers' traffic."""


def zenoh_callback(function: Callable[[zenoh.Sample], None]) -> zenoh.handlers.Callback:
    """A handler that runs ``function`` directly on Zenoh's receiving thread (``indirect=False``), keeping that
    thread's Python thread state from one sample to the next.

    Zenoh's threads are not Python's: pyo3 makes a thread state for each callback and drops it after, which
    costs a gettid, an mmap and an munmap per sample; the munmap shoots down the TLB of every other CPU the
    process runs on (an interrupt to each, and in a VM a trap to the host). One ``PyGILState_Ensure``, never
    released, keeps the state alive, as CPython's own threads keep theirs. Measured: 15-20 % faster lockstep.
    """

    def call(sample: zenoh.Sample) -> None:
        thread = threading.get_ident()
        if thread not in _ATTACHED:
            ctypes.pythonapi.PyGILState_Ensure()
            _ATTACHED.add(thread)
        function(sample)

    return zenoh.handlers.Callback(call, indirect=False)


class Received(NamedTuple):
    key: str
    payload: bytes
    alive: bool | None = None  # set for liveliness changes, None for data samples


_WAKE = Received("", b"")
"""Put by ``Inbox.wake``: ``get`` takes it as a timeout come early."""


class Inbox:
    """What a process has received and not yet handled: in arrival order, bounded per key and in all.

    Excess is dropped on arrival and counted per topic (the key's last segment: forged rover ids must not grow the
    table), so a client publishing as fast as it can costs the process the callback, never memory or a backlog.
    """

    def __init__(self, per_key: int = PER_KEY_LIMIT, total: int = TOTAL_LIMIT, max_bytes: int = BYTES_LIMIT) -> None:
        self.per_key, self.total, self.max_bytes = per_key, total, max_bytes
        self._bytes = 0
        self.dropped: Counter[str] = Counter()
        self._queue: queue.SimpleQueue[Received] = queue.SimpleQueue()
        self._pending: dict[str, int] = {}
        self._size = 0
        self._lock = threading.Lock()

    def put(self, item: Received) -> None:
        key = item.key
        with self._lock:
            n = self._pending.get(key, 0)
            size = len(item.payload)
            if n >= self.per_key or self._size >= self.total or self._bytes + size > self.max_bytes:
                self._drop(key)
                return
            self._pending[key] = n + 1
            self._size += 1
            self._bytes += size
        self._queue.put(item)

    def _drop(self, key: str) -> None:
        topic = key.rsplit("/", 1)[-1]
        self.dropped[topic] += 1
        if self.dropped[topic] in (1, 10, 100) or self.dropped[topic] % 100_000 == 0:
            log.warning("inbox full for %s: dropped %d sample(s) of %s so far (a publisher floods it)", key,
                        self.dropped[topic], topic)

    def wake(self) -> None:
        """End a ``get`` waiting now, or the next one, at once (as if its timeout had passed). Safe in a signal
        handler, as ``SimpleQueue.put`` is."""
        self._queue.put(_WAKE)

    def get(self, timeout: float | None) -> Received:
        """Raises ``queue.Empty`` as ``SimpleQueue.get`` does, and when woken."""
        item = self._queue.get(timeout=timeout) if timeout is None or timeout > 0 else self._queue.get_nowait()
        if item is _WAKE:
            raise queue.Empty
        with self._lock:
            n = self._pending[item.key] - 1
            if n:
                self._pending[item.key] = n
            else:
                del self._pending[item.key]
            self._size -= 1
            self._bytes -= len(item.payload)
        return item

    def get_nowait(self) -> Received:
        return self.get(0)

    def qsize(self) -> int:
        return self._size


class Bus:
    def __init__(self, session: zenoh.Session, lossless: bool = False, declare_publishers: bool = True,
                 loss: float = 0.0, loss_seed: int = 0, per_key_limit: int = PER_KEY_LIMIT) -> None:
        """``lossless``: publications wait for a congested link instead of being dropped (Zenoh's default for
        puts), for a replay, which must deliver the whole recording, and a lockstep world, whose agents must
        see every sample. In real time the fresh sample beats the one held back, so the default drops.

        ``declare_publishers=False``: put through the session, for the world, which publishes on thousands of
        rovers' keys. As the router, declaring a publisher costs in proportion to every subscription in the network
        (1 ms each with a thousand rovers' 13,000), while a put without one costs microseconds; as a client, each
        publisher brings the subscriptions that match it into the session, and Zenoh matches every sample the
        session receives against all of them (``Resource::get_matches``: 0.2 of a core at a thousand rovers, on
        the threads that hand samples to Python).

        ``loss``: fault injection for tests and the chaos benchmark: this share of the samples this bus publishes
        is dropped as a bad link would (``loss.SeededLoss``, seeded by ``loss_seed``) and counted in ``lost``."""
        self.session = session
        self._declare = declare_publishers
        self.inbox = Inbox(per_key_limit)
        self.loss, self.lost = loss, 0
        self._losing = SeededLoss(loss, loss_seed) if loss else None
        self._publishers: dict[str, zenoh.Publisher] = {}
        self._declared: list = []
        self._congestion = zenoh.CongestionControl.BLOCK if lossless else zenoh.CongestionControl.DROP
        self._direct: Callable[[Received], None] | None = None

    def handle_directly(self, handler: Callable[[Received], None]) -> None:
        """Hand every sample to ``handler`` on Zenoh's receiving thread as it arrives, instead of to the inbox; set
        before subscribing. For a process whose own loop would only pass each sample on (a rover agent): the
        handoff to that loop is a thread wake-up a sample, about half of what the agent adds to a control loop and
        most of what a lockstep tick costs it. Samples of one session still arrive in order, on one thread; the
        handler publishes from it, and never waits for anything but a congested link."""
        self._direct = handler

    def wake_on(self, stop: Stop) -> None:
        """``receive`` returns None as soon as ``stop`` is set, rather than at the end of its timeout."""
        stop.also_wake(self.inbox.wake)

    def subscribe(self, key_expr: str) -> None:
        self._declared.append(self.session.declare_subscriber(key_expr, zenoh_callback(self._on_sample)))

    def watch_liveliness(self, key_expr: str) -> None:
        """Liveliness changes arrive in the inbox with ``alive`` set; tokens already there are reported too."""
        sub = self.session.liveliness().declare_subscriber(key_expr, zenoh_callback(self._on_liveliness), history=True)
        self._declared.append(sub)

    def serve(self, key_expr: str, answer: Callable[[bytes], bytes]) -> None:
        """Answer queries on ``key_expr``. ``answer`` runs on Zenoh's thread: it must be quick and thread-safe."""

        def _on_query(query: zenoh.Query) -> None:
            request = query.payload.to_bytes() if query.payload is not None else b""
            query.reply(query.key_expr, answer(request))

        self._declared.append(self.session.declare_queryable(key_expr, _on_query))

    def declare_token(self, key: str) -> None:
        self._declared.append(self.session.liveliness().declare_token(key))

    def _on_sample(self, sample: zenoh.Sample) -> None:
        item = Received(str(sample.key_expr), sample.payload.to_bytes())
        if self._direct is not None:
            self._direct(item)
        else:
            self.inbox.put(item)

    def _on_liveliness(self, sample: zenoh.Sample) -> None:
        self.inbox.put(Received(str(sample.key_expr), b"", sample.kind == zenoh.SampleKind.PUT))

    def publish(self, key: str, message) -> None:
        self.put(key, codec.encode(message))

    def put(self, key: str, payload: bytes) -> None:
        if self._losing is not None and self._losing.drops(key, payload):
            self.lost += 1
            return
        if not self._declare:
            self.session.put(key, payload, congestion_control=self._congestion_for(key),
                             timestamp=self.session.new_timestamp())
            return
        publisher = self._publishers.get(key) or self._declare_publisher(key)
        publisher.put(payload, timestamp=self.session.new_timestamp())  # the recorder keeps it (0.3 us)

    def declare_publishers(self, keys: Iterable[str]) -> None:
        """Declare now the publishers ``put`` will use for ``keys`` (nothing to do for a bus that puts undeclared).
        A process that knows its keys declares them before the clock starts (``keyspace.ROVER_OUTPUTS`` says why)
        rather than on a sample's way out."""
        if self._declare:
            for key in keys:
                if key not in self._publishers:
                    self._declare_publisher(key)

    def _declare_publisher(self, key: str) -> zenoh.Publisher:
        congestion = self._congestion_for(key)
        publisher = self._publishers[key] = self.session.declare_publisher(key, congestion_control=congestion)
        return publisher

    def _congestion_for(self, key: str) -> zenoh.CongestionControl:
        """Radio traffic waits out congestion rather than be dropped unseen (``keyspace.RADIO_TOPICS``)."""
        if key.rsplit("/", 1)[-1] in ks.RADIO_TOPICS:
            return zenoh.CongestionControl.BLOCK
        return self._congestion

    def receive(self, timeout: float | None) -> Received | None:
        try:
            return self.inbox.get(timeout=timeout) if timeout is None or timeout > 0 else self.inbox.get_nowait()
        except queue.Empty:
            return None

    def drain(self) -> list[Received]:
        items = []
        while True:
            try:
                items.append(self.inbox.get_nowait())
            except queue.Empty:
                return items

    def close(self) -> None:
        for entity in reversed(self._declared):
            entity.undeclare()
        for publisher in self._publishers.values():
            publisher.undeclare()
        self._declared.clear()
        self._publishers.clear()
        self.session.close()

    def __enter__(self) -> Bus:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()
