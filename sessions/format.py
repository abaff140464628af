"""The LunarSim session file: MCAP, one channel per key, the original msgpack payloads.

What a recording holds, so any MCAP tool can read it without our code:
- one channel per key expression (the channel's topic is the key), message encoding ``msgpack``;
- each channel's schema, encoding ``jsonschema``: the pydantic model's JSON Schema wrapped in our
  codec's envelope ``[schema_version, {fields}]``; keys that carry no LunarSim message get none;
- per message, ``log_time`` = when the recorder received it and ``publish_time`` = the publisher's
  Zenoh timestamp (the receive time where a publisher sent none), both in Unix nanoseconds;
- metadata ``lunarsim.session``: the scenario (YAML), seed, world, software version and command line, so
  a recording says how to reproduce itself; ``lunarsim.drops``: samples lost per key, written at the end.
"""

from __future__ import annotations

import json
from collections.abc import Iterator
from dataclasses import dataclass
from fnmatch import fnmatchcase
from pathlib import Path
from typing import TYPE_CHECKING, BinaryIO

from schemas import codec
from schemas.messages import Message, model_for_key

if TYPE_CHECKING:
    from schemas.scenario import Scenario

PROFILE = "lunarsim"
MESSAGE_ENCODING = "msgpack"
SCHEMA_ENCODING = "jsonschema"
SESSION_METADATA = "lunarsim.session"
DROPS_METADATA = "lunarsim.drops"


@dataclass(frozen=True)
class Sample:
    key: str
    payload: bytes
    log_time_ns: int
    publish_time_ns: int


def schema_for(model: type[Message]) -> bytes:
    """JSON Schema of a payload as it travels: the codec's ``[version, fields]`` envelope around the model."""
    schema = {
        "title": model.__name__,
        "description": (model.__doc__ or "").strip().splitlines()[0] if model.__doc__ else model.__name__,
        "type": "array",
        "prefixItems": [{"const": codec.SCHEMA_VERSION, "description": "schema version"},
                        model.model_json_schema()],
        "minItems": 2,
        "maxItems": 2,
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


def read_samples(path: str | Path | BinaryIO, keep: TopicFilter | None = None,
                 start_ns: int | None = None) -> Iterator[Sample]:
    """Every sample of a recording in log-time order (optionally filtered, from ``start_ns`` on)."""
    from mcap.reader import make_reader

    with _open(path) as stream:
        reader = make_reader(stream)
        for _, channel, message in reader.iter_messages(start_time=start_ns, log_time_order=True):
            if keep is None or keep(channel.topic):
                yield Sample(channel.topic, bytes(message.data), message.log_time, message.publish_time)


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

    Raises ``ScenarioError`` naming the recording when it cannot be read or its scenario is broken.
    """
    import yaml

    from schemas.scenario import ScenarioError, load_scenario, parse_scenario

    if override is not None:
        return load_scenario(override)
    try:
        text = read_metadata(recording).get(SESSION_METADATA, {}).get("scenario")
    except Exception as exc:  # the mcap reader raises many kinds; all mean an unreadable recording
        empty = Path(recording).is_file() and Path(recording).stat().st_size == 0
        detail = "the file is empty" if empty else str(exc) or type(exc).__name__
        raise ScenarioError(f"{recording}: not a readable MCAP recording ({detail})") from None
    if not text:
        return None
    try:
        data = yaml.safe_load(text)
    except yaml.YAMLError as exc:
        raise ScenarioError(f"{recording}: the embedded scenario is not valid YAML: {exc}") from None
    return parse_scenario(data, f"{recording} (embedded scenario)")


def decode(sample: Sample) -> Message | None:
    """The pydantic message of a sample, or None for keys without a model (raises codec.DecodeError)."""
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
