"""The LunarSim session file: MCAP, one channel per key, the original msgpack payloads.

What a recording holds, so any MCAP tool can read it without our code:
- one channel per key expression (the channel's topic is the key), message encoding ``msgpack``;
- each channel's schema, encoding ``jsonschema``: the message model's JSON Schema (msgspec's) wrapped in our
  codec's envelope ``[schema_version, {fields}]``; keys that carry no LunarSim message get none;
- per message, ``log_time`` = when the recorder received it and ``publish_time`` = the publisher's
  Zenoh timestamp (the receive time where a publisher sent none), both in Unix nanoseconds;
- metadata ``lunarsim.session``: the scenario (YAML), seed, world, software version and command line, so
  a recording says how to reproduce itself; ``lunarsim.drops``: samples lost per key, written at the end;
  ``lunarsim.gaps``: the spans the recorder missed because it had lost its router (``sessions.gaps``).

A file ends with MCAP's magic bytes once its writer has closed it: one that does not was cut short (its recorder was
killed, the disk filled) and ``lunarsim recover`` rewrites what it holds.
"""

from __future__ import annotations

import heapq
import json
import shlex
from collections.abc import Callable, Iterator
from dataclasses import dataclass
from fnmatch import fnmatchcase
from pathlib import Path
from typing import TYPE_CHECKING, BinaryIO

import msgspec

from bus.errors import UsageError
from schemas import codec
from schemas.messages import Message, model_for_key

if TYPE_CHECKING:
    from schemas.scenario import Scenario

PROFILE = "lunarsim"
MESSAGE_ENCODING = "msgpack"
SCHEMA_ENCODING = "jsonschema"
SESSION_METADATA = "lunarsim.session"
DROPS_METADATA = "lunarsim.drops"
GAPS_METADATA = "lunarsim.gaps"
MCAP_MAGIC = b"\x89MCAP0\r\n"


class BadRecording(UsageError):
    """A session file a command cannot use; the message names the file and says why (exit 2)."""


class CutShort(BadRecording):
    """The file does not end as a closed MCAP file does: its writer was stopped before finishing it."""


@dataclass(frozen=True)
class Sample:
    key: str
    payload: bytes
    log_time_ns: int
    publish_time_ns: int


def schema_for(model: type[Message]) -> bytes:
    """JSON Schema of a payload as it travels: the codec's ``[version, fields]`` envelope around the model, the
    models it refers to under ``$defs``."""
    _, defs = msgspec.json.schema_components([model], ref_template="#/$defs/{name}")
    fields = defs.pop(model.__name__)
    schema = {
        "title": model.__name__,
        "description": (model.__doc__ or "").strip().splitlines()[0] if model.__doc__ else model.__name__,
        "type": "array",
        "prefixItems": [{"const": codec.SCHEMA_VERSION, "description": "schema version"},
                        fields],
        "minItems": 2,
        "maxItems": 2,
        **({"$defs": defs} if defs else {}),
    }
    return json.dumps(schema, separators=(",", ":")).encode()


def schema_of_key(key: str) -> tuple[str, bytes] | None:
    """(schema name, schema data) for a key, or None if the key carries no LunarSim message."""
    model = model_for_key(key)
    return (model.__name__, schema_for(model)) if model else None


class TopicFilter:
    """``--topics`` / ``--exclude`` globs over keys (``*`` matches across ``/`` too)."""

    def __init__(self, topics: list[str] | None = None, exclude: list[str] | None = None) -> None:
        self.topics = list(topics or [])
        self.exclude = list(exclude or [])

    def __call__(self, key: str) -> bool:
        if self.topics and not any(fnmatchcase(key, g) for g in self.topics):
            return False
        return not any(fnmatchcase(key, g) for g in self.exclude)


READ_WINDOW_BYTES = 512 * 2**20
"""Chunk bytes that reading in log-time order may hold at once: chunks whose times overlap are unpacked together.
A recorder writes them in time order; a file whose chunks all overlap would be unpacked whole (1.7 GB from 5 MB)."""


def read_samples(path: str | Path | BinaryIO, keep: Callable[[str], bool] | None = None,
                 start_ns: int | None = None) -> Iterator[Sample]:
    """Every sample of a recording in log-time order (those whose key ``keep`` accepts, from ``start_ns`` on).
    A file whose overlapping chunks hold more than ``READ_WINDOW_BYTES`` at once is a ``BadRecording``."""
    from mcap.reader import make_reader

    with _open(path) as stream:
        reader = make_reader(stream)
        summary = reader.get_summary()
        if summary is not None and (held := overlap_bytes(summary.chunk_indexes)) > READ_WINDOW_BYTES:
            name = path if isinstance(path, str | Path) else getattr(path, "name", "the recording")
            raise BadRecording(f"{name}: its chunks overlap in time, {held / 2**20:.0f} MiB to unpack at once to "
                               f"read it in order (at most {READ_WINDOW_BYTES / 2**20:.0f}): not as a recorder "
                               "writes one")
        for _, channel, message in reader.iter_messages(start_time=start_ns, log_time_order=True):
            if keep is None or keep(channel.topic):
                yield Sample(channel.topic, bytes(message.data), message.log_time, message.publish_time)


def overlap_bytes(chunks: list) -> int:
    """The most uncompressed chunk bytes whose log-time ranges meet at one time (``mcap`` ChunkIndex records)."""
    ends: list[tuple[int, int]] = []  # (end time, size) of the chunks still open, a heap
    held = most = 0
    for chunk in sorted(chunks, key=lambda c: c.message_start_time):
        while ends and ends[0][0] < chunk.message_start_time:
            held -= heapq.heappop(ends)[1]
        heapq.heappush(ends, (chunk.message_end_time, chunk.uncompressed_size))
        held += chunk.uncompressed_size
        most = max(most, held)
    return most


def read_metadata(path: str | Path) -> dict[str, dict[str, str]]:
    from mcap.reader import make_reader

    with _open(path) as stream:
        return {record.name: dict(record.metadata) for record in make_reader(stream).iter_metadata()}


def time_range(path: str | Path) -> tuple[int, int]:
    """(first, last) log time in ns, from the summary."""
    from mcap.reader import make_reader

    with _open(path) as stream:
        summary = make_reader(stream).get_summary()
    stats = summary.statistics if summary else None
    if stats is None or stats.message_count == 0:
        return 0, 0
    return stats.message_start_time, stats.message_end_time


def scenario_for(recording: str | Path, override: str | Path | None = None) -> Scenario | None:
    """The scenario of a recording: ``override`` (a file), else the YAML the recorder embedded, else None.

    Raises ``ScenarioError`` or ``BadRecording`` naming the file when it cannot be used.
    """
    from schemas.scenario import load_scenario

    if override is not None:
        return load_scenario(override)
    path = Path(recording)
    check_file(path)
    try:
        metadata = read_metadata(path)
    except Exception as exc:  # the mcap reader raises many kinds on damaged files
        raise BadRecording(damaged(path, exc)) from None
    return embedded_scenario(metadata, str(recording))


def embedded_scenario(metadata: dict[str, dict[str, str]], source: str) -> Scenario | None:
    """The scenario a recording's metadata holds, read with the bounds of a scenario file (None if it holds none)."""
    import yaml

    from schemas.scenario import ScenarioError, parse_scenario
    from schemas.scenario_files import load_yaml_text
    from schemas.scenario_limits import MAX_SCENARIO_BYTES, clip

    text = metadata.get(SESSION_METADATA, {}).get("scenario")
    if not text:
        return None
    if len(text.encode("utf-8", "replace")) > MAX_SCENARIO_BYTES:
        raise ScenarioError(f"{source}: the embedded scenario is larger than {MAX_SCENARIO_BYTES // 1024**2} MiB")
    try:
        data = load_yaml_text(text)
    except yaml.YAMLError as exc:
        problem = clip(str(getattr(exc, "problem", None) or exc))
        raise ScenarioError(f"{source}: the embedded scenario is not valid YAML: {problem}") from None
    except (ValueError, RecursionError) as exc:  # a scalar YAML cannot build, deep nesting
        raise ScenarioError(f"{source}: the embedded scenario cannot be read: {clip(str(exc))}") from None
    return parse_scenario(data, f"{source} (embedded scenario)")


def check_file(path: Path) -> None:
    """A path that can hold a recording: a regular, non-empty MCAP file that its writer finished (``CutShort``
    otherwise, with the command that mends it). Says nothing of what the file holds (``sessions.recording``)."""
    if not path.exists():
        raise BadRecording(f"{path}: no such file")
    if not path.is_file():
        raise BadRecording(f"{path}: not a file")
    size = path.stat().st_size
    if size == 0:
        raise BadRecording(f"{path}: not a readable MCAP recording (the file is empty)")
    with path.open("rb") as stream:
        head = stream.read(len(MCAP_MAGIC))
        stream.seek(max(0, size - len(MCAP_MAGIC)))
        tail = stream.read(len(MCAP_MAGIC))
    if head != MCAP_MAGIC:
        raise BadRecording(f"{path}: not an MCAP file (expected a recording made by 'lunarsim record' or "
                           "'lunarsim run')")
    if tail != MCAP_MAGIC or size < 2 * len(MCAP_MAGIC):
        raise CutShort(cut_short(path))


def cut_short(path: Path) -> str:
    """The line for a file that ends early, with the command that mends it."""
    fixed = path.with_name(f"{path.stem}-fixed{path.suffix or '.mcap'}")
    return (f"{path}: the file ends early (its writer never finished it: a recorder killed, a disk full); run "
            f"'lunarsim recover {shlex.quote(str(path))} -o {shlex.quote(str(fixed))}' and use the recovered file")


def damaged(path: Path, exc: BaseException) -> str:
    """The line for a file the reader fails on part way (a corrupt chunk, a record too long for the file)."""
    text = str(exc).strip()
    detail = escaped(text.splitlines()[0], 200) if text else type(exc).__name__
    return f"{path}: damaged MCAP recording ({detail}); try 'lunarsim recover {shlex.quote(str(path))} -o FIXED.mcap'"


def escaped(text: str, limit: int = 60) -> str:
    """``text`` cut at ``limit``, as it is when printable, else as its ``repr``."""
    cut = text[:limit] + ("..." if len(text) > limit else "")
    return cut if cut.isprintable() else repr(cut)


def decode(sample: Sample) -> Message | None:
    """The message of a sample, or None for keys without a model (raises codec.DecodeError)."""
    model = model_for_key(sample.key)
    return codec.decode(model, sample.payload) if model else None


class _open:
    """Open a path, or pass an open binary stream through untouched."""

    def __init__(self, path: str | Path | BinaryIO) -> None:
        self.path = path
        self.stream: BinaryIO | None = None

    def __enter__(self) -> BinaryIO:
        if isinstance(self.path, (str, Path)):
            self.stream = open(self.path, "rb")
            return self.stream
        return self.path

    def __exit__(self, *exc: object) -> None:
        if self.stream is not None:
            self.stream.close()
