"""A recording converted to Foxglove channels (``lunarsim export-foxglove``): the static scene once, then the rovers,
trails and radio links of every world state on ``/scene``, ``/tf``, the photos and the lander's map, all in
Foxglove's own protobuf schemas; with ``keep_raw`` the original msgpack channels too.
"""

from __future__ import annotations

import sys
from collections import Counter
from pathlib import Path
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from mcap.writer import Writer

    from schemas.scenario import Scenario
    from sessions.format import Sample
    from sessions.recording import Recording


class FoxgloveFile:
    """The output MCAP: Foxglove channels registered on first use with the SDK's own protobuf schemas, each schema
    written once and shared by every channel of its type (one ``CompressedImage`` for all the rovers' photos)."""

    def __init__(self, writer: Writer) -> None:
        self.writer = writer
        self.channels: dict[str, int] = {}
        self.schemas: dict[str, int] = {}
        self.counts: Counter[str] = Counter()

    def write(self, topic: str, message, ns: int) -> None:
        """``message`` is any ``foxglove.messages`` type: ``encode()`` gives the protobuf bytes."""
        channel = self.channels.get(topic)
        if channel is None:
            channel = self.channels[topic] = self.writer.register_channel(topic, "protobuf", self._schema(message))
        self.writer.add_message(channel, log_time=ns, publish_time=ns, data=message.encode())
        self.counts[type(message).__name__] += 1

    def _schema(self, message) -> int:
        schema = type(message).get_schema()
        if schema.name not in self.schemas:
            self.schemas[schema.name] = self.writer.register_schema(schema.name, schema.encoding, schema.data)
        return self.schemas[schema.name]


MAX_TERRAIN_CELLS = 2048
"""Terrain mesh nodes along the longer side at most: 2,048 squared is four million vertices, more than a viewer
draws smoothly; 100,000 asked for 70 GB."""


def export_foxglove(source: Recording, target: Path, scenario: Scenario | None, keep_raw: bool = False,
                    trail_points: int = 300, terrain_cells: int = 128, progress: bool = False) -> dict[str, int]:
    """Convert a checked recording (its LunarSim keys only); written to a temporary file first, so a failure leaves
    no half file behind.

    Returns how many messages of each kind were written (for the summary line and tests).
    """
    from mcap.writer import CompressionType, Writer

    tmp = target.with_name(target.name + ".part")
    target.parent.mkdir(parents=True, exist_ok=True)
    try:
        with open(tmp, "wb") as stream:
            writer = Writer(stream, compression=CompressionType.ZSTD)
            writer.start(profile="", library="lunarsim export-foxglove")
            out = FoxgloveFile(writer)
            raw = _RawCopy(writer, source.metadata) if keep_raw else None
            converter = _Converter(scenario, out, trail_points, terrain_cells)
            for sample in _with_progress(source.samples(), source.messages, progress):
                converter.add(sample)
                if raw is not None:
                    raw.write(sample)
            converter.finish(source.first_ns)
            writer.finish()
        tmp.replace(target)
    except Exception:
        tmp.unlink(missing_ok=True)
        raise
    counts = dict(out.counts)
    if raw is not None:
        counts["raw"] = raw.count
    return counts


class _Converter:
    """Sample by sample: the static scene before the first message, then states and photos as they come."""

    def __init__(self, scenario: Scenario | None, out: FoxgloveFile, trail_points: int, terrain_cells: int) -> None:
        from sessions import foxglove as fx

        self.fx, self.out, self.scenario = fx, out, scenario
        self.grid = _terrain(scenario, terrain_cells) if scenario is not None else None
        self.dynamic = fx.DynamicScene(scenario, self.grid, trail_points) if scenario is not None else None
        self.first_ns: int | None = None

    def add(self, sample: Sample) -> None:
        from schemas.codec import DecodeError
        from schemas.messages import LanderMap, Photo, WorldState
        from sessions.format import decode

        fx = self.fx
        if not (fx.is_state_key(sample.key) or fx.is_photo_key(sample.key) or fx.is_map_key(sample.key)):
            return
        self._start(sample.log_time_ns)
        try:
            message = decode(sample)
        except DecodeError as exc:
            print(f"warning: skipped a malformed sample on {sample.key}: {exc}", file=sys.stderr)
            return
        ns = sample.log_time_ns
        if isinstance(message, WorldState):
            if self.dynamic is not None:
                self.out.write(fx.SCENE_TOPIC, self.dynamic.update(message, ns), ns)
            ground = self.dynamic.ground if self.dynamic is not None else None
            for transform in fx.transforms(message, ns, ground):
                self.out.write(fx.TF_TOPIC, transform, ns)
        elif isinstance(message, Photo):
            rover = fx.rover_of_key(sample.key)
            self.out.write(fx.photo_topic(rover), fx.photo_image(message, rover, ns), ns)
        elif isinstance(message, LanderMap):
            try:
                self.out.write(fx.MAP_TOPIC, fx.map_grid(message, ns, fx.map_elevation(self.grid)), ns)
            except ValueError as exc:
                print(f"warning: skipped a lander map on {sample.key}: {exc}", file=sys.stderr)

    def _start(self, ns: int) -> None:
        """The static scene goes first, stamped with the recording's first time, so it is there from the start."""
        if self.first_ns is None:
            self.first_ns = ns
            if self.scenario is not None and self.grid is not None:
                self.out.write(self.fx.SCENE_TOPIC, self.fx.static_scene(self.scenario, self.grid, ns), ns)

    def finish(self, start_ns: int) -> None:
        """A recording without states or photos still gets its static scene."""
        self._start(start_ns)


def _terrain(scenario: Scenario, cells: int):
    """The scenario's terrain on a coarse grid; a mesh that cannot be loaded costs the relief, not the export."""
    from sessions import foxglove as fx

    try:
        return fx.sample_terrain(scenario, cells=cells)
    except (OSError, ValueError, MemoryError) as exc:
        print(f"warning: terrain not drawn ({exc}); using a flat plane", file=sys.stderr)
        return fx.sample_terrain(scenario, lambda x, z: x * 0.0, cells=cells)


class _RawCopy:
    """The original channels, schemas and metadata, copied unchanged (``--keep-raw``)."""

    def __init__(self, writer: Writer, metadata: dict[str, dict[str, str]]) -> None:
        self.writer = writer
        self.channels: dict[str, int] = {}
        self.schemas: dict[str, int] = {}
        self.count = 0
        for name, data in metadata.items():
            writer.add_metadata(name, data)

    def write(self, sample: Sample) -> None:
        from sessions.format import MESSAGE_ENCODING, SCHEMA_ENCODING, schema_of_key

        channel = self.channels.get(sample.key)
        if channel is None:
            schema_id = 0
            described = schema_of_key(sample.key)
            if described is not None:
                name, data = described
                if name not in self.schemas:
                    self.schemas[name] = self.writer.register_schema(name, SCHEMA_ENCODING, data)
                schema_id = self.schemas[name]
            channel = self.channels[sample.key] = self.writer.register_channel(sample.key, MESSAGE_ENCODING,
                                                                               schema_id)
        self.writer.add_message(channel, log_time=sample.log_time_ns, publish_time=sample.publish_time_ns,
                                data=sample.payload)
        self.count += 1


def _with_progress(samples, total: int | None, show: bool):
    """Samples, with a rich progress bar on a terminal (long recordings take a while)."""
    if not show:
        yield from samples
        return
    from rich.progress import Progress

    with Progress(transient=True) as bar:
        task = bar.add_task("exporting", total=total)
        for i, sample in enumerate(samples):
            yield sample
            if i % 1000 == 0:
                bar.update(task, completed=i)
