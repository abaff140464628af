"""What every LunarSim process shares: signal handling, logging set-up and exit codes.

Exit codes: 0 done, 2 bad input (usage, scenario), 3 no router reachable, 130 interrupted.
"""

from __future__ import annotations

import argparse
import contextlib
import gc
import importlib
import logging
import signal
import sys
import threading
from collections.abc import Iterator

EXIT_USAGE = 2
EXIT_NO_ROUTER = 3
EXIT_INTERRUPTED = 130


class UsageError(ValueError):
    """A command-line value that cannot work; the message is shown as is."""


@contextlib.contextmanager
def stop_on_signals() -> Iterator[threading.Event]:
    """An event set by SIGINT or SIGTERM, so loops finish their iteration and clean up."""
    stop = threading.Event()

    def _handler(signum: int, frame: object) -> None:
        stop.set()

    previous = {sig: signal.signal(sig, _handler) for sig in (signal.SIGINT, signal.SIGTERM)}
    try:
        yield stop
    finally:
        for sig, handler in previous.items():
            signal.signal(sig, handler)


def freeze_start_up_heap() -> None:
    """Take what start-up made (modules, models, the world's terrain) out of the garbage collector's scans.

    A full collection of a rover agent's start-up heap takes about 17 ms on this machine, the world's longer,
    and steady traffic sets one off every few seconds: a stall of a third of a gyroscope period, which in a
    crowded run tips samples past their period, and plain wall time in lockstep. What start-up made lives for
    the whole run, so it is collected once and then never scanned again (``gc.freeze``)."""
    gc.collect()
    gc.freeze()


def setup_logging(verbose: bool = False) -> None:
    logging.basicConfig(level=logging.INFO if verbose else logging.WARNING,
                        format="%(asctime)s %(name)s %(levelname)s: %(message)s", stream=sys.stderr)


def run_guarded(run, args: argparse.Namespace) -> int:
    """Run a command, turning the errors a user can fix into one line and an exit code."""
    from deploy.zenoh_config import RouterUnreachable
    from schemas.scenario import ScenarioError

    try:
        return run(args)
    except (UsageError, ScenarioError) as exc:
        print(f"error: {exc}", file=sys.stderr)
        return EXIT_USAGE
    except RouterUnreachable as exc:
        print(f"error: {exc}", file=sys.stderr)
        return EXIT_NO_ROUTER
    except KeyboardInterrupt:
        return EXIT_INTERRUPTED


def main_for(name: str, module_name: str) -> None:
    """``python -m <package>``: the same arguments and behaviour as ``lunarsim <name>``."""
    module = importlib.import_module(module_name)
    parser = argparse.ArgumentParser(prog=f"python -m {module_name.split('.')[0]}", description=module.__doc__)
    module.add_arguments(parser)
    parser.add_argument("--verbose", "-v", action="store_true", help="log progress at INFO level")
    args = parser.parse_args()
    setup_logging(args.verbose)
    sys.exit(run_guarded(module.run_from_args, args))
