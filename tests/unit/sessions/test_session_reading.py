"""Reading a recording in log-time order holds the chunks whose times overlap at once: a file whose chunks all
overlap is refused, naming itself, before it is unpacked whole."""

from __future__ import annotations

from pathlib import Path
from types import SimpleNamespace

import pytest

from sessions import format as session_format
from sessions.format import BadRecording, Sample, overlap_bytes, read_samples
from sessions.writer import SessionWriter

KEY = "lunar/w/world/state"


def _chunk(start: int, end: int, size: int) -> SimpleNamespace:
    return SimpleNamespace(message_start_time=start, message_end_time=end, uncompressed_size=size)


def test_the_bytes_held_are_those_of_the_chunks_open_at_one_time():
    assert overlap_bytes([]) == 0
    assert overlap_bytes([_chunk(0, 9, 100), _chunk(10, 19, 100), _chunk(20, 29, 100)]) == 100  # in time order
    assert overlap_bytes([_chunk(20, 29, 5), _chunk(0, 25, 7), _chunk(10, 12, 11)]) == 18  # 0-25 with 10-12
    assert overlap_bytes([_chunk(1, 100 + i, 10) for i in range(50)]) == 500  # every chunk opens at time 1


def _recording(path: Path, overlapping: bool) -> Path:
    writer = SessionWriter(path, {"world": "w"}, chunk_size=2_000)
    for i in range(40):
        if overlapping:
            writer.write(Sample(KEY, b"early", 1, 1))
        writer.write(Sample(KEY, bytes(1_500), 10 + i, 10 + i))
    writer.close()
    return path


def test_a_file_whose_chunks_overlap_past_the_window_is_refused_and_one_in_order_is_read(tmp_path, monkeypatch):
    monkeypatch.setattr(session_format, "READ_WINDOW_BYTES", 20_000)
    overlapping = _recording(tmp_path / "overlapping.mcap", overlapping=True)
    with pytest.raises(BadRecording, match=f"{overlapping}: its chunks overlap in time, 0 MiB"):
        next(read_samples(overlapping))
    in_order = _recording(tmp_path / "in_order.mcap", overlapping=False)
    assert [s.log_time_ns for s in read_samples(in_order)] == list(range(10, 50))
