"""Command line of the rover agent: ``lunarsim rover --id N`` and ``python -m rover_agent --id N``."""

from __future__ import annotations

import argparse
import logging
import os
import sys
from pathlib import Path

from deploy import process
from deploy.zenoh_config import add_zenoh_arguments, config_from_args, describe_endpoints, open_session


def add_arguments(parser: argparse.ArgumentParser) -> None:
    env_id = os.environ.get("LUNARSIM_ROVER_ID")
    parser.add_argument("--id", default=env_id, required=env_id is None,
                        help="rover id (1..N, as rover1, rover2 in the report); 'ordinal': from a StatefulSet pod's "
                             "host name (rover-0 is rover 1); 'auto': the world hands out a free one "
                             "(default: $LUNARSIM_ROVER_ID)")
    parser.add_argument("--world", default="default", help="world name in the keyspace (default: default)")
    parser.add_argument("--params", type=Path, metavar="FILE",
                        help="YAML of rover parameters (report tables 4-8); a scenario file works too")
    parser.add_argument("--behaviour", default="default", metavar="NAME",
                        help="behaviour by name: default, straight, an installed plugin, or package.module:Class")
    parser.add_argument("--state", type=Path, metavar="FILE",
                        help="keep the dead-reckoned pose here, so a restarted agent takes its rover again")
    add_zenoh_arguments(parser, agent=True)


def run_from_args(args: argparse.Namespace) -> int:
    from deploy.bus import Bus
    from rover_agent import identity, runtime
    from rover_agent.agent import RoverAgent
    from rover_agent.behaviours import UnknownBehaviour, load_behaviour
    from schemas.keyspace import Keyspace
    from schemas.scenario import load_rover_params

    try:
        spec = identity.parse_id(args.id)
        rover_id = identity.id_from_hostname() if spec == "ordinal" else spec
        behaviour_class = load_behaviour(args.behaviour)
    except (ValueError, UnknownBehaviour) as exc:
        raise process.UsageError(str(exc)) from None
    params = load_rover_params(args.params)
    keys = Keyspace(args.world)
    session = open_session(config_from_args(args), describe_endpoints(args), args.router_timeout,
                           who=f"rover {rover_id}")
    with Bus(session) as bus, process.stop_on_signals() as stop:
        if rover_id == "auto":
            rover_id = identity.ask_world(session, keys, stop)
            if rover_id is None:
                return process.EXIT_INTERRUPTED
            print(f"rover {rover_id}: id handed out by the world service", file=sys.stderr, flush=True)
        logging.getLogger("lunarsim.rover").info("rover %d connected", rover_id)
        agent = RoverAgent(rover_id, keys, params, behaviour_class(rover_id, params), state_file=args.state)
        runtime.run(agent, bus, stop)
    return 0


def main() -> None:
    """``lunarsim-rover``: the flight computer's entry (the wheel there has no ``lunarsim`` command)."""
    process.main_for("rover", "rover_agent.app")
