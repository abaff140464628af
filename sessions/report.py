"""Mission statistics from a recording alone: its world states and ground commands through the same
``MissionStats`` the live world uses, and its last ``lander/map`` through the same map scoring as the launcher,
so the result equals the run's ``report.json`` (wall time aside)."""

from __future__ import annotations

from collections import Counter
from collections.abc import Iterable

import msgspec

from schemas import codec
from schemas import keyspace as ks
from schemas import messages as m
from schemas.errors import LunarSimError
from schemas.scenario import Scenario
from sessions.format import Sample
from shared.mission import RoverMissions
from world_service.outcome.statistics import MissionStats


class NothingToReport(LunarSimError, ValueError):
    """The recording holds no world state of the world asked for."""


def report_from_samples(scenario: Scenario, samples: Iterable[Sample], world: str,
                        malformed: Counter[str] | None = None) -> m.MissionReport:
    """The statistics; a sample that does not decode is skipped and counted per key in ``malformed``, as the world
    and the viewers skip one, and so is a last map that is not the grid this scenario's lander builds."""
    keys = ks.Keyspace(world)
    stats = MissionStats(scenario, RoverMissions(scenario))
    skipped: Counter[str] = Counter() if malformed is None else malformed
    last_map: bytes | None = None
    for sample in samples:
        try:
            if sample.key == keys.lander(ks.MAP):
                last_map = sample.payload
            elif sample.key == keys.state:
                stats.observe(codec.decode(m.WorldState, sample.payload))
            elif sample.key == keys.ground_command:
                stats.command(codec.decode(m.GroundCommand, sample.payload))
        except codec.DecodeError:
            skipped[sample.key] += 1
    if stats.last is None:
        raise NothingToReport(f"no {keys.state} samples: nothing to compute statistics from")
    report = stats.report()  # wall_time_s stays None: the launcher's stopwatch is not in the world's data
    if last_map is None:
        return report
    try:
        figures = _map_figures(scenario, last_map)
    except (codec.DecodeError, ValueError):
        skipped[keys.lander(ks.MAP)] += 1
        return report
    return codec.checked(msgspec.structs.replace(report, **figures))


def _map_figures(scenario: Scenario, payload: bytes) -> dict:
    """A recorded ``lander/map`` scored as the launcher scores ``map.npz``. Only the grid the scenario's lander
    builds is unpacked: scoring takes several times the grid's size in memory, and a sample on the lander's key
    may claim a billion cells."""
    from lander_agent import mapping
    from world_service.outcome.map_truth import map_figures

    msg = codec.decode(m.LanderMap, payload)
    spec = mapping.GridSpec.for_scenario(scenario, scenario.rover_params.mapping.cell_m)
    if (msg.origin_x, msg.origin_z, msg.cell_m, msg.width, msg.height) != (
            spec.origin_x, spec.origin_z, spec.cell_m, spec.width, spec.height):
        raise ValueError(f"lander map: a {msg.width} x {msg.height} grid, not this scenario's")
    _, classes = mapping.from_message(msg)
    return map_figures(scenario, spec, classes).report_fields()
