"""The scale benchmark's command line: the quick and full series and their checks."""

from __future__ import annotations

import argparse
from pathlib import Path

from scale_hosts import unavailable
from world_scale import SCENARIO

from bus import priority

QUICK = {"counts": [3, 5], "seconds": 2.0, "warmup": 0.5, "shared_counts": [10], "per_process": 5,
         "lockstep_counts": [5], "lockstep_sim_time": 3.0, "lockstep_repeats": 1}
FULL = {"counts": [10, 50, 100], "seconds": 30.0, "warmup": 5.0, "shared_counts": [1000, 750, 500],
        "per_process": 250, "lockstep_counts": [5, 20, 100], "lockstep_sim_time": 60.0, "lockstep_repeats": 3}


def parse_args(argv: list[str] | None = None, description: str = "") -> argparse.Namespace:
    parser = argparse.ArgumentParser(description=description)
    parser.add_argument("--quick", action="store_true", help="a smoke check: small counts, short windows "
                        f"({', '.join(f'{k} {v}' for k, v in QUICK.items())})")
    parser.add_argument("--counts", type=int, nargs="+", metavar="N",
                        help=f"real time, one process per rover (default {FULL['counts']})")
    parser.add_argument("--seconds", type=float, metavar="S", help="measuring window in real time "
                        f"(default {FULL['seconds']:g})")
    parser.add_argument("--warmup", type=float, metavar="S", help="running clock before the window "
                        f"(default {FULL['warmup']:g})")
    parser.add_argument("--shared-counts", type=int, nargs="+", metavar="N", help="real time, rovers sharing "
                        f"processes, largest first until one holds (default {FULL['shared_counts']})")
    parser.add_argument("--no-step-down", dest="step_down", action="store_false",
                        help="measure the shared counts given and no others (to compare two builds at one count)")
    parser.add_argument("--per-process", type=int, metavar="K", help="agents per process in the shared series "
                        f"(default {FULL['per_process']})")
    parser.add_argument("--lockstep-counts", type=int, nargs="+", metavar="N",
                        help=f"lockstep, one process per rover (default {FULL['lockstep_counts']})")
    parser.add_argument("--lockstep-sim-time", type=float, metavar="S", help="cap of each lockstep mission in "
                        f"simulated seconds (default {FULL['lockstep_sim_time']:g})")
    parser.add_argument("--lockstep-repeats", type=int, metavar="R", help="runs of each lockstep measurement, "
                        f"interleaved; the median is reported (default {FULL['lockstep_repeats']}, "
                        f"--quick {QUICK['lockstep_repeats']})")
    parser.add_argument("--lockstep-timeout", type=float, default=900.0, metavar="S",
                        help="wall seconds a lockstep mission may take (default 900)")
    parser.add_argument("--skip-lockstep", action="store_true")
    parser.add_argument("--skip-1000", action="store_true", help="leave out the shared-process series")
    parser.add_argument("--no-witness", action="store_true", help="no second observer process (it tells a "
                        "sample lost before the router's per-subscriber queues from one lost on the way to the "
                        "benchmark)")
    parser.add_argument("--sample", type=int, default=10, metavar="K", help="rovers whose sensors are followed "
                        "(spread over the ids; default 10)")
    parser.add_argument("--lockstep-sample", type=int, default=0, metavar="K",
                        help="rovers whose sensors are followed in lockstep (default 0: the speed-up is the run's "
                             "own; following sensors makes the router copy them to this process and a witness, "
                             "which on two cores slowed a 5-rover mission from 10.1 to 7.1 times real time)")
    parser.add_argument("--startup-timeout", type=float, default=180.0, metavar="S",
                        help="seconds for every rover to connect (default 180)")
    parser.add_argument("--routing", choices=("auto", "world", "process"), default="auto",
                        help="who routes: the world (as lunarsim run), a router process, or auto (default): the "
                             "world, but a router process for the shared-process real-time series")
    parser.add_argument("--two-hosts", action="store_true",
                        help="the world and the lander on one host, the rovers on another, each behind its own "
                             "router: two network namespaces of this machine, as tests/e2e/test_multihost.py makes "
                             "(needs root; they share this machine's cores)")
    parser.add_argument("--agent-priority", choices=priority.CHOICES, default="auto",
                        help="as lunarsim run's (the witness runs at it too): " + priority.HELP)
    parser.add_argument("--scenario", type=Path, default=SCENARIO, help="default: crater_observation.yaml")
    parser.add_argument("--logs", type=Path, metavar="DIR", help="keep the processes' logs under DIR")
    parser.add_argument("--json", type=Path, metavar="FILE", help="also write the figures to FILE as JSON")
    args = parser.parse_args(argv)
    for key, value in (QUICK if args.quick else FULL).items():
        if getattr(args, key) is None:
            setattr(args, key, value)
    check_args(parser, args)
    return args


def check_args(parser: argparse.ArgumentParser, args: argparse.Namespace) -> None:
    counts = [*args.counts, *args.shared_counts, *args.lockstep_counts]
    if min(counts) < 1 or min(args.per_process, args.sample, args.lockstep_repeats) < 1 or args.lockstep_sample < 0:
        parser.error("rover counts, --per-process, --sample and --lockstep-repeats must be 1 or more, "
                     "--lockstep-sample 0 or more")
    if args.seconds <= 0 or args.warmup < 0 or args.lockstep_sim_time <= 0:
        parser.error("--seconds and --lockstep-sim-time must be more than 0, --warmup 0 or more")
    if not args.scenario.is_file():
        parser.error(f"--scenario {args.scenario}: no such file")
    if args.two_hosts and (why := unavailable()):
        parser.error(why)
    if args.logs is not None:
        args.logs.mkdir(parents=True, exist_ok=True)
