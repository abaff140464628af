"""Fault injection: which of the samples a bus publishes a lossy link drops (``Bus(loss=...)``, ``lunarsim run
--fault-loss``)."""

from __future__ import annotations

import hashlib
from collections import OrderedDict

MAX_SHARE = 0.5
"""The most a run may lose (``--fault-loss``): past half, a link is down rather than lossy, and a mission's final
report, sent again each second, waited minutes for a send that went through (at 0.99)."""
HISTORY = 16
"""Payloads remembered per key. A sample sent again (a clock, an action's end, a final report) draws anew each
time only while it is remembered; one resent after this many other payloads on its key would draw as it did
the first time. The world resends well within it (the same clock over and over; a rover's unheard action ends
in turn, each second), and a world of 1,000 rovers publishes on 13,000 keys: about 40 MB at 16."""


class SeededLoss:
    """Drops a ``share`` of samples, each decided by the seed, its key, its payload and how many times that
    payload has gone out on that key: not by the order or the timing of the other samples.

    A lockstep world sends a tick's clock again while acks are missing, after waits measured in wall time, so how
    many clocks go out varies from run to run. Drawn from one stream, every resend would shift the fate of every
    later sample, and the same seed would lose different samples each run; decided sample by sample, a lockstep
    run with losses is as reproducible as one without. Each send of the same payload draws anew, as on a real
    link, so no sample is lost for good, and a resend that was not needed changes nothing else.
    """

    def __init__(self, share: float, seed: int) -> None:
        self.share = share
        self._seed = seed.to_bytes(16, "little", signed=True)
        self._sent: dict[str, OrderedDict[bytes, int]] = {}  # key -> payload digest -> sends before this one

    def drops(self, key: str, payload: bytes) -> bool:
        digest = hashlib.blake2b(payload, digest_size=16).digest()
        history = self._sent.setdefault(key, OrderedDict())
        sends = history.pop(digest, -1) + 1
        history[digest] = sends
        if len(history) > HISTORY:
            history.popitem(last=False)
        draw = hashlib.blake2b(key.encode() + digest + sends.to_bytes(8, "little"), digest_size=8, key=self._seed)
        return int.from_bytes(draw.digest(), "little") < self.share * 2.0**64
