"""Recovering a recording whose writer died (SIGKILL, power loss) before writing the summary.

MCAP writes data in self-contained chunks, each carrying the schemas and channels its messages use
(or preceded by them), so everything up to the last complete chunk can be read by streaming the file
from the start; the truncated tail is dropped. The result is rewritten as a proper, indexed file.
"""

from __future__ import annotations

import struct
from collections import Counter
from dataclasses import dataclass, field
from pathlib import Path

from mcap.exceptions import McapError
from mcap.records import Channel, Header, Message, Metadata, Schema
from mcap.stream_reader import StreamReader
from mcap.writer import Writer

from schemas.errors import LunarSimError
from sessions.format import PROFILE
from sessions.writer import CHUNK_SIZE, COMPRESSION


class NotARecording(LunarSimError, ValueError):
    """The file does not even start like an MCAP file."""


@dataclass
class Recovered:
    messages: int = 0
    channels: int = 0
    truncated: bool = False
    error: str = ""
    per_key: Counter[str] = field(default_factory=Counter)


def recover(broken: Path, fixed: Path, compression: str = "zstd") -> Recovered:
    """Copy every complete record of ``broken`` into a new, indexed ``fixed``."""
    result = Recovered()
    if broken.stat().st_size == 0:
        raise NotARecording(f"{broken}: empty: its writer never wrote the header")
    with open(broken, "rb") as source, open(fixed, "wb") as target:
        writer = Writer(target, chunk_size=CHUNK_SIZE, compression=COMPRESSION[compression])
        writer.start(profile=PROFILE, library="lunarsim recover")
        copier = _Copier(writer, result)
        try:
            for record in StreamReader(source, emit_chunks=False).records:
                copier.copy(record)
        except McapError as exc:
            if not copier.header:
                fixed.unlink(missing_ok=True)
                raise NotARecording(f"{broken}: not an MCAP recording ({exc})") from None
            result.truncated, result.error = True, _why(exc)
        except (EOFError, ValueError, OSError, KeyError, struct.error) as exc:
            # a chunk cut mid-way, or garbage after it
            result.truncated, result.error = True, _why(exc)
        writer.finish()
    result.channels = len(copier.channels)
    return result


def _why(exc: Exception) -> str:
    return f"{type(exc).__name__}: {exc}" if str(exc) else "the file ends in the middle of a record"


class _Copier:
    """Re-registers schemas and channels in the new file (ids may differ) and copies messages over."""

    def __init__(self, writer: Writer, result: Recovered) -> None:
        self.writer, self.result = writer, result
        self.schemas: dict[int, int] = {}
        self.channels: dict[int, tuple[int, str]] = {}
        self.header = False

    def copy(self, record: object) -> None:
        if isinstance(record, Header):
            self.header = True
        elif isinstance(record, Schema):
            self.schemas[record.id] = self.writer.register_schema(record.name, record.encoding, record.data)
        elif isinstance(record, Channel):
            schema = self.schemas.get(record.schema_id, 0)
            new = self.writer.register_channel(record.topic, record.message_encoding, schema, record.metadata)
            self.channels[record.id] = (new, record.topic)
        elif isinstance(record, Message) and record.channel_id in self.channels:
            channel, topic = self.channels[record.channel_id]
            self.writer.add_message(channel, record.log_time, record.data, record.publish_time, record.sequence)
            self.result.messages += 1
            self.result.per_key[topic] += 1
        elif isinstance(record, Metadata):
            self.writer.add_metadata(record.name, record.metadata)
