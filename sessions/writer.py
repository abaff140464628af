"""Writing session files: channels registered on first use, chunked and compressed, split by size or time."""

from __future__ import annotations

import json
from collections import Counter
from pathlib import Path
from typing import BinaryIO

from mcap.writer import CompressionType, Writer

from sessions.format import (
    DROPS_METADATA,
    GAPS_METADATA,
    MESSAGE_ENCODING,
    PROFILE,
    SCHEMA_ENCODING,
    SESSION_METADATA,
    Sample,
    schema_of_key,
)

COMPRESSION = {"zstd": CompressionType.ZSTD, "lz4": CompressionType.LZ4, "none": CompressionType.NONE}
CHUNK_SIZE = 1 << 20
"""Bytes per chunk at most; the recorder also closes a chunk every ``FLUSH_S`` (``lunarsim recover`` keeps
every closed chunk of a file whose writer was killed)."""


class SessionWriter:
    """One MCAP file. ``write`` takes samples of any key; ``close`` writes the drop counts, the gaps and the index."""

    def __init__(self, path: Path | BinaryIO, session: dict[str, str] | None = None,
                 compression: str = "zstd", chunk_size: int = CHUNK_SIZE) -> None:
        if compression not in COMPRESSION:
            raise ValueError(f"compression must be one of {', '.join(COMPRESSION)}, got {compression!r}")
        self.path = path if isinstance(path, Path) else None
        self._stream = open(path, "wb") if isinstance(path, Path) else path  # noqa: SIM115 - closed in close()
        self._writer = Writer(self._stream, chunk_size=chunk_size, compression=COMPRESSION[compression])
        self._writer.start(profile=PROFILE, library="lunarsim")
        self._channels: dict[str, int] = {}
        self._schemas: dict[str, int] = {}
        self.bytes_written = 0
        self.first_ns: int | None = None
        self.count = 0
        if session:
            self._writer.add_metadata(SESSION_METADATA, session)
        self.flush()  # the header and the session are on disk before the first sample

    def flush(self) -> None:
        """Close the chunk in progress and hand it to the OS: what a SIGKILL can lose ends here."""
        self._writer.flush()

    def write(self, sample: Sample) -> None:
        channel = self._channels.get(sample.key)
        if channel is None:
            channel = self._channels[sample.key] = self._register(sample.key)
        self._writer.add_message(channel, log_time=sample.log_time_ns, publish_time=sample.publish_time_ns,
                                 data=sample.payload, sequence=self.count & 0xFFFFFFFF)
        self.count += 1
        self.bytes_written += len(sample.payload)
        if self.first_ns is None:
            self.first_ns = sample.log_time_ns

    def _register(self, key: str) -> int:
        schema_id = 0
        described = schema_of_key(key)
        if described is not None:
            name, data = described
            schema_id = self._schemas.get(name, 0)
            if not schema_id:
                schema_id = self._schemas[name] = self._writer.register_schema(name, SCHEMA_ENCODING, data)
        return self._writer.register_channel(key, MESSAGE_ENCODING, schema_id)

    def close(self, drops: Counter[str] | None = None, gaps: dict[str, str] | None = None) -> None:
        """``gaps``: the ``lunarsim.gaps`` record (``GapTracker.metadata``), left out when nobody tracked gaps."""
        self._writer.add_metadata(DROPS_METADATA, {"total": str(sum((drops or Counter()).values())),
                                                   "per_key": json.dumps(dict(drops or {}))})
        if gaps is not None:
            self._writer.add_metadata(GAPS_METADATA, gaps)
        self._writer.finish()
        if self.path is not None:
            self._stream.close()


class SplittingWriter:
    """Writes ``NAME.mcap``, or ``NAME-000.mcap``, ``NAME-001.mcap``... when split by size or duration."""

    def __init__(self, path: Path, session: dict[str, str] | None = None, compression: str = "zstd",
                 split_size: int | None = None, split_duration_s: float | None = None) -> None:
        self.base, self.session, self.compression = path, session, compression
        self.split_size, self.split_ns = split_size, int(split_duration_s * 1e9) if split_duration_s else None
        self.splitting = bool(split_size or split_duration_s)
        self.files: list[Path] = []
        self.count = 0
        self._current = self._open()

    def _open(self) -> SessionWriter:
        path = self.base.with_name(f"{self.base.stem}-{len(self.files):03d}{self.base.suffix}") \
            if self.splitting else self.base
        self.files.append(path)
        return SessionWriter(path, self.session, self.compression)

    def write(self, sample: Sample) -> None:
        current = self._current
        full = self.split_size and current.bytes_written >= self.split_size
        old = self.split_ns and current.first_ns is not None and sample.log_time_ns - current.first_ns >= self.split_ns
        if full or old:
            current.close()
            self._current = current = self._open()
        current.write(sample)
        self.count += 1

    def flush(self) -> None:
        self._current.flush()

    def close(self, drops: Counter[str] | None = None, gaps: dict[str, str] | None = None) -> None:
        """Drops and gaps go into the last file: they are the whole recording's."""
        self._current.close(drops, gaps)
