"""A second observer of the scale benchmark, in its own process with its own Zenoh session.

The benchmark's own subscriber finds gaps in the sampled rovers' sensor stamps, but a gap may come from the
router's queue towards that one subscriber. This process subscribes to the same keys through the same router
and, when stopped (SIGTERM or SIGINT), writes what it received as JSON. A sample missing at both is lost before
the router's per-subscriber queues (the world's own send queue, or the router taking it in), so the rover agents
lose it too; one missing at only one of them was lost on the way to that subscriber.

    python benchmarks/scale_witness.py ENDPOINT WORLD OUT.json ID [ID ...]
"""

from __future__ import annotations

import json
import os
import sys
from pathlib import Path

from scale_observe import ClockMark, Observer, Reading, no_collector_pauses

from bus import process
from bus.zenoh_config import build_config, open_session
from schemas.keyspace import Keyspace


def main(argv: list[str]) -> int:
    endpoint, world, out, *ids = argv
    parent = os.getppid()
    session = open_session(build_config(connect=[endpoint]), endpoint, 10.0, who="scale witness")
    with process.stop_on_signals() as stop, no_collector_pauses():
        observer = Observer(session, Keyspace(world), [int(i) for i in ids])
        print("witness ready", flush=True)
        while not stop.is_set() and os.getppid() == parent:  # a benchmark killed outright leaves no witness behind
            observer.pump(0.2)
        observer.close()
    session.close()
    Path(out).write_text(json.dumps({"readings": observer.readings, "ticks": observer.ticks}))
    return 0


def load(path: Path) -> tuple[list[Reading], list[ClockMark]]:
    doc = json.loads(path.read_text())
    return [Reading(*r) for r in doc["readings"]], [ClockMark(*t) for t in doc["ticks"]]


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
