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
    and the viewers skip one."""
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
    return report if last_map is None else _with_map_figures(report, scenario, last_map)


def _with_map_figures(report: m.MissionReport, scenario: Scenario, payload: bytes) -> m.MissionReport:
    """The last recorded ``lander/map`` scored as the launcher scores ``map.npz`` (a bad sample is skipped)."""
    from lander_agent import mapping
    from world_service.outcome.map_truth import map_figures

    try:
        spec, classes = mapping.from_message(codec.decode(m.LanderMap, payload))
    except (codec.DecodeError, ValueError):
        return report
    return codec.checked(msgspec.structs.replace(report, **map_figures(scenario, spec, classes).report_fields()))
