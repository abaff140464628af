"""What every LunarSim process shares: signal handling, logging set-up and exit codes.

Exit codes (``schemas.errors``): 0 done, 1 failed (a process of the run died, or an unexpected error), 2 bad input
(usage, scenario, a file that cannot be read or written), 3 no router reachable, 130 interrupted. Each
``LunarSimError`` carries its own. Whatever goes wrong, a command says so in one line on stderr; only ``--verbose``
adds a traceback.
"""

from __future__ import annotations

import argparse
import contextlib
import faulthandler
import gc
import importlib
import logging
import math
import os
import signal
import sys
import threading
import traceback
from collections.abc import Callable, Iterator
from pathlib import Path

from bus import heap
from bus.errors import RouterUnreachable, UsageError
from bus.loss import MAX_SHARE
from schemas.errors import EXIT_FAILED, EXIT_INTERRUPTED, EXIT_NO_ROUTER, EXIT_USAGE, LunarSimError
from schemas.scenario_limits import clip

__all__ = ["EXIT_FAILED", "EXIT_INTERRUPTED", "EXIT_NO_ROUTER", "EXIT_USAGE", "SHUTDOWN_DEADLINE_S",
           "RouterUnreachable", "Stop", "UsageError", "check_common_arguments", "check_range", "freeze_before_fork",
           "freeze_start_up_heap", "main_for", "one_blas_thread", "run_guarded", "setup_logging", "state_folder",
           "stop_on_signals"]


SHUTDOWN_DEADLINE_S = 10.0
"""How long a process of a mission may take to stop once asked to (``stop_on_signals(deadline_s=...)``)."""
STDERR_FD = 2
"""The watchdog writes to the descriptor, not ``sys.stderr``: a handler must not fail on a stream replaced by one
without a descriptor."""


class Stop(threading.Event):
    """A request to stop (a signal, or a thread of the process giving up) that also wakes what waits on something
    other than the event: a loop blocked on its inbox (``Bus.wake_on``) would notice only at its timeout, and a
    mission's way out waits for its slowest process.

    A waker must be safe to call from a signal handler on any thread, as ``queue.SimpleQueue.put`` is."""

    def __init__(self) -> None:
        super().__init__()
        self._wakers: list[Callable[[], None]] = []

    def also_wake(self, waker: Callable[[], None]) -> None:
        self._wakers.append(waker)
        if self.is_set():  # set before it was registered: it must not sleep out its timeout either
            waker()

    def set(self) -> None:
        super().set()
        for waker in self._wakers:
            waker()


@contextlib.contextmanager
def stop_on_signals(deadline_s: float | None = None) -> Iterator[Stop]:
    """An event set by SIGINT or SIGTERM, so loops finish their iteration and clean up.

    With ``deadline_s``, the process ends that long after the first signal even if its clean-up never returns
    (a library call that blocks, such as a Zenoh undeclaration waiting on a callback): a supervisor, systemd or
    ``lunarsim run`` asked it to stop and must not wait on it forever. The deadline is kept by the interpreter's
    own watchdog thread (``faulthandler``), which needs no lock a hung thread could hold; it writes every
    thread's stack to stderr (the process's log) and exits with status 1, so the hang is reported, with where
    it was, rather than hidden."""
    stop = Stop()

    def _handler(signum: int, frame: object) -> None:
        if deadline_s is not None and not stop.is_set():  # nothing printed here: a handler can interrupt a print
            faulthandler.dump_traceback_later(deadline_s, exit=True, file=STDERR_FD)
        stop.set()

    previous = {sig: signal.signal(sig, _handler) for sig in (signal.SIGINT, signal.SIGTERM)}
    try:
        yield stop
    finally:
        for sig, handler in previous.items():
            signal.signal(sig, handler)


BLAS_THREAD_VARIABLES = ("OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS", "OMP_NUM_THREADS")


def one_blas_thread() -> None:
    """Have NumPy's BLAS run on the calling thread alone, unless the environment says otherwise: call before
    NumPy is imported; the processes this one starts inherit it.

    A mission is many processes on few cores, and LunarSim's arrays (a rover's rays, a map's cells) are far
    below the sizes a BLAS splits over threads, so its pool only costs: OpenBLAS starts a thread per core at
    import, about a fifth of a CPU second of each world, lander and command that imports NumPy. One thread
    also keeps a sum's order, and so its last bit, the same on machines with different numbers of cores."""
    for name in BLAS_THREAD_VARIABLES:
        os.environ.setdefault(name, "1")


def freeze_start_up_heap() -> None:
    """Take what start-up made (modules, models, the world's terrain) out of the garbage collector's scans.

    A full collection of a rover agent's start-up heap takes about 17 ms on this machine, the world's longer,
    and steady traffic sets one off every few seconds: a stall of a third of a gyroscope period, which in a
    crowded run tips samples past their period, and plain wall time in lockstep. What start-up made lives for
    the whole run, so it is collected once and then never scanned again (``gc.freeze``). The C heap is set to
    keep freed array blocks from here on (``heap.keep_freed_memory``)."""
    gc.collect()
    gc.freeze()
    heap.keep_freed_memory()


def freeze_before_fork() -> None:
    """Take this process's heap out of the garbage collector's scans before it forks a child that carries on from
    it (the world and the lander of ``lunarsim run``, the world's camera): the child's collections, its start-up
    freeze's full one included (``freeze_start_up_heap``), then scan what it made itself, not everything it was
    forked with, and leave those pages shared (what Python's ``gc.freeze`` documentation advises before a fork)."""
    gc.freeze()


def setup_logging(verbose: bool = False, events: bool = False) -> None:
    """``events``: a process of a mission (world, lander, rover, bridge, recorder) logs what an operator reads
    afterwards at INFO (its start, its connection, each rover's goals and stops, what it refused, its end), so a
    run's ``logs/`` tell its story; a one-shot command keeps quiet but for warnings."""
    logging.basicConfig(level=logging.INFO if verbose or events else logging.WARNING,
                        format="%(asctime)s %(name)s %(levelname)s: %(message)s", stream=sys.stderr)


AT_LEAST = {"max_sim_time": (0.0, False), "time_scale": (0.0, True), "router_timeout": (0.0, True),
            "start_timeout": (0.0, True), "duration": (0.0, False), "timeout": (0.0, True)}
"""Options several commands share, by destination: (bound, whether the bound itself is allowed). Checked before a
command starts, so a negative ``--max-sim-time`` cannot start a mission that ends at once with a report."""
AT_MOST = {"max_sim_time": 1e9, "time_scale": 1e6, "router_timeout": 1e6, "start_timeout": 1e6, "duration": 1e9,
           "timeout": 1e6}
"""Their upper bounds: no run lasts longer, and far larger counts of seconds overflow the conversions of clocks and
timers (the platform's time_t)."""
SMALLEST_SCALE = 1e-3
"""``--time-scale`` is 0 (as fast as possible, where a command has that) or at least this, a thousandth of real
time: 1e-20 failed the world on an overflow, and 1e-9 would not end a second in a lifetime."""


def check_range(option: str, value: float, low: float, high: float) -> None:
    """A command's own numeric option, within [low, high] or refused naming both."""
    if not low <= value <= high:
        shown = str(value) if isinstance(value, int) else f"{value:g}"
        raise UsageError(f"{option} must be between {low:g} and {high:g}, got {clip(shown, 40)}")


def check_common_arguments(args: argparse.Namespace) -> None:
    """No command takes nan or inf; shared options keep their bounds; a ``--port`` is a TCP port; a ``--world`` is a
    valid keyspace name."""
    from schemas.keyspace import check_world_name

    for name, value in vars(args).items():
        if isinstance(value, float) and not math.isfinite(value):
            raise UsageError(f"--{name.replace('_', '-')} must be a finite number, got {value}")
        if name in AT_LEAST and value is not None:
            bound, inclusive = AT_LEAST[name]
            if value < bound or (value == bound and not inclusive):
                raise UsageError(f"--{name.replace('_', '-')} must be {'at least' if inclusive else 'more than'} "
                                 f"{bound:g}, got {value:g}")
            if value > AT_MOST[name]:
                raise UsageError(f"--{name.replace('_', '-')} must be at most {AT_MOST[name]:g}, got {value:g}")
    if (loss := getattr(args, "fault_loss", None)) is not None:
        check_range("--fault-loss", loss, 0.0, MAX_SHARE)
    if (scale := getattr(args, "time_scale", None)) is not None and 0 < scale < SMALLEST_SCALE:
        raise UsageError(f"--time-scale must be 0 or at least {SMALLEST_SCALE:g}, got {scale:g}")
    if (port := getattr(args, "port", None)) is not None:
        check_range("--port", port, 1, 65535)
    if getattr(args, "world", None) is not None:
        try:
            check_world_name(args.world)
        except ValueError as exc:
            raise UsageError(f"--world: {exc}") from None


def run_guarded(run, args: argparse.Namespace) -> int:
    """Run a command, turning every error into one line on stderr and an exit code (no traceback, unless
    ``--verbose``: an unexpected error is still a bug to report, with the traceback that shows it). A
    ``LunarSimError`` worded for the user ends the command with its own exit code."""
    try:
        check_common_arguments(args)
        return run(args)
    except LunarSimError as exc:
        if not exc.for_the_user:
            return _unexpected(exc, args)
        return _fail(f"error: {exc}", exc.exit_code)
    except KeyboardInterrupt:
        return EXIT_INTERRUPTED
    except OSError as exc:
        if exc.filename is None:
            return _unexpected(exc, args)
        return _fail(f"error: {exc.filename}: {exc.strerror or exc}", EXIT_USAGE)
    except Exception as exc:
        return _unexpected(exc, args)


def _fail(message: str, code: int) -> int:
    print(message, file=sys.stderr)
    return code


def _unexpected(exc: BaseException, args: argparse.Namespace) -> int:
    if getattr(args, "verbose", False):
        traceback.print_exc()
    text = str(exc).strip().replace("\n", " | ") or "(no message)"
    hint = "" if getattr(args, "verbose", False) else " (add --verbose for the traceback)"
    return _fail(f"error: {type(exc).__name__}: {text}{hint}", EXIT_FAILED)


def main_for(name: str, module_name: str) -> None:
    """``python -m <package>``: the same arguments and behaviour as ``lunarsim <name>``, from its command module
    ``module_name`` (``<package>.commands.<name>``)."""
    one_blas_thread()
    module = importlib.import_module(module_name)
    parser = argparse.ArgumentParser(prog=f"python -m {module_name.split('.')[0]}", description=module.__doc__)
    module.add_arguments(parser)
    parser.add_argument("--verbose", "-v", action="store_true", help="log progress at INFO level")
    args = parser.parse_args()
    setup_logging(args.verbose, events=True)
    sys.exit(run_guarded(module.run, args))


def state_folder(world: str) -> Path:
    """Where a process started alone keeps what a restart resumes from, one folder per world:
    ``$XDG_STATE_HOME/lunarsim/<world>`` (``~/.local/state`` without it)."""
    home = Path(os.environ.get("XDG_STATE_HOME") or Path.home() / ".local" / "state")
    return home / "lunarsim" / world
