"""Run a whole mission in one process, with no router: the world, lander and rover agents wired through their
pure ``handle`` functions, every message still encoded and decoded with the codec.

Deterministic and fast: the behaviour checker, the behaviour suite and the tests of mission logic use it. As in
lockstep, photos arrive on their due tick, and an agent that publishes on a tick the world would not wait for
(its ``next_wake`` misses a timer) is an error here. The cross-process path is tested separately over a real
router, and gives the same report (tests/e2e/test_loopback_equals_processes.py).
"""

from __future__ import annotations

from pathlib import Path

from bus import heap
from harness.rounds import Drop, Rounds
from lander_agent.archive import PhotoArchive
from rover_agent.agent import RoverAgent
from rover_agent.behaviour import BaseBehaviour
from schemas import codec
from schemas import keyspace as ks
from schemas import messages as m
from schemas.messages import Out
from schemas.scenario import Scenario
from shared.mission import calibration
from world_service.sim import World

__all__ = ["Drop", "answer", "rover_agents", "run_mission", "run_mission_agents"]


def run_mission(scenario: Scenario, max_sim_time: float, archive: PhotoArchive | None = None,
                behaviour: type[BaseBehaviour] | None = None, map_folder: Path | None = None,
                drop: Drop | None = None) -> World:
    """The world at the end; with ``map_folder``, the lander's traverse map is written there as it ends."""
    return run_mission_agents(scenario, max_sim_time, archive, behaviour, map_folder, drop)[0]


def run_mission_agents(scenario: Scenario, max_sim_time: float, archive: PhotoArchive | None = None,
                       behaviour: type[BaseBehaviour] | None = None, map_folder: Path | None = None,
                       drop: Drop | None = None) -> tuple[World, dict[int, RoverAgent]]:
    """The world and the rover agents at the end: what each rover believed (its pose estimate) beside the truth.

    The process's C heap is set to keep freed array blocks (``bus.heap``), as the processes of a run set theirs."""
    heap.keep_freed_memory()
    rounds = Rounds(scenario, max_sim_time, archive, map_folder, drop, strict=True)
    agents = rover_agents(scenario, rounds.keys, rounds.rover_ids, behaviour)
    heard = rounds.advance({})
    while heard:
        heard = rounds.advance({rid: answer(agents[rid], samples) for rid, samples in heard.items()})
    return rounds.finish(), agents


def rover_agents(scenario: Scenario, keys: ks.Keyspace, rover_ids: list[int],
                 behaviour: type[BaseBehaviour] | None = None) -> dict[int, RoverAgent]:
    """One agent a rover, each knowing only its own parameters and where the mission plan dispatches it."""
    params = scenario.rover_params
    return {rid: RoverAgent(rid, keys, params, behaviour(rid, params) if behaviour else None,
                            dispatch=calibration(scenario, rid)) for rid in rover_ids}


def answer(agent: RoverAgent, samples: list[tuple[str, bytes]]) -> list[Out]:
    """What the agent publishes on hearing ``samples`` (one round of ``Rounds``), as its Zenoh loop would. Its last
    scan is folded into its map at once (``catch_up``), which the loop leaves to the next sample: the same map
    for every decision, and a current one wherever the mission ends."""
    out: list[Out] = []
    for topic, payload in samples:
        out += agent.on_clock(codec.decode(m.Clock, payload)) if topic == ks.CLOCK else agent.handle(topic, payload)
    agent.catch_up()
    return out


