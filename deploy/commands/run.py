"""``lunarsim run``: a whole mission on this machine, every part its own OS process.

Starts the world service, the lander agent and a process per rover agent (``--agents-per-process`` groups
them, as ``lunarsim rover --ids`` runs them); the world is the Zenoh router the others connect to, unless
``--connect`` names a router for all of them. Shows progress, and warns when an agent falls behind the world's
clock (``deploy.agent_lag``); stops when every rover is done or stuck, or at
``--max-sim-time``; writes ``report.json`` into the run folder (scoring the lander's traverse map, ``map.npz``
and ``map.png`` there); and stops every process it started, also on Ctrl-C or SIGTERM.
"""

from __future__ import annotations

import argparse
from pathlib import Path

from bus import paths, priority, process
from bus.loss import MAX_SHARE
from bus.zenoh_config import DEFAULT_PORT


def _positive(text: str) -> int:
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"not a whole number: {text!r}") from None
    if value < 1:
        raise argparse.ArgumentTypeError(f"must be at least 1, got {value}")
    return value


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("scenario", type=Path, nargs="?", help="scenario YAML (see scenarios/)")
    parser.add_argument("--from", dest="from_recording", type=Path, metavar="FILE.mcap",
                        help="re-run the scenario and seed a recording was made with (use --lockstep to get the "
                        "same message sequence again)")
    parser.add_argument("--out", type=paths.output_folder,
                        metavar="DIR", help="run folder (default runs/<scenario>-<timestamp>)")
    parser.add_argument("--max-sim-time", type=float, metavar="S", help="stop after S simulated seconds")
    parser.add_argument("--seed", type=int, help="override the scenario's seed")
    parser.add_argument("--rovers", type=int, metavar="N", help="spawn N rovers in the scenario's formation")
    parser.add_argument("--params", type=Path, metavar="FILE", help="rover parameters (YAML) replacing the "
                        "scenario's rover_params, e.g. scenarios/params/report_defaults.yaml")
    parser.add_argument("--time-scale", type=float, default=1.0, metavar="K",
                        help="simulated seconds per wall second (default 1 = real time)")
    parser.add_argument("--lockstep", action="store_true",
                        help="deterministic clock: a tick advances only when every agent has handled the last one")
    parser.add_argument("--agents-per-process", type=_positive, default=1, metavar="K",
                        help="rover agents sharing one process, K to a process as 'lunarsim rover --ids' runs them "
                             "(default 1: a process per rover). Fewer processes wake fewer times a tick: a 5-rover "
                             "lockstep mission takes about a seventh less time in one process")
    parser.add_argument("--agent-priority", choices=priority.CHOICES, default="auto", help=priority.HELP)
    parser.add_argument("--world", default="default", help="world name in the keyspace (default: default)")
    parser.add_argument("--port", type=int, default=DEFAULT_PORT, help=f"port on 127.0.0.1 where the world "
                        f"routes for the run (default {DEFAULT_PORT})")
    parser.add_argument("--connect", metavar="ENDPOINT", help="join a running router (every process does) instead "
                        "of the world routing for the run")
    parser.add_argument("--quiet", "-q", action="store_true", help="no live progress, only the summary")
    parser.add_argument("--no-record", action="store_true", help="do not record the session (by default it "
                        "goes to session.mcap in the run folder)")
    parser.add_argument("--ros2", action="store_true", help="also run the ROS 2 bridge ('lunarsim ros2'), on "
                        "$ROS_DOMAIN_ID (default 0): the rovers' topics for ROS 2 nodes on rmw_zenoh")
    parser.add_argument("--external", metavar="IDS", help="rovers an outside ROS 2 node drives, e.g. 1 or 1,3: no "
                        "agent is started for them and the ROS 2 bridge runs with --drive IDS (real time only)")
    parser.add_argument("--fault-loss", type=float, default=0.0, metavar="P",
                        help=f"fault injection: the world drops this share (0-{MAX_SHARE:g}) of the samples it "
                             "publishes, as a bad link would (seeded by the scenario's seed); to test what the agents "
                             "survive")


def run(args: argparse.Namespace) -> int:
    from deploy import launcher, run_setup

    if args.time_scale <= 0:
        raise process.UsageError(f"--time-scale must be positive for a live run, got {args.time_scale}")
    if args.external and args.lockstep:
        raise process.UsageError("--external with --lockstep: a lockstep tick waits for every agent's ack, and a "
                                 "ROS 2 node does not acknowledge ticks; run the outside rovers in real time")
    if args.connect:
        run_setup.check_router(args.connect)
    run_setup.warm_up()  # before the imports and the scenario below, which its own imports then overlap
    from deploy.behaviour_check import require_behaviour
    from deploy.rover_groups import external_ids
    from schemas.scenario import load_rover_params

    params = load_rover_params(args.params) if args.params else None
    scenario = run_setup.base_scenario(args.scenario, args.from_recording).with_overrides(
        seed=args.seed, rovers=args.rovers, rover_params=params)
    require_behaviour(scenario.behaviour, str(args.scenario or args.from_recording))  # before any process starts
    options = launcher.LaunchOptions(
        world=args.world, port=args.port, connect=args.connect, time_scale=args.time_scale,
        max_sim_time=args.max_sim_time, lockstep=args.lockstep, agents_per_process=args.agents_per_process,
        agent_priority=args.agent_priority, quiet=args.quiet, record=not args.no_record, ros2=args.ros2,
        external=external_ids(args.external, len(scenario.rovers)), fault_loss=args.fault_loss,
        verbose=getattr(args, "verbose", False))
    return launcher.launch(scenario, options, args.out)
