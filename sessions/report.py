"""Mission statistics from a recording alone: its world states and ground commands through the same
``MissionStats`` the live world uses, and its last ``lander/map`` through the same map scoring as the launcher,
so the result equals the run's ``report.json`` (wall time aside)."""

from __future__ import annotations

from collections import Counter
from collections.abc import Iterable

import msgspec

from lander_agent import mapping
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
    and the viewers skip one, and so is a state naming a rover the scenario does not have, or a map that is not
    the grid this scenario's lander builds."""
    keys = ks.Keyspace(world)
    stats = MissionStats(scenario, RoverMissions(scenario))
    skipped: Counter[str] = Counter() if malformed is None else malformed
    grid = mapping.GridSpec.for_scenario(scenario, scenario.rover_params.mapping.cell_m)
    last_map: m.LanderMap | None = None
    for sample in samples:
        try:
            if sample.key == keys.lander(ks.MAP):
                last_map = _scenario_map(codec.decode(m.LanderMap, sample.payload), grid)
            elif sample.key == keys.state:
                stats.observe(_of_scenario(codec.decode(m.WorldState, sample.payload), len(scenario.rovers)))
            elif sample.key == keys.ground_command:
                stats.command(codec.decode(m.GroundCommand, sample.payload))
        except (codec.DecodeError, _NotThisScenario):
            skipped[sample.key] += 1
    if stats.last is None:
        why = f" ({skipped[keys.state]} skipped: malformed, or of another scenario)" if skipped[keys.state] else ""
        raise NothingToReport(f"no {keys.state} samples{why}: nothing to compute statistics from")
    report = stats.report()  # wall_time_s stays None: the launcher's stopwatch is not in the world's data
    fields = _map_fields(scenario, grid, last_map) if last_map is not None else {}
    if fields is None:
        skipped[keys.lander(ks.MAP)] += 1
    return codec.checked(msgspec.structs.replace(report, **fields)) if fields else report


def _map_fields(scenario: Scenario, grid: mapping.GridSpec, msg: m.LanderMap) -> dict | None:
    """The map's scores as the launcher scores ``map.npz``; None if its cells do not fit its grid."""
    from world_service.outcome.map_truth import map_figures

    try:
        _, classes = mapping.from_message(msg)
    except ValueError:
        return None
    return map_figures(scenario, grid, classes).report_fields()


class _NotThisScenario(LunarSimError, ValueError):
    """A sample that decodes but cannot be of the scenario's mission: a state naming a rover it does not have, a map
    whose grid is not the one its lander builds."""


def _of_scenario(state: m.WorldState, rovers: int) -> m.WorldState:
    if any(not 1 <= r.id <= rovers for r in state.rovers):
        raise _NotThisScenario(f"a world state names a rover outside 1..{rovers}")
    return state


def _scenario_map(msg: m.LanderMap, grid: mapping.GridSpec) -> m.LanderMap:
    """``msg`` if it is the scenario's grid, the one the launcher scores in ``map.npz``. Another is not unpacked:
    scoring takes several times the grid's size in memory, and a sample on the lander's key may claim a billion
    cells."""
    if (msg.origin_x, msg.origin_z, msg.cell_m, msg.width, msg.height) != (
            grid.origin_x, grid.origin_z, grid.cell_m, grid.width, grid.height):
        raise _NotThisScenario(f"lander map: a {msg.width} x {msg.height} grid, not this scenario's")
    return msg
