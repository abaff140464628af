"""Command line of the rover agent: ``lunarsim rover --id N`` and ``python -m rover_agent --id N``."""

from __future__ import annotations

import argparse
import logging
from pathlib import Path

from deploy import process
from deploy.zenoh_config import add_zenoh_arguments, config_from_args, describe_endpoints, open_session


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--id", type=int, required=True, help="rover id (1..N, as rover1, rover2 in the report)")
    parser.add_argument("--world", default="default", help="world name in the keyspace (default: default)")
    parser.add_argument("--params", type=Path, metavar="FILE",
                        help="YAML of rover parameters (report tables 4-8); a scenario file works too")
    parser.add_argument("--behaviour", default="default", metavar="NAME",
                        help="behaviour by name: default, straight, an installed plugin, or package.module:Class")
    parser.add_argument("--state", type=Path, metavar="FILE",
                        help="keep the dead-reckoned pose here, so a restarted agent takes its rover again")
    add_zenoh_arguments(parser)


def run_from_args(args: argparse.Namespace) -> int:
    from deploy.bus import Bus
    from rover_agent import runtime
    from rover_agent.agent import RoverAgent
    from schemas.keyspace import Keyspace
    from schemas.scenario import load_rover_params

    if args.id < 1:
        raise process.UsageError(f"--id must be 1 or more (rover ids start at 1), got {args.id}")
    from rover_agent.behaviours import UnknownBehaviour, load_behaviour

    params = load_rover_params(args.params)
    try:
        behaviour = load_behaviour(args.behaviour)(args.id, params)
    except UnknownBehaviour as exc:
        raise process.UsageError(str(exc)) from None
    keys = Keyspace(args.world)
    session = open_session(config_from_args(args), describe_endpoints(args), args.router_timeout,
                           who=f"rover {args.id}")
    with Bus(session) as bus, process.stop_on_signals() as stop:
        logging.getLogger("lunarsim.rover").info("rover %d connected", args.id)
        runtime.run(RoverAgent(args.id, keys, params, behaviour, state_file=args.state), bus, stop)
    return 0
