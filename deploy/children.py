"""Child processes of ``lunarsim run``: started with their logs in the run folder, stopped cleanly.

Every child asks the kernel to send it SIGTERM if the launcher dies, so no process is left orphaned
even when the launcher itself is killed with SIGKILL.
"""

from __future__ import annotations

import os
import signal
import socket
import subprocess
import sys
import threading
import time
from dataclasses import dataclass, field
from functools import partial
from pathlib import Path
from typing import TYPE_CHECKING

from bus.lifeline import die_with_parent
from bus.priority import Priority, lower

if TYPE_CHECKING:
    from deploy.warm_start import WarmProcess

def _child_setup(priority: Priority) -> None:
    die_with_parent()
    lower(priority)


@dataclass
class Children:
    log_dir: Path
    procs: dict[str, subprocess.Popen | WarmProcess] = field(default_factory=dict)
    preload: tuple[str, ...] = ()
    """What the warm server imports before it forks (``start(..., warm=True)``, see ``deploy.warm_start``)."""

    def start(self, name: str, module: str, *args: str, warm: bool = False, forked: bool = False,
              priority: Priority = "equal", prefix: tuple[str, ...] = ()) -> subprocess.Popen | WarmProcess:
        """``python -m module args``, logging into ``<log_dir>/<name>.log``; ``warm``: forked from the warm
        server, for the many agents of one run, which would otherwise each spend their start importing; ``forked``:
        forked from this process itself (``warm_start.fork_here``), for a child that needs much of what it has
        imported (the world and the lander of ``lunarsim run``), else as ``warm`` says where it cannot fork safely;
        ``priority``: its CPU priority against this machine's other processes (``bus.priority``); ``prefix``: a
        command that runs it, such as ``ip netns exec NS`` for another network namespace (never warm: the warm
        server's children share its namespaces)."""
        self.log_dir.mkdir(parents=True, exist_ok=True)
        if forked and not prefix:
            from deploy import warm_start

            if (proc := warm_start.fork_here(module, args, self.log_dir / f"{name}.log", priority)) is not None:
                self.procs[name] = proc
                return proc
        if warm and not prefix:
            from deploy import warm_start

            if warm_start.available():
                proc = self.procs[name] = warm_start.start(module, args, self.log_dir / f"{name}.log", self.preload,
                                                           priority)
                return proc
        log = open(self.log_dir / f"{name}.log", "wb")  # noqa: SIM115 - owned by the child for its lifetime
        proc = subprocess.Popen([*prefix, sys.executable, "-P", "-m", module, *args], stdout=log,
                                stderr=subprocess.STDOUT, stdin=subprocess.DEVNULL,
                                preexec_fn=partial(_child_setup, priority), env=environment())
        log.close()
        self.procs[name] = proc
        return proc

    def warm_up(self) -> None:
        """Have the warm server import ``preload`` now, while other children start (``warm_start.prestart``)."""
        from deploy import warm_start

        if warm_start.available():
            warm_start.prestart(self.preload)

    def dead(self) -> dict[str, int]:
        return {name: p.returncode for name, p in self.procs.items() if p.poll() is not None}

    def log_tail(self, name: str, lines: int = 5) -> str:
        try:
            text = (self.log_dir / f"{name}.log").read_text(errors="replace").strip().splitlines()
        except OSError:
            return ""
        return "\n".join(text[-lines:])

    def wait_for_line(self, name: str, text: str, timeout_s: float, stop: threading.Event) -> bool:
        """True once ``name``'s log holds a line with ``text`` (what it says once it serves: its own word, where a
        port that answers may be another run's); False if it exits, ``timeout_s`` passes or ``stop`` is set."""
        proc, path, deadline = self.procs[name], self.log_dir / f"{name}.log", time.monotonic() + timeout_s
        while not stop.is_set() and time.monotonic() < deadline:
            try:
                if text in path.read_text(errors="replace"):
                    return True
            except OSError:
                pass
            if proc.poll() is not None:
                return False
            time.sleep(START_POLL_S)
        return False

    def stop(self, names: list[str] | None = None, grace_s: float = 5.0) -> None:
        """SIGTERM, wait up to ``grace_s``, then SIGKILL what is left."""
        targets = [self.procs[n] for n in (names or list(self.procs)) if n in self.procs]
        for p in targets:
            if p.poll() is None:
                p.send_signal(signal.SIGTERM)
        deadline = time.monotonic() + grace_s
        for p in targets:
            try:
                p.wait(timeout=max(0.0, deadline - time.monotonic()))
            except subprocess.TimeoutExpired:
                p.kill()
                p.wait()


START_POLL_S = 0.01
"""Between two looks at whether a child has started (``wait_for_port``, ``Children.wait_for_line``): a run's agents
start once its world listens, so a coarser poll is that much longer a start."""


def wait_for_port(host: str, port: int, timeout_s: float, proc: subprocess.Popen | None = None) -> bool:
    """True once something accepts TCP connections on host:port; False on timeout or if ``proc`` exits."""
    deadline = time.monotonic() + timeout_s
    while time.monotonic() < deadline:
        if proc is not None and proc.poll() is not None:
            return False
        with socket.socket() as s:
            s.settimeout(0.2)
            if s.connect_ex((host, port)) == 0:
                return True
        time.sleep(START_POLL_S)
    return False


def environment() -> dict[str, str]:
    env = dict(os.environ)
    env.setdefault("PYTHONUNBUFFERED", "1")
    return env
