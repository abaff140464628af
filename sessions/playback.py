"""A recording published onto Zenoh again with its original timing, and its controls (``lunarsim replay``).

``replay`` checks that something is left to play, plays on a worker thread (``sessions.replay.Player``), and keeps
the main thread for signals, the progress bar and the terminal's keys (space pauses and resumes, ``s`` or the right
arrow steps, ``q`` quits); ``pause``/``resume``/``step``/``seek`` ground commands on the target world control it
too, except those the replay itself publishes from the recording. Its liveliness token says whether it plays.
"""

from __future__ import annotations

import contextlib
import os
import select
import sys
import threading
import time
from collections.abc import Callable, Iterator
from dataclasses import dataclass, replace
from pathlib import Path
from typing import TYPE_CHECKING

from bus import process

if TYPE_CHECKING:
    import zenoh

    from sessions.recording import Recording

ESC_RIGHT = b"\x1b[C"


@dataclass(frozen=True)
class ReplaySpec:
    """How to play a recording: the options of ``lunarsim replay`` (its ``--help`` says what each does)."""

    rate: float = 1.0
    loop: bool = False
    topics: list[str] | None = None
    exclude: list[str] | None = None
    start_offset: float = 0.0
    remap_world: str | None = None
    clock: bool = False
    start_paused: bool = False
    quiet: bool = False


def open_recording(path: Path) -> Recording:
    """The file checked as a LunarSim recording with samples to play; every failure is a one-line UsageError naming
    it, raised before any Zenoh session opens. Foreign channels are skipped, and said to be."""
    from sessions.recording import check_recording

    recording = check_recording(path)
    first = next(recording.samples(), None)
    if first is None:
        raise process.UsageError(f"{path}: the recording is empty (no samples)")
    if recording.foreign:  # the file's time range counts the skipped channels too: take ours alone
        last = max(s.log_time_ns for s in recording.samples())
        recording = replace(recording, first_ns=first.log_time_ns, last_ns=last)
    for note in (recording.foreign_note(), recording.gap_note()):
        if note:
            print(f"warning: {note}", file=sys.stderr, flush=True)
    return recording


def replay(recording: Recording, spec: ReplaySpec, open_zenoh: Callable[[], zenoh.Session]) -> int:
    """Play ``recording`` as ``spec`` says on the session ``open_zenoh`` opens; the exit code (130 if stopped)."""
    from sessions.format import TopicFilter
    from sessions.replay import CLOCK_GLOB, Player, prefetch, world_remapper

    keep = TopicFilter(spec.topics, [*(spec.exclude or []), *([] if spec.clock else [CLOCK_GLOB])])
    if next(recording.samples(keep), None) is None:
        raise process.UsageError(f"{recording.path}: no samples left after --topics/--exclude"
                                 + ("" if spec.clock else " (the world clock is left out without --clock)"))
    target = spec.remap_world
    if target and recording.world is None:
        raise process.UsageError(f"{recording.path}: cannot tell which world was recorded, so cannot --remap-world")
    world = target or recording.world or "default"
    remap = world_remapper(recording.world, target) if target and recording.world else None
    return _play(spec, recording, world, open_zenoh, lambda publish: Player(
        lambda start_ns: prefetch(recording.samples(keep, start_ns)), publish, rate=spec.rate,
        loop=spec.loop, start_offset_s=spec.start_offset, paused=spec.start_paused, remap=remap,
        first_ns=recording.first_ns, last_ns=recording.last_ns))


def _play(spec: ReplaySpec, recording: Recording, world: str, open_zenoh: Callable[[], zenoh.Session],
          make_player) -> int:
    """Open Zenoh, play on a worker thread, and keep the main thread for signals and the progress bar."""
    from bus.bus import Bus
    from schemas.keyspace import Keyspace
    from sessions.replay import ReplayToken

    keys = Keyspace(world)
    session = open_zenoh()
    with Bus(session, lossless=True) as bus:
        own = OwnCommands(keys.ground_command)
        player = make_player(own.wrap(bus.put))
        commands = session.declare_subscriber(keys.ground_command, _command_handler(player, own))
        token = ReplayToken(session.liveliness().declare_token, keys)
        token.show(player.paused)
        print(f"replaying {recording.path} ({player.duration_s:.1f} s, world {recording.world} -> {world}) "
              f"at rate {spec.rate:g}" + (" - paused" if spec.start_paused else ""), flush=True)
        started = time.monotonic()
        try:
            interrupted = _run_with_controls(player, spec.quiet, token)
        finally:
            commands.undeclare()
            token.close()
    print(f"replayed {player.published} samples in {time.monotonic() - started:.1f} s"
          + (f" ({player.loops} loops)" if player.loops else "") + (" - interrupted" if interrupted else ""),
          flush=True)
    return process.EXIT_INTERRUPTED if interrupted else 0


def _run_with_controls(player, quiet: bool, token) -> bool:
    """Play to the end; True if stopped by Ctrl-C or SIGTERM. A failure of the player is raised here. The replay's
    token follows the player's pause every tenth of a second."""
    failure: list[BaseException] = []

    def play() -> None:
        try:
            player.run()
        except BaseException as exc:  # handed to the main thread, which reports it
            failure.append(exc)

    worker = threading.Thread(target=play, name="replay-player", daemon=True)
    interrupted = False
    with process.stop_on_signals() as stop, keyboard(player), progress(player, quiet) as update:
        worker.start()
        while worker.is_alive():
            if stop.wait(0.1):
                interrupted = True
                player.quit()
                worker.join()
            update()
            token.show(player.paused)
    if failure:
        raise failure[0]
    return interrupted


class OwnCommands:
    """Ground commands this replay publishes itself (from the recording) must not control it."""

    def __init__(self, key: str) -> None:
        self.key = key
        self.payloads: list[bytes] = []
        self._lock = threading.Lock()

    def wrap(self, put):
        def publish(key: str, payload: bytes) -> None:
            if key == self.key:
                with self._lock:
                    self.payloads.append(payload)
            put(key, payload)

        return publish

    def is_own(self, payload: bytes) -> bool:
        with self._lock:
            if payload in self.payloads:
                self.payloads.remove(payload)
                return True
        return False


def _command_handler(player, own: OwnCommands):
    """Zenoh callback: playback ground commands become player controls; others are not ours."""
    from schemas import codec
    from schemas import messages as m

    def handle(sample) -> None:
        payload = sample.payload.to_bytes()
        if own.is_own(payload):
            return
        try:
            command = codec.decode(m.GroundCommand, payload)
        except codec.DecodeError as exc:
            print(f"replay: ignored a malformed ground command: {exc}", file=sys.stderr, flush=True)
            return
        if command.command not in m.PLAYBACK_COMMANDS:
            return
        if command.command == "seek" and command.seconds is None:
            print("replay: ignored a seek command without seconds", file=sys.stderr, flush=True)
            return
        player.control(command.command, command.seconds or 0.0)

    return handle


def keys_to_controls(data: bytes) -> list[str]:
    """Keyboard bytes to controls: space toggles, ``s`` or the right arrow steps, ``q`` quits."""
    controls = ["step"] * data.count(ESC_RIGHT)
    for char in data.replace(ESC_RIGHT, b"").decode(errors="ignore").lower():
        control = {" ": "toggle", "s": "step", "q": "quit"}.get(char)
        if control:
            controls.append(control)
    return controls


@contextlib.contextmanager
def keyboard(player) -> Iterator[None]:
    """Read single keys from a terminal on stdin (cbreak mode, restored on exit); nothing otherwise."""
    if not sys.stdin.isatty():
        yield
        return
    import termios
    import tty

    fd = sys.stdin.fileno()
    saved = termios.tcgetattr(fd)
    done = threading.Event()

    def read() -> None:
        while not done.is_set():
            if select.select([fd], [], [], 0.1)[0]:
                for control in keys_to_controls(os.read(fd, 64)):
                    player.control(control)

    tty.setcbreak(fd)  # keys arrive one by one; Ctrl-C still raises SIGINT
    reader = threading.Thread(target=read, name="replay-keyboard", daemon=True)
    reader.start()
    try:
        yield
    finally:
        done.set()
        reader.join(timeout=1)
        termios.tcsetattr(fd, termios.TCSADRAIN, saved)


@contextlib.contextmanager
def progress(player, quiet: bool) -> Iterator:
    """A rich progress bar of position / duration on a terminal; yields the function that refreshes it."""
    from rich.console import Console

    console = Console()
    if quiet or not console.is_terminal:
        yield lambda: None
        return
    from rich.progress import BarColumn, Progress, TextColumn

    columns = (TextColumn("[bold]{task.fields[state]}"), BarColumn(),
               TextColumn("{task.completed:.1f} / {task.total:.1f} s"), TextColumn("{task.fields[hint]}"))
    with Progress(*columns, console=console, transient=False) as bar:
        hint = "space pause · s step · q quit" if sys.stdin.isatty() else ""
        task = bar.add_task("replay", total=max(player.duration_s, 1e-9), state="playing", hint=hint)

        def update() -> None:
            bar.update(task, completed=player.position_s, state="paused" if player.paused else "playing")

        yield update
        update()
