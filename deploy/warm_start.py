"""Start many agent processes from a warm interpreter: each is forked from a server that has already imported
the agent's code, instead of a fresh Python importing it again.

A rover agent spends most of its start-up importing (its own modules, the message models, Zenoh's bindings):
a fraction of a CPU second, which 100 rovers starting at once on two cores turn into a wait of many seconds.
Forked from a warm server, a rover starts with those modules in memory (shared copy-on-write) and only opens its
own Zenoh session. It is still its own OS process, with its own session, liveliness token, log, exit code and command
line (``python -m rover_agent --id 3 ...`` in ps), killed and reaped like any other. The server holds no Zenoh
session and no thread, so forking it is safe; it is the standard library's (``multiprocessing``'s
``forkserver``), started once per launcher. A launcher that has imported much of what one child needs forks that
child from itself instead (``fork_here``: ``lunarsim run``'s world and lander, after the scenario's models and the
lander's code), while it has no thread of its own.
"""

from __future__ import annotations

import contextlib
import importlib.machinery
import logging
import multiprocessing
import os
import runpy
import shlex
import signal
import subprocess
import sys
import threading
from collections.abc import Iterator, Sequence
from multiprocessing import forkserver
from multiprocessing.context import ForkServerContext
from pathlib import Path

import setproctitle

from bus.lifeline import die_with_parent
from bus.priority import Priority, lower
from bus.process import freeze_before_fork

_context: ForkServerContext | None = None


def _server(preload: Sequence[str]) -> ForkServerContext:
    """The launcher's one fork server; the first caller's ``preload`` is what it imports."""
    global _context
    if _context is None:
        _context = multiprocessing.get_context("forkserver")
        _context.set_forkserver_preload([*preload, "deploy.warm_freeze"])
    return _context


def available() -> bool:
    """Whether this platform can fork from a server (not Windows); where not, agents start cold, as before."""
    return "forkserver" in multiprocessing.get_all_start_methods()


def _child(module: str, args: list[str], log_path: str, priority: Priority) -> None:
    """In the forked process (from the warm server, or from the launcher itself: ``fork_here``): what ``python -m
    module args`` would do, writing into ``log_path``, at ``priority`` (``bus.priority``)."""
    lowered = lower(priority)
    log = os.open(log_path, os.O_WRONLY | os.O_CREAT | os.O_TRUNC, 0o644)
    os.dup2(log, 1)
    os.dup2(log, 2)
    os.close(log)
    for stream in (sys.stdout, sys.stderr):
        stream.reconfigure(write_through=True)  # as PYTHONUNBUFFERED: a log read while the process runs
    _let_go_of_server()
    die_with_parent()
    signal.signal(signal.SIGINT, signal.default_int_handler)  # the server ignores Ctrl-C; an agent must not
    signal.signal(signal.SIGTERM, signal.SIG_DFL)  # not a launcher's handler, which ``fork_here`` would leave
    logging.root.handlers.clear()  # nor its log set-up: the program makes its own
    # "daemon" only tells the launcher not to wait for it at exit; the program may start processes of its own
    multiprocessing.current_process().daemon = False
    if not lowered:
        print(f"note: could not lower this process to CPU priority {priority!r}; it runs at the default",
              file=sys.stderr, flush=True)
    sys.argv = [module, *args]
    # ps, top and pkill -f show and find it as the command it stands for, not as the fork server
    setproctitle.setproctitle(shlex.join([sys.executable, "-m", module, *args]))
    try:
        runpy.run_module(module, run_name="__main__", alter_sys=True)
    finally:
        _end_leftover_children()


def _end_leftover_children() -> None:
    """Stop what the program left running of the processes it started with ``multiprocessing`` (a pool it never
    shut down). A forked child's end waits for them before ``concurrent.futures`` would stop its pools, the order
    a plain interpreter's exit has the other way round, so a leftover would hold the child for ever."""
    for child in multiprocessing.active_children():
        child.terminate()


def _let_go_of_server() -> None:
    """Close the child's copy of the pipe by which the fork server learns that its launcher is gone.

    The standard library hands it to every child, so that they may fork from the server themselves; an agent
    never does, and while it held the pipe open a launcher killed outright (SIGKILL) would leave the server
    waiting for the pipe to close and the agents waiting for the server to die (their SIGTERM-on-parent-death
    is tied to the server, their parent). Closed, the launcher's death ends the server, and that ends them."""
    server = forkserver._forkserver  # CPython's own; tests/e2e/test_warm_start.py fails if it ever moves
    fd = getattr(server, "_forkserver_alive_fd", None)
    if fd is not None:
        with contextlib.suppress(OSError):
            os.close(fd)
        server._forkserver_alive_fd = None


class WarmProcess:
    """A forked agent behind the part of ``subprocess.Popen``'s interface that ``Children`` uses."""

    def __init__(self, process: multiprocessing.Process) -> None:
        self._process = process

    @property
    def pid(self) -> int:
        return self._process.pid

    @property
    def returncode(self) -> int | None:
        return self._process.exitcode

    def poll(self) -> int | None:
        return self._process.exitcode

    def send_signal(self, signum: int) -> None:
        if self._process.exitcode is None:
            with contextlib.suppress(ProcessLookupError):
                os.kill(self._process.pid, signum)

    def kill(self) -> None:
        self.send_signal(signal.SIGKILL)

    def wait(self, timeout: float | None = None) -> int:
        self._process.join(timeout)
        if self._process.exitcode is None:
            raise subprocess.TimeoutExpired(f"pid {self.pid}", timeout or 0.0)
        return self._process.exitcode


def prestart(preload: Sequence[str]) -> None:
    """Start the warm server now, importing ``preload``, so that its imports overlap what the launcher does before
    it starts the first agent (the world's start, the lander's) instead of holding up that first agent: on two
    cores that is most of a second of a lockstep run's start."""
    _server(preload)
    with _main_left_behind(), _server_spared_ctrl_c():
        forkserver.ensure_running()


def start(module: str, args: Sequence[str], log_path: Path, preload: Sequence[str],
          priority: Priority = "equal") -> WarmProcess:
    """``python -m module args`` with stdout and stderr into ``log_path``, forked from the warm server."""
    # daemon: ended with the launcher's interpreter, as Children's SIGTERM-on-parent-death ends the others
    process = _server(preload).Process(target=_child, args=(module, list(args), str(log_path), priority),
                                       name=module, daemon=True)
    with _main_left_behind(), _server_spared_ctrl_c():
        process.start()
    return WarmProcess(process)


def fork_here(module: str, args: Sequence[str], log_path: Path, priority: Priority = "equal") -> WarmProcess | None:
    """``python -m module args`` forked from this process itself, which has imported much of what ``module``
    needs (the world: the scenario's models; the lander: its own code), or None where that is not safe: only a
    process with a single thread, native ones counted (Zenoh's runtime, once a session has opened), can fork and go
    on in the child."""
    if not available() or not _single_threaded():
        return None
    freeze_before_fork()
    process = multiprocessing.get_context("fork").Process(target=_child, args=(module, list(args), str(log_path),
                                                                               priority), name=module, daemon=True)
    process.start()
    return WarmProcess(process)


def _single_threaded() -> bool:
    try:
        return len(os.listdir("/proc/self/task")) == 1
    except OSError:  # no procfs: the native threads cannot be counted
        return False


@contextlib.contextmanager
def _server_spared_ctrl_c() -> Iterator[None]:
    """Start the server, if this starts it, with Ctrl-C ignored, which it keeps from its first instruction.

    The standard library's server ignores Ctrl-C only once its imports are done, a fifth of a second and more: a
    Ctrl-C before that ended it with a traceback on the user's terminal, and the launcher's next agent with
    "EOFError". Its agents take Ctrl-C back (``_child``). The launcher ignores Ctrl-C the few milliseconds the
    server takes to spawn; only the main thread may change a handler, so elsewhere the server starts as it did."""
    starting = getattr(forkserver._forkserver, "_forkserver_pid", None) is None
    if not starting or threading.current_thread() is not threading.main_thread():
        yield
        return
    previous = signal.signal(signal.SIGINT, signal.SIG_IGN)
    try:
        yield
    finally:
        signal.signal(signal.SIGINT, previous)


_MAIN = importlib.machinery.ModuleSpec("__main__", None)


@contextlib.contextmanager
def _main_left_behind() -> Iterator[None]:
    """Start a child without the launcher's main script.

    The standard library prepares every child it starts by running the parent's ``__main__`` again, as
    ``__mp_main__`` (``multiprocessing.spawn.prepare``), so that functions defined there unpickle; an agent needs
    nothing from it. A launcher's script may be heavy: the scale benchmark's imports NumPy and the world, which
    cost each of 100 warm rovers 0.2 CPU seconds and 14 MiB: they connected in 13-16 s, and without it in 2-3 s.
    A main named ``__main__`` is one the child skips."""
    main = sys.modules["__main__"]
    had, spec = hasattr(main, "__spec__"), getattr(main, "__spec__", None)
    main.__spec__ = _MAIN
    try:
        yield
    finally:
        if had:
            main.__spec__ = spec
        else:
            del main.__spec__
