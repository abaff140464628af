"""Command line of the world service: ``lunarsim world SCENARIO`` and ``python -m world_service SCENARIO``."""

from __future__ import annotations

import argparse
import logging
from pathlib import Path
from typing import TYPE_CHECKING

import zenoh

from bus import paths, process
from bus.loss import MAX_SHARE
from bus.zenoh_config import add_zenoh_arguments, config_from_args, describe_endpoints, open_router, open_session
from schemas.scenario_limits import clip

if TYPE_CHECKING:
    from bus.bus import Bus
    from schemas.keyspace import Keyspace
    from schemas.scenario import Scenario
    from world_service.served import ServedWorld

log = logging.getLogger("lunarsim.world")


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("scenario", type=Path, help="scenario YAML")
    parser.add_argument("--world", default="default", help="world name in the keyspace (default: default)")
    parser.add_argument("--seed", type=int, help="override the scenario's seed")
    parser.add_argument("--rovers", type=int, metavar="N", help="spawn N rovers in the scenario's formation")
    parser.add_argument("--time-scale", type=float, default=1.0, metavar="K",
                        help="simulated seconds per wall second (default 1; 0 = as fast as possible)")
    parser.add_argument("--max-sim-time", type=float, metavar="S", help="end the mission after S simulated seconds")
    parser.add_argument("--lockstep", action="store_true",
                        help="advance a tick only when every live agent has acknowledged the last one "
                             "(deterministic for a scenario and seed; as fast as the processes allow)")
    parser.add_argument("--start-timeout", type=float, default=30.0, metavar="S",
                        help="seconds to wait for the lander and every rover agent before starting anyway")
    parser.add_argument("--no-lander", action="store_true", help="do not wait for a lander agent")
    parser.add_argument("--exit-when-done", action="store_true",
                        help="exit after the mission instead of serving the final statistics")
    parser.add_argument("--report", type=paths.output_file,
                        metavar="FILE", help="also write the final report.json here")
    parser.add_argument("--photos", type=paths.output_folder,
                        metavar="DIR", help="also save every rover photo (PNG) here")
    parser.add_argument("--twin", action="store_true",
                        help="follow real rovers (poses from their drivers' telemetry) instead of simulating "
                             "them; real time only")
    parser.add_argument("--fault-loss", type=float, default=0.0, metavar="P",
                        help=f"fault injection: drop this share (0-{MAX_SHARE:g}) of the samples the world "
                             "publishes, seeded by the scenario's seed, as a bad link would")
    state = parser.add_mutually_exclusive_group()
    state.add_argument("--state", type=paths.output_file, metavar="FILE",
                       help="keep the world's state here every simulated second, and resume this run from it when "
                            "started again (default: $XDG_STATE_HOME/lunarsim/<world>/world.state, ~/.local/state "
                            "without it)")
    state.add_argument("--no-state", action="store_true", help="keep no state: a restart begins a new run")
    parser.add_argument("--fresh", action="store_true", help="begin a new run even if a saved state could be resumed")
    add_zenoh_arguments(parser, listen=True, agent=True)
    parser.epilog = ("--listen makes the world the Zenoh router of the run: agents connect straight to it, one "
                     "hop less each way than through a router process (what 'lunarsim run' does).")


def run(args: argparse.Namespace) -> int:
    from schemas.keyspace import Keyspace
    from schemas.scenario import load_scenario
    from world_service import service

    _check(args)
    scenario = load_scenario(args.scenario).with_overrides(seed=args.seed, rovers=args.rovers)
    if args.twin:
        _check_twin(args)
    state_file = None if args.no_state or args.twin else args.state or process.state_folder(args.world) / "world.state"
    settings = service.ClockSettings(args.time_scale, args.max_sim_time, args.start_timeout, not args.no_lander,
                                     lockstep=args.lockstep, photo_dir=args.photos, state_file=state_file)
    camera = None if args.twin else service.start_camera(scenario, args.lockstep)  # it starts while all else does
    try:  # the camera is stopped whatever ends the world, a Ctrl-C as it starts included
        session = _open(args)  # before the terrain is built: agents may connect meanwhile
        bus = world_bus(session, args.lockstep, args.fault_loss, scenario.seed)
        with bus, process.stop_on_signals(process.SHUTDOWN_DEADLINE_S) as stop:
            bus.wake_on(stop)
            world = _world(args, scenario, Keyspace(args.world), state_file)
            service.serve(world, bus, settings, stop, args.report, lingering=not args.exit_when_done, camera=camera)
    finally:
        if camera is not None:
            camera.close()
    return 0


def world_bus(session: zenoh.Session, lockstep: bool, fault_loss: float, seed: int) -> Bus:
    """The world's bus, router or client: it puts on its rovers' keys undeclared (``Bus`` says why)."""
    from bus.bus import Bus

    return Bus(session, lossless=lockstep, declare_publishers=False, loss=fault_loss, loss_seed=seed)


def _check(args: argparse.Namespace) -> None:
    if args.time_scale < 0:
        raise process.UsageError(f"--time-scale must be 0 or more, got {args.time_scale}")
    if args.report is not None and not args.report.parent.is_dir():  # else found only once the mission is over
        raise process.UsageError(f"--report {clip(str(args.report))}: there is no folder "
                                 f"{clip(str(args.report.parent))}")


def _check_twin(args: argparse.Namespace) -> None:
    """Real rovers move in real time and take their own photos: refuse what only a simulation can do."""
    if args.lockstep:
        raise process.UsageError("--twin follows real rovers in real time: it cannot run --lockstep")
    if args.time_scale != 1.0:
        raise process.UsageError(f"--twin follows real rovers in real time: --time-scale must be 1, got "
                                 f"{args.time_scale:g}")
    if args.photos is not None:
        raise process.UsageError("--twin has no simulated camera: the rovers' drivers take the photos (drop --photos)")


def _world(args: argparse.Namespace, scenario: Scenario, keys: Keyspace, state_file: Path | None) -> ServedWorld:
    """The twin of real rovers; or this run resumed from the state a killed world saved; or a new run."""
    if args.twin:
        from world_service.twin.world import TwinWorld

        return TwinWorld(scenario, keys)
    from world_service import resume
    from world_service.sim import World

    world = resume.load(state_file, scenario) if state_file is not None and not args.fresh else None
    if world is not None and world.keys == keys:
        log.warning("resumed run %s at %.1f s from %s (--fresh begins a new run)", world.clock.run_id,
                    world.clock.sim_time, state_file)
        return world
    return World(scenario, keys)


LISTENING = "the world is the router, listening on"


def listening_line(listen: list[str]) -> str:
    """What the world logs once it listens as the run's router: ``lunarsim run`` waits for it in the world's log
    (a port that answers may be another run's world)."""
    return f"{LISTENING} {', '.join(listen)}"


def _open(args: argparse.Namespace) -> zenoh.Session:
    """The world's session: with ``--listen``, the run's router itself; else a client of the router named."""
    if args.listen:
        session = open_router(config_from_args(args, "router"), args.listen, args.config)
        log.info("%s", listening_line(args.listen))
        return session
    return open_session(config_from_args(args), describe_endpoints(args), args.router_timeout, who="world")
