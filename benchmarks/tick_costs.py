"""Where a lockstep run's wall time goes in one process: each part's own time (what it spent minus what the parts it
called spent), by wrapping the functions that mark the parts for the length of a run.

The wrapped functions are the seams between the parts (the world's step and its sensors, the camera, the codec,
the agents' estimator, planner and map, the lander), so the split costs one ``perf_counter`` pair a call, a few
percent of a run. What no part claims is the in-process harness routing the samples. Time spent inside an agent's
handling of a perception is also kept apart, per perception, for the agent's own figure.
"""

from __future__ import annotations

import time
from collections import Counter
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from dataclasses import dataclass, field
from functools import wraps
from importlib import import_module

PARTS: tuple[tuple[str, str, str, str], ...] = (
    ("world: step (actuation, radio, statuses, state)", "world_service.sim", "World", "step"),
    ("world: perception rays", "world_service.sensors.perception", "Perceiver", "scans"),
    ("world: gyroscopes (terrain pitch)", "world_service.sensors.readings", "Sensors", "_gyroscopes"),
    ("world: taking the agents' answers", "world_service.sim", "World", "receive"),
    ("camera: rendering photos", "world_service.sim", "World", "render"),
    ("codec: decode (msgpack + validation)", "schemas.codec", "", "decode"),
    ("codec: encode", "schemas.codec", "", "encode"),
    ("agents: estimator", "rover_agent.estimation.estimator", "Estimator", "localise"),
    ("agents: estimator", "rover_agent.estimation.estimator", "Estimator", "heard"),
    ("agents: estimator", "rover_agent.estimation.estimator", "Estimator", "share"),
    ("agents: planner (behaviour)", "rover_agent.behaviour", "DefaultBehaviour", "decide"),
    ("agents: planner (behaviour)", "rover_agent.behaviour", "DefaultBehaviour", "should_cancel"),
    ("agents: traverse map", "rover_agent.mission.traverse_map", "MapRecorder", "fold_scan"),
    ("agents: the rest of their handlers", "rover_agent.agent", "RoverAgent", "handle"),
    ("agents: the rest of their handlers", "rover_agent.agent", "RoverAgent", "on_clock"),
    ("lander", "lander_agent.runtime", "Lander", "handle"),
)
"""(part, module, class or "" for a module function, function): the seams timed."""
HARNESS = "harness: routing samples between them"


@dataclass
class Tally:
    """Own time per part, and, inside the agents' handling of perceptions, per part per perception."""

    own: Counter[str] = field(default_factory=Counter)
    perception: Counter[str] = field(default_factory=Counter)
    perceptions: int = 0
    _stack: list[list] = field(default_factory=list)  # [part, start, time of the calls below]
    _in_perception: int = 0

    def timed(self, part: str, function: Callable) -> Callable:
        @wraps(function)
        def call(*args, **kwargs):
            perception = function.__name__ == "handle" and part.startswith("agents") and args[1] == "perception"
            self._in_perception += perception
            frame = [part, time.perf_counter(), 0.0]
            self._stack.append(frame)
            try:
                return function(*args, **kwargs)
            finally:
                spent = time.perf_counter() - frame[1]
                self._stack.pop()
                self.own[part] += spent - frame[2]
                if self._in_perception:
                    self.perception[part] += spent - frame[2]
                if self._stack:
                    self._stack[-1][2] += spent
                if perception:
                    self._in_perception -= 1
                    self.perceptions += 1

        return call

    def shares(self, wall_s: float) -> list[tuple[str, float, float]]:
        """(part, seconds, share of ``wall_s``), the largest first, the harness taking what no part claimed."""
        rows = dict(self.own)
        rows[HARNESS] = max(0.0, wall_s - sum(self.own.values()))
        return [(part, s, s / wall_s) for part, s in sorted(rows.items(), key=lambda r: -r[1])]


@contextmanager
def attributed() -> Iterator[Tally]:
    """Every seam of ``PARTS`` timed into one ``Tally`` until the block ends; the functions are restored after."""
    tally = Tally()
    undo: list[tuple[object, str, object]] = []
    try:
        for part, module_name, class_name, name in PARTS:
            module = import_module(module_name)
            owner = getattr(module, class_name) if class_name else module
            original = owner.__dict__[name] if class_name else getattr(module, name)
            undo.append((owner, name, original))
            setattr(owner, name, tally.timed(part, original))
        yield tally
    finally:
        for owner, name, original in reversed(undo):
            setattr(owner, name, original)
