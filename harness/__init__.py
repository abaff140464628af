"""In-process wiring of the world, the lander and rover agents, with no router: the harness of the tests, the
behaviour checker and the behaviour benchmarks. It gives the same report as ``lunarsim run --lockstep``."""

from __future__ import annotations

from harness.loopback import run_mission, run_mission_agents
from harness.rounds import Rounds

__all__ = ["Rounds", "run_mission", "run_mission_agents"]
