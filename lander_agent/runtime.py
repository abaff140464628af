"""The lander's Zenoh loop: subscribe to its keys, hand each sample to the ``Lander``, publish what it returns."""

from __future__ import annotations

import logging
import threading

from bus.bus import Bus
from bus.process import freeze_start_up_heap
from bus.world_watch import ClockWatch
from lander_agent.lander import Lander

log = logging.getLogger("lunarsim.lander")


def run(lander: Lander, bus: Bus, stop: threading.Event) -> None:
    keys = lander.keys
    for key in lander.handlers:
        bus.subscribe(key)
    bus.declare_token(keys.alive_lander)
    watch = ClockWatch("lander", keys.clock)
    log.info("lander: started on %s with %d goal(s) for %d rover(s), waiting for the world's clock", keys.prefix,
             len(lander.plan.scenario.mission), len(lander.plan.scenario.rovers))
    freeze_start_up_heap()
    while not stop.is_set():
        item = bus.receive(timeout=0.2)
        watch.check()
        if item is not None:
            if item.key == keys.clock:
                watch.heard()
            for key, message in lander.handle(item.key, item.payload):
                bus.publish(key, message)
            lander.catch_up()
    for key, message in lander.final_map():  # stopped before the world finished: the map as it stands
        bus.publish(key, message)
    log.info("lander: stopping at t = %.1f s; refused %d sample(s)", lander.now, lander.rejected.total)
