"""What the agent publishes: each sample as a (key, message) pair (``schemas.messages.Out``), addressed to one
rover's own topics.

The agent's parts return these pairs rather than publish them; the Zenoh loop (``runtime``) or the in-process
harness moves them, so every part runs in tests without a router.
"""

from __future__ import annotations

from dataclasses import dataclass

from schemas import keyspace as ks
from schemas import messages as m
from schemas import radio
from schemas.messages import Out


@dataclass(frozen=True)
class Sender:
    """Addresses the samples of one rover: its own keys, and radio messages through its ``comm_out``."""

    keys: ks.Keyspace
    rover_id: int

    def key(self, topic: str) -> str:
        return self.keys.rover(self.rover_id, topic)

    def radio(self, targets: list[int], message: m.Message) -> Out:
        return self.key(ks.COMM_OUT), m.OutboundComm(targets=targets, payload=radio.pack(message))
