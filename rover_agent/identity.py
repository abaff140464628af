"""Which rover an agent drives: a number given on the command line (or in ``LUNARSIM_ROVER_ID``), the ordinal
of a Kubernetes StatefulSet pod (``rover-0`` drives rover 1), or an id the world service hands out
(``auto``, for containers scaled with ``docker compose --scale rover=N``, which have no ordinal)."""

from __future__ import annotations

import logging
import re
import socket
import sys
import threading

import zenoh

from bus.process import UsageError
from schemas import codec
from schemas import messages as m
from schemas.keyspace import Keyspace
from schemas.scenario_limits import MAX_ROVERS, clip

log = logging.getLogger("lunarsim.rover")
ID_MODES = ("auto", "ordinal")
ASK_PERIOD_S = 2.0
_ORDINAL = re.compile(r"-(\d+)$")


def parse_id(text: str) -> int | str:
    """``--id`` as given: a rover id from 1, or one of ``ID_MODES``."""
    text = text.strip()
    if text in ID_MODES:
        return text
    if text.isascii() and text.isdigit() and 1 <= int(text) <= MAX_ROVERS:
        return int(text)
    raise ValueError(f"rover id must be a number from 1 to {MAX_ROVERS}, 'auto' or 'ordinal'; got {clip(text, 40)!r}")


MAX_AGENTS_PER_PROCESS = 1000


def parse_ids(text: str) -> list[int]:
    """``--ids``: rover ids and ranges, ``1-250`` or ``1,3,7-9``; each id once, from 1."""
    ids: list[int] = []
    shown = repr(clip(text, 40))
    for part in text.split(","):
        first, dash, last = part.strip().partition("-")
        try:
            low = int(first)
            high = int(last) if dash else low
        except ValueError:
            raise ValueError(f"--ids {shown}: {clip(part.strip(), 40)!r} is not an id or a range like 1-250") from None
        if low < 1 or high < low or high > MAX_ROVERS:
            raise ValueError(f"--ids {shown}: {clip(part.strip(), 40)!r} must be ids from 1 to "
                             f"{MAX_ROVERS}, low-high with low <= high")
        ids.extend(range(low, high + 1))
    if len(set(ids)) != len(ids):
        raise ValueError(f"--ids {shown} names some rover twice")
    if len(ids) > MAX_AGENTS_PER_PROCESS:
        raise ValueError(f"--ids {shown} names {len(ids)} rovers; one process runs at most {MAX_AGENTS_PER_PROCESS}")
    return ids


def id_from_hostname(hostname: str | None = None) -> int:
    """StatefulSet pods are named ``<set>-<ordinal>`` from 0; rovers are numbered from 1 as in the report."""
    hostname = hostname or socket.gethostname()
    found = _ORDINAL.search(hostname.split(".")[0])
    if found is None:
        raise ValueError(f"--id ordinal needs a host name ending in -<number> (a StatefulSet pod), got {hostname!r}")
    return int(found.group(1)) + 1


def ask_world(session: zenoh.Session, keys: Keyspace, stop: threading.Event) -> int | None:
    """Ask the world service for a free rover id, waiting (and saying so) until one answers; None if stopped."""
    requester = str(session.info.zid())
    waited = False
    while not stop.is_set():
        for reply in session.get(keys.rover_ids, payload=requester.encode(), timeout=ASK_PERIOD_S):
            if reply.ok is None:
                continue
            try:
                grant = codec.decode(m.RoverIdGrant, reply.ok.payload.to_bytes())
            except codec.DecodeError as exc:
                log.warning("rejected rover id grant: %s", exc)
                continue
            if grant.id is not None:
                return grant.id
            raise UsageError(f"the world service has no rover id left: {grant.detail}")
        if not waited:
            print(f"rover (id auto): waiting for the world service to hand out a rover id on {keys.rover_ids}",
                  file=sys.stderr, flush=True)
            waited = True
    return None
