"""``lunarsim record``: record every sample of a world (or a filtered set) into an MCAP session file.

Stops on Ctrl-C or SIGTERM and prints what it wrote, what it dropped and the gaps it knows of (spans it missed
while it had lost its router). With ``--snapshot N`` it keeps only the last N seconds and writes them to a new file
on SIGUSR1 or a ``snapshot`` ground command.
"""

from __future__ import annotations

import argparse
import json
import shlex
import signal
import sys
import time
from importlib import metadata
from pathlib import Path

from bus import process
from bus.zenoh_config import add_zenoh_arguments


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("-o", "--output", type=Path, required=True, metavar="FILE.mcap",
                        help="the session file to write")
    parser.add_argument("--world", default="default", help="world name in the keyspace (default: default)")
    parser.add_argument("--topics", nargs="+", metavar="GLOB", help="record only keys matching these globs")
    parser.add_argument("--exclude", nargs="+", metavar="GLOB", help="leave out keys matching these globs")
    parser.add_argument("--compression", choices=["zstd", "lz4", "none"], default="zstd",
                        help="how MCAP chunks are compressed (default zstd)")
    parser.add_argument("--split-size", type=_size, metavar="BYTES", help="start a new file after this much "
                        "payload (suffixes k, M, G)")
    parser.add_argument("--split-duration", type=float, metavar="S", help="start a new file every S seconds")
    parser.add_argument("--snapshot", type=float, metavar="N", help="keep only the last N seconds; write them "
                        "on SIGUSR1 or a 'snapshot' ground command")
    parser.add_argument("--scenario", type=Path, metavar="FILE", help="scenario to embed in the metadata, so "
                        "the recording says how to reproduce itself")
    parser.add_argument("--duration", type=float, metavar="S", help="stop after S seconds")
    add_zenoh_arguments(parser, agent=True)


def _size(text: str) -> int:
    units = {"k": 1 << 10, "m": 1 << 20, "g": 1 << 30}
    try:
        scale = units.get(text[-1].lower(), 1)
        value = int(float(text[:-1] if text[-1].lower() in units else text) * scale)
    except (ValueError, IndexError):
        raise argparse.ArgumentTypeError(f"not a size: {text!r} (e.g. 500M)") from None
    if value <= 0:
        raise argparse.ArgumentTypeError("a size must be positive")
    return value


def session_metadata(world: str, scenario_file: Path | None) -> dict[str, str]:
    """What a recording needs to say how to reproduce itself."""
    info = {"world": world, "software": "lunarsim", "command_line": shlex.join(sys.argv),
            "recorded_at": time.strftime("%Y-%m-%dT%H:%M:%S%z")}
    try:
        info["version"] = metadata.version("lunarsim")
    except metadata.PackageNotFoundError:
        info["version"] = "unknown"
    if scenario_file is not None:
        from schemas.scenario import load_scenario

        scenario = load_scenario(scenario_file)  # validated: a broken scenario is named now, not at replay
        info["scenario"] = scenario_file.read_text(encoding="utf-8")
        info["scenario_name"] = scenario.name
        info["seed"] = str(scenario.seed)
        info["rover_params"] = json.dumps(scenario.rover_params.model_dump())
    return info


def run_from_args(args: argparse.Namespace) -> int:
    from bus.zenoh_config import config_from_args, describe_endpoints, open_session
    from schemas.keyspace import Keyspace, check_world_name
    from sessions.format import TopicFilter
    from sessions.gaps import GapTracker
    from sessions.recorder import Recorder, RollingBuffer, RouterWatch
    from sessions.writer import SplittingWriter

    try:
        check_world_name(args.world)
    except ValueError as exc:
        raise process.UsageError(f"--world: {exc}") from None
    if args.output.suffix != ".mcap":
        raise process.UsageError(f"{args.output}: the output file must end in .mcap")
    if args.snapshot is not None and (args.split_size or args.split_duration):
        raise process.UsageError("--snapshot writes one file per trigger: it cannot be combined with --split-*")
    args.output.parent.mkdir(parents=True, exist_ok=True)
    keys = Keyspace(args.world)
    info = session_metadata(args.world, args.scenario)
    session = open_session(config_from_args(args), describe_endpoints(args), args.router_timeout,
                           who="lunarsim record")
    gaps = GapTracker()
    if args.snapshot is not None:
        sink = RollingBuffer(args.snapshot, args.output, info, args.compression, gaps)
    else:
        sink = SplittingWriter(args.output, info, args.compression, args.split_size, args.split_duration)
    keep = TopicFilter(args.topics, args.exclude)
    with process.stop_on_signals() as stop:
        flush = sink.flush if isinstance(sink, SplittingWriter) else None
        recorder = Recorder(session, keys.all, _with_triggers(sink, keys), keep, flush=flush, clock_key=keys.clock,
                            gaps=gaps)
        watch = RouterWatch(session, gaps)
        watch.poll()
        if isinstance(sink, RollingBuffer):
            signal.signal(signal.SIGUSR1, lambda *_: _snapshot(sink))
        print(f"recording {keys.all} to {args.output}", flush=True)
        deadline = time.monotonic() + args.duration if args.duration else None
        while not stop.wait(0.2):
            watch.poll()
            if deadline is not None and time.monotonic() >= deadline:
                break
        recorder.stop()
        gaps.close(time.time_ns())
    if isinstance(sink, SplittingWriter):
        sink.close(recorder.drops, gaps.metadata())
        files = ", ".join(map(str, sink.files))
        print(f"recorded {sink.count} samples to {files}; dropped {sum(recorder.drops.values())}"
              + (f" ({dict(recorder.drops)})" if recorder.drops else "") + f"; {gaps.summary()}", flush=True)
    else:
        print(f"snapshots written: {len(sink.snapshots)}; {gaps.summary()}", flush=True)
    session.close()
    return 0


def _with_triggers(sink, keys):
    """A sink that also watches ground commands for a ``snapshot`` trigger (snapshot mode only)."""
    from sessions.recorder import RollingBuffer

    if not isinstance(sink, RollingBuffer):
        return sink.write

    from schemas import codec
    from schemas import messages as m

    def write(sample) -> None:
        sink(sample)
        if sample.key == keys.ground_command:
            try:
                command = codec.decode(m.GroundCommand, sample.payload)
            except codec.DecodeError as exc:
                print(f"ignored a malformed ground command: {exc}", file=sys.stderr, flush=True)
                return
            if command.command == "snapshot":
                _snapshot(sink)

    return write


def _snapshot(sink) -> None:
    path = sink.snapshot()
    print(f"snapshot written to {path}", flush=True)
