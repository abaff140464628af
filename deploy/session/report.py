"""Mission statistics from a recording alone: its world states and ground commands through the same
``MissionStats`` the live world uses, so the result equals the run's ``report.json`` (wall time aside)."""

from __future__ import annotations

from collections.abc import Iterable

from deploy.session.format import Sample
from schemas import codec
from schemas import keyspace as ks
from schemas import messages as m
from schemas.mission import RoverMissions
from schemas.scenario import Scenario
from world_service.statistics import MissionStats


class NothingToReport(ValueError):
    """The recording holds no world state of the world asked for."""


def report_from_samples(scenario: Scenario, samples: Iterable[Sample], world: str) -> m.MissionReport:
    keys = ks.Keyspace(world)
    stats = MissionStats(scenario, RoverMissions(scenario))
    for sample in samples:
        if sample.key == keys.state:
            stats.observe(codec.decode(m.WorldState, sample.payload))
        elif sample.key == keys.ground_command:
            try:
                stats.command(codec.decode(m.GroundCommand, sample.payload))
            except codec.DecodeError:
                continue  # the world ignored it too
    if stats.last is None:
        raise NothingToReport(f"no {keys.state} samples: nothing to compute statistics from")
    return stats.report()  # wall_time_s stays 0: the launcher's stopwatch is not in the world's data
