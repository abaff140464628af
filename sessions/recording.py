"""A session file checked before any command uses it: what a file holds is untrusted data.

``check_recording`` reads the file's summary (or, for a file written without one, its records) and refuses it with
one line naming it: not MCAP, cut short (with the ``lunarsim recover`` command that mends it), damaged, holding
nothing of LunarSim's, or naming a world that is not a safe keyspace name. It never takes a value from the file into
a path or a key expression unchecked: channels whose topic is not a LunarSim key (another tool's ``/foo``, a key with
wildcards) are set apart as foreign, and the commands skip them and say how many.
"""

from __future__ import annotations

import re
from collections.abc import Callable, Iterable, Iterator
from dataclasses import dataclass, field
from pathlib import Path

from schemas.keyspace import ROOT, check_world_name
from sessions.format import (
    GAPS_METADATA,
    SESSION_METADATA,
    BadRecording,
    Sample,
    check_file,
    damaged,
    escaped,
    read_samples,
)
from sessions.gaps import describe

KEY_SEGMENT = re.compile(r"[A-Za-z0-9_-]{1,64}")
"""A chunk of a LunarSim key after ``lunar/<world>/``: what the keyspace builds (names, ids), never a wildcard."""
MAX_KEY_LENGTH = 256
MAX_SHOWN = 5
"""Foreign channels named in a message; the rest are counted."""
WORLD_RULE = "1 to 64 letters, digits, '-' or '_', starting with a letter or digit"
"""A world name a recording may carry: the keyspace's rule and the scenario's safe-name rule together."""


@dataclass(frozen=True)
class Recording:
    """What a command may rely on once a file has passed ``check_recording``."""

    path: Path
    metadata: dict[str, dict[str, str]]
    world: str | None
    """The recorded world: the metadata's, else that of its keys (the first in order); a valid keyspace name."""
    keys: frozenset[str]
    """Channel topics that are LunarSim keys."""
    foreign: dict[str, int] = field(default_factory=dict)
    """Other channels' topics and how many messages each holds."""
    first_ns: int = 0
    last_ns: int = 0
    messages: int = 0
    """Messages on LunarSim keys."""

    def is_ours(self, key: str) -> bool:
        return key in self.keys

    def foreign_note(self) -> str | None:
        """One line on the channels skipped, or None when there are none."""
        if not self.foreign:
            return None
        count = sum(self.foreign.values())
        plural = "channel" if len(self.foreign) == 1 else "channels"
        return (f"{self.path}: skipping {len(self.foreign)} {plural} not on a LunarSim key ({count} messages): "
                f"{shown(self.foreign)}")

    def gap_note(self) -> str | None:
        """One line on the gaps the recorder noted, or None when it noted none."""
        said = describe(self.metadata.get(GAPS_METADATA))
        return f"{self.path} has {said}" if said else None

    def samples(self, keep: Callable[[str], bool] | None = None, start_ns: int | None = None) -> Iterator[Sample]:
        """The samples of LunarSim keys (and ``keep``); a file found damaged part way is a ``BadRecording``."""
        ours = self.is_ours if keep is None else (lambda key: self.is_ours(key) and keep(key))
        yield from reading(self.path, read_samples(self.path, ours, start_ns))


def check_recording(path: Path) -> Recording:
    """The file as a LunarSim recording, or ``BadRecording`` with one line saying what is wrong with it."""
    check_file(path)
    try:
        metadata, counts, span = _contents(path)
    except Exception as exc:  # the mcap reader raises many kinds on damaged files
        raise BadRecording(damaged(path, exc)) from None
    keys = frozenset(topic for topic in counts if lunarsim_key(topic))
    foreign = {topic: n for topic, n in counts.items() if topic not in keys}
    session = metadata.get(SESSION_METADATA)
    if session is None and not keys:
        raise BadRecording(f"{path}: not a LunarSim recording (no lunarsim metadata; channels: "
                           f"{shown(foreign) or 'none'})")
    if not keys and foreign:
        raise BadRecording(f"{path}: holds no LunarSim key (channels: {shown(foreign)})")
    world = _world(path, (session or {}).get("world"), keys)
    first_ns, last_ns = span
    return Recording(path, metadata, world, keys, foreign, first_ns, last_ns, sum(counts[k] for k in keys))


def lunarsim_key(topic: str) -> bool:
    """``lunar/<world>/<chunk>/...`` with a valid world name and plain chunks: safe to publish as a key expression."""
    parts = topic.split("/")
    return (len(topic) <= MAX_KEY_LENGTH and len(parts) >= 3 and parts[0] == ROOT and valid_world(parts[1])
            and all(KEY_SEGMENT.fullmatch(part) for part in parts[2:]))


def reading(path: Path, samples: Iterable[Sample]) -> Iterator[Sample]:
    """``samples`` as they are read; a reader error part way (a corrupt chunk) becomes a ``BadRecording``.
    Only the reading is guarded: an error in the caller's own loop body is not raised in here."""
    iterator = iter(samples)
    while True:
        try:
            sample = next(iterator)
        except StopIteration:
            return
        except BadRecording:  # already says what is wrong with the file
            raise
        except Exception as exc:  # the mcap reader and its decompressors raise many kinds
            raise BadRecording(damaged(path, exc)) from None
        yield sample


def shown(topics: Iterable[str]) -> str:
    """Topics for a message, sorted: each escaped (``repr`` past plain text), cut short, at most ``MAX_SHOWN``."""
    names = sorted(topics)
    text = ", ".join(escaped(name) for name in names[:MAX_SHOWN])
    return text + (f" and {len(names) - MAX_SHOWN} more" if len(names) > MAX_SHOWN else "")


def valid_world(world: str) -> bool:
    """Whether ``world`` keeps ``WORLD_RULE`` (``schemas.keyspace.check_world_name``), which also makes it a safe
    file name."""
    try:
        check_world_name(world)
    except ValueError:
        return False
    return True


def _world(path: Path, recorded: str | None, keys: frozenset[str]) -> str | None:
    """The metadata's world, refused if it is not a safe keyspace name; else the world of the first key in order."""
    if recorded is not None:
        if not valid_world(recorded):
            raise BadRecording(f"{path}: the recorded world name {recorded[:60]!r} is not a valid world name "
                               f"({WORLD_RULE})")
        return recorded
    return min(keys).split("/")[1] if keys else None


def _contents(path: Path) -> tuple[dict[str, dict[str, str]], dict[str, int], tuple[int, int]]:
    """(metadata, messages per channel topic, (first, last) log time) from the summary, else from every record."""
    from mcap.reader import make_reader

    with path.open("rb") as stream:
        reader = make_reader(stream)
        summary = reader.get_summary()
        if summary is None:
            return _scan(path)
        metadata = {record.name: dict(record.metadata) for record in reader.iter_metadata()}
    counts: dict[str, int] = dict.fromkeys((c.topic for c in summary.channels.values()), 0)
    stats = summary.statistics
    if stats is not None:
        for channel_id, n in stats.channel_message_counts.items():
            channel = summary.channels.get(channel_id)
            if channel is not None:
                counts[channel.topic] += n
    span = (stats.message_start_time, stats.message_end_time) if stats and stats.message_count else (0, 0)
    return metadata, counts, span


def _scan(path: Path) -> tuple[dict[str, dict[str, str]], dict[str, int], tuple[int, int]]:
    """A closed file written without a summary section: read every record once."""
    from mcap.records import Channel, Message, Metadata
    from mcap.stream_reader import StreamReader

    metadata: dict[str, dict[str, str]] = {}
    topics: dict[int, str] = {}
    counts: dict[str, int] = {}
    first, last = None, None
    with path.open("rb") as stream:
        for record in StreamReader(stream).records:
            if isinstance(record, Channel):
                topics[record.id] = record.topic
                counts.setdefault(record.topic, 0)
            elif isinstance(record, Message) and record.channel_id in topics:
                counts[topics[record.channel_id]] += 1
                first = record.log_time if first is None else min(first, record.log_time)
                last = record.log_time if last is None else max(last, record.log_time)
            elif isinstance(record, Metadata):
                metadata[record.name] = dict(record.metadata)
    return metadata, counts, (first or 0, last or 0)
