"""The world's saved state: what a world service killed mid-mission resumes from, so a restart never fakes a result.

The world is the only process that knows ground truth. Started again without it, it would begin a new run with every
rover at its start while the agents, still running, go on from where they were, and the report would count them done
at places the world does not hold. So the service saves the whole world (``bus.snapshot``: bodies, action ledger,
random generators, statistics, run id) every ``service.SAVE_PERIOD_S`` simulated seconds, and a world started with the
same scenario and state file carries on the same run from there: the same run id, so agents go on as they were, and
rovers at most ``service.SAVE_PERIOD_S`` of motion back (their agents' estimates absorb that like slip). ``report.json``
counts the resumes.

Only a world that did not end in order (killed, or its machine lost) leaves a state: one that ends its mission, or is
stopped with Ctrl-C or SIGTERM, removes it, and is started again as a new run. A state that this code cannot carry on
(saved by a version whose parts held other attributes) is refused, said why, and the run begins anew.
"""

from __future__ import annotations

import contextlib
import copy
import logging
from collections.abc import Iterator
from pathlib import Path

from bus import snapshot
from schemas.scenario import Scenario
from world_service.sim import World

log = logging.getLogger("lunarsim.world")


def load(path: Path, scenario: Scenario) -> World | None:
    """The world saved in ``path`` if it is this scenario's, works with this code and its mission is not over; None,
    said why, if not."""
    world = snapshot.load(path, log)
    if world is None:
        return None
    if not isinstance(world, World):
        log.warning("not resuming from %s: it holds no world", path)
        return None
    if (problem := unworkable(world)) is not None:
        log.warning("not resuming from %s: the world saved there does not work with this version of the code (%s)",
                    path, problem)
        return None
    if world.scenario != scenario:
        log.warning("not resuming from %s: it is a run of another scenario or seed (%s, seed %d)", path,
                    world.scenario.name, world.scenario.seed)
        return None
    if world.complete:
        log.info("not resuming from %s: its mission is over", path)
        return None
    world.resumed()
    return world


def unworkable(world: World) -> str | None:
    """Why ``world`` cannot go on with this code, or None: a copy of it steps once and states its truth and report,
    which touches every part. A world pickled by another version unpickles whole however its parts have changed;
    this finds out before the run depends on it."""
    trial = copy.deepcopy(world)
    try:
        with _quiet():
            trial.step()
            trial.observed_state()
            trial.report()
    except Exception as exc:  # whatever an old state breaks, it must not end the service
        return f"{type(exc).__name__}: {exc}"
    return None


@contextlib.contextmanager
def _quiet() -> Iterator[None]:
    """The trial's own story (a rover shut down, counted stuck) is not the run's: nothing of it is logged."""
    was, log.disabled = log.disabled, True
    try:
        yield
    finally:
        log.disabled = was
