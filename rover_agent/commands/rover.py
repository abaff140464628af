"""Command line of the rover agent: ``lunarsim rover --id N`` and ``python -m rover_agent --id N``."""

from __future__ import annotations

import argparse
import logging
import os
import sys
from pathlib import Path
from typing import TYPE_CHECKING

from bus import paths, process
from bus.zenoh_config import (
    add_zenoh_arguments,
    config_from_args,
    describe_endpoints,
    open_session,
    receive_on_one_thread,
)
from schemas.scenario_limits import clip

if TYPE_CHECKING:
    from schemas import messages as m
    from schemas.params import RoverParams

PRELOAD = ("rover_agent.commands.rover", "bus.bus", "rover_agent.identity", "rover_agent.runtime", "rover_agent.agent",
           "rover_agent.registry", "schemas.keyspace", "schemas.scenario")
"""What ``run`` imports: a launcher's warm server (``deploy.warm_start``) has it loaded before it
forks the rover agents of a run, so none of them spends its start importing."""


def add_arguments(parser: argparse.ArgumentParser) -> None:
    which = parser.add_mutually_exclusive_group()
    which.add_argument("--id", default=os.environ.get("LUNARSIM_ROVER_ID"),
                       help="rover id (1..N, as rover1, rover2 in the report); 'ordinal': from a StatefulSet pod's "
                            "host name (rover-0 is rover 1); 'auto': the world hands out a free one "
                            "(default: $LUNARSIM_ROVER_ID)")
    which.add_argument("--ids", metavar="IDS",
                       help="run several agents in this one process, e.g. 1-250 or 1,3,7-9: each keeps its own "
                            "keys and liveliness token, as separate processes would (for very large runs)")
    parser.add_argument("--world", default="default", help="world name in the keyspace (default: default)")
    parser.add_argument("--params", type=Path, metavar="FILE",
                        help="YAML of rover parameters (report tables 4-8); a scenario file works too")
    parser.add_argument("--behaviour", default="default", metavar="NAME",
                        help="behaviour by name: default, straight, an installed plugin, or package.module:Class")
    state = parser.add_mutually_exclusive_group()
    state.add_argument("--state", type=paths.output_path, metavar="FILE",
                       help="keep the dead-reckoned pose and the action in flight here, so a restarted agent takes "
                            "its rover again where it is (with --ids: a folder, one rover<N>.json per agent; "
                            "default: $XDG_STATE_HOME/lunarsim/<world>/rover<N>.json, ~/.local/state without it)")
    state.add_argument("--no-state", action="store_true",
                       help="keep nothing: a restart mid-mission then leaves the rover lost, and it says so")
    add_zenoh_arguments(parser, agent=True)


def run(args: argparse.Namespace) -> int:
    from bus.bus import Bus
    from rover_agent import identity, runtime
    from rover_agent.agent import RoverAgent
    from rover_agent.registry import UnknownBehaviour, load_behaviour
    from schemas.keyspace import Keyspace

    if args.id is None and args.ids is None:
        raise process.UsageError("give the rover's --id (or set LUNARSIM_ROVER_ID), or --ids for several agents")
    if args.state is not None and (args.state.is_dir() if args.ids is None else args.state.is_file()):
        raise process.UsageError(f"--state {clip(str(args.state))}: with --ids a folder, with --id a file")
    try:
        if args.ids is not None:
            rover_ids: list[int | str] = list(identity.parse_ids(args.ids))
        else:
            spec = identity.parse_id(args.id)
            rover_ids = [identity.id_from_hostname() if spec == "ordinal" else spec]
        behaviour_class = load_behaviour(args.behaviour)
    except (ValueError, UnknownBehaviour) as exc:
        raise process.UsageError(str(exc)) from None
    params = rover_params(args.params)
    keys = Keyspace(args.world)
    who = f"rover {rover_ids[0]}" if len(rover_ids) == 1 else f"rovers {args.ids}"
    if len(rover_ids) == 1:  # a process of many agents receives many samples at a time: Zenoh's default
        receive_on_one_thread()
    session = open_session(config_from_args(args), describe_endpoints(args), args.router_timeout, who=who)
    with Bus(session) as bus, process.stop_on_signals(process.SHUTDOWN_DEADLINE_S) as stop:
        if rover_ids == ["auto"]:
            granted = identity.ask_world(session, keys, stop)
            if granted is None:
                return process.EXIT_INTERRUPTED
            print(f"rover {granted}: id handed out by the world service", file=sys.stderr, flush=True)
            rover_ids = [granted]
        logging.getLogger("lunarsim.rover").info("%s connected", who)
        dispatch = _dispatch(args.params, rover_ids)
        agents = [RoverAgent(rid, keys, params, behaviour_class(rid, params), state_file=_state_file(args, rid),
                             dispatch=dispatch.get(rid)) for rid in rover_ids]
        runtime.run(agents, bus, stop)
    return 0


def rover_params(path: Path | None) -> RoverParams:
    """The parameters of ``--params``, or the defaults: without a file the agent imports neither the scenario
    models nor PyYAML, which it needs only to read one."""
    if path is None:
        from schemas.params import RoverParams

        return RoverParams()
    from schemas.scenario import load_rover_params

    return load_rover_params(path)


def _dispatch(params: Path | None, rover_ids: list[int]) -> dict[int, m.Calibration]:
    """The planned dispatch poses when ``--params`` is a mission (scenario) file, read once for every agent of the
    process: the fallback for a rover that never hears the lander's calibration (``rover_agent.contact``)."""
    if params is None:
        return {}
    from schemas.scenario import load_dispatch_plan
    from shared.mission import dispatch_pose

    plan = load_dispatch_plan(params)
    if plan is None:
        return {}
    lander, spawns = plan
    return {rid: dispatch_pose(lander, spawns[rid - 1]) for rid in rover_ids if 1 <= rid <= len(spawns)}


def _state_file(args: argparse.Namespace, rover_id: int) -> Path | None:
    """Where the agent keeps its state: ``--state``, or by default a file per world and rover (a state saved in
    another run of the world is not resumed: it names its run)."""
    if args.no_state:
        return None
    if args.state is None:
        path = process.state_folder(args.world) / f"rover{rover_id}.json"
    elif args.ids is None:
        path = args.state
    else:
        path = args.state / f"rover{rover_id}.json"
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        logging.getLogger("lunarsim.rover").warning("rover %d: cannot keep its state in %s (%s); a restart will "
                                                    "leave it lost", rover_id, path.parent, exc)
        return None
    return path


def main() -> None:
    """``lunarsim-rover``: the flight computer's entry (the wheel there has no ``lunarsim`` command)."""
    process.main_for("rover", "rover_agent.commands.rover")
