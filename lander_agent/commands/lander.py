"""Command line of the lander agent: ``lunarsim lander SCENARIO`` and ``python -m lander_agent SCENARIO``."""

from __future__ import annotations

import argparse
from pathlib import Path

from bus import paths, process
from bus.zenoh_config import add_zenoh_arguments, config_from_args, describe_endpoints, open_session

PRELOAD = ("lander_agent.archive", "lander_agent.lander", "lander_agent.mission", "lander_agent.resume",
           "lander_agent.runtime")
"""What ``run`` imports of the lander's own (NumPy among it): ``lunarsim run`` imports it while its world starts,
then forks the lander from itself."""


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("scenario", type=Path, help="scenario YAML: the lander takes its mission plan from it")
    parser.add_argument("--world", default="default", help="world name in the keyspace (default: default)")
    parser.add_argument("--archive", type=paths.output_folder,
                        metavar="DIR", help="archive received photos here (PNG + index)")
    parser.add_argument("--map-out", type=paths.output_folder,
                        metavar="DIR", help="write the traverse map here (map.npz, map.png)")
    state = parser.add_mutually_exclusive_group()
    state.add_argument("--state", type=paths.output_folder, metavar="DIR",
                       help="keep the lander's plan and map here every simulated second, and resume them when started "
                            "again in the same run (default: $XDG_STATE_HOME/lunarsim/<world>/, ~/.local/state "
                            "without it)")
    state.add_argument("--no-state", action="store_true", help="keep no state: a restart begins its plan and map again")
    add_zenoh_arguments(parser, agent=True)


def run(args: argparse.Namespace) -> int:
    from bus.bus import Bus
    from lander_agent.archive import PhotoArchive
    from lander_agent.lander import Lander
    from lander_agent.mission import MissionPlan
    from lander_agent.resume import FILE_NAME, LanderMemory
    from lander_agent.runtime import run
    from schemas.keyspace import Keyspace
    from schemas.scenario import load_scenario

    plan = MissionPlan(load_scenario(args.scenario))
    memory = LanderMemory(None if args.no_state else (args.state or process.state_folder(args.world)) / FILE_NAME)
    session = open_session(config_from_args(args), describe_endpoints(args), args.router_timeout, who="lander")
    with Bus(session) as bus, process.stop_on_signals(process.SHUTDOWN_DEADLINE_S) as stop:
        bus.wake_on(stop)
        run(Lander(plan, Keyspace(args.world), PhotoArchive(args.archive), args.map_out, memory), bus, stop)
    return 0
