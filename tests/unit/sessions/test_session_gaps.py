"""Gaps (``sessions.gaps``): how an outage of the recorder's router is bounded by the world clocks around it, counted,
written and read back from a file as untrusted text. The outage of a real router is in ``test_session_record``."""

from __future__ import annotations

import json

import pytest

from schemas import codec
from schemas import messages as m
from sessions.format import GAPS_METADATA, Sample, read_metadata
from sessions.gaps import MAX_GAPS_KEPT, ClockMark, GapTracker, describe
from sessions.recorder import RollingBuffer
from sessions.writer import SessionWriter


def _clock(tick: int) -> bytes:
    return codec.encode(m.Clock(tick=tick, sim_time=tick / 20, time_scale=1.0, running=True, lockstep=False))


def _mark(t_s: float, sim: float, run: str = "r1") -> ClockMark:
    return ClockMark(log_ns=round(t_s * 1e9), tick=round(sim * 50), sim_time=sim, run=run)


def test_a_gap_is_bounded_by_the_last_clock_before_the_outage_and_the_first_after_it():
    gaps = GapTracker()
    assert gaps.connection(False, 0) is None  # waiting for a first router: nothing recorded yet, no gap
    gaps.connection(True, 1_000_000_000)
    for t in (1.0, 1.2):
        gaps.clock(_mark(t, t))
    lost = gaps.connection(False, 1_500_000_000)
    assert lost is not None and lost.back_ns is None
    gaps.clock(_mark(1.4, 1.4))  # received before the loss was seen, handled after: still before it
    back = gaps.connection(True, 8_500_000_000)
    assert back is lost and back.wall_s == 7.0
    gaps.clock(_mark(8.6, 8.6))
    gaps.clock(_mark(8.8, 8.8))  # later clocks do not move the gap's end
    assert (lost.before.sim_time, lost.after.sim_time) == (1.4, 8.6)
    assert lost.sim_s == pytest.approx(7.2)
    record = gaps.metadata()
    assert record["count"] == "1" and float(record["router_lost_s"]) == 7.0
    assert float(record["sim_s_missed"]) == pytest.approx(7.2)
    (detail,) = json.loads(record["gaps"])
    assert (detail["sim_from"], detail["sim_to"], detail["tick_from"], detail["tick_to"]) == (1.4, 8.6, 70, 430)
    assert describe(record) == "1 gap: the recorder lost its router for 7.0 s; 7.2 simulated s not recorded"
    assert gaps.summary() == describe(record)


def test_a_clock_heard_before_the_poll_sees_the_router_back_ends_the_gap():
    """The connection is polled every 0.2 s; a clock can come through the restored router before the next poll. It
    is the first clock after the outage, not the last before it, or a 7 s outage would count 0.2 simulated s."""
    gaps = GapTracker()
    gaps.connection(True, 0)
    gaps.clock(_mark(1.0, 1.0))
    lost = gaps.connection(False, 1_500_000_000)
    for t in (8.5, 8.55, 8.6):  # through the router that is back, before the poll notices it
        gaps.clock(_mark(t, t))
    back = gaps.connection(True, 8_700_000_000)
    assert back is lost and back.wall_s == pytest.approx(7.2)
    gaps.clock(_mark(8.75, 8.75))
    assert (lost.before.sim_time, lost.after.sim_time) == (1.0, 8.5)
    assert lost.sim_s == pytest.approx(7.5)


def test_a_gap_across_a_world_restart_or_at_the_end_says_its_simulated_time_is_unknown():
    gaps = GapTracker()
    gaps.connection(True, 0)
    gaps.clock(_mark(1.0, 30.0, run="first"))
    gaps.connection(False, 2_000_000_000)
    gaps.connection(True, 4_000_000_000)
    gaps.clock(_mark(4.5, 0.5, run="second"))  # the world restarted meanwhile: its time began again
    gaps.connection(False, 6_000_000_000)
    gaps.close(9_000_000_000)  # stopped while the router was still gone
    first, second = gaps.gaps
    assert first.sim_s is None and second.sim_s is None and second.wall_s == 3.0
    record = gaps.metadata()
    assert record["count"] == "2" and record["sim_s_missed"] == ""
    assert describe(record) == ("2 gaps: the recorder lost its router for 5.0 s; simulated time missed unknown "
                                "(no world clock heard on both sides)")
    assert gaps.metadata(since_ns=5_000_000_000)["count"] == "1"  # a snapshot's window holds the second only


def test_a_flapping_link_is_counted_in_full_but_kept_bounded():
    gaps = GapTracker()
    gaps.connection(True, 0)
    for i in range(MAX_GAPS_KEPT + 50):
        gaps.connection(False, (2 * i + 1) * 10**9)
        gaps.connection(True, (2 * i + 2) * 10**9)
    record = gaps.metadata()
    assert record["count"] == str(MAX_GAPS_KEPT + 50) and len(json.loads(record["gaps"])) == MAX_GAPS_KEPT


@pytest.mark.parametrize("record", [{"count": "x"}, {"count": "1", "router_lost_s": "nan"},
                                    {"count": "-3", "router_lost_s": "1"}, {"count": "9" * 40},
                                    {"count": "1", "router_lost_s": "1e400"}])
def test_a_gap_record_read_from_a_file_that_does_not_parse_is_said_to_be_unreadable(record):
    assert describe(record) == "a gap record that cannot be read (lunarsim.gaps): it may have gaps"


def test_no_gap_record_or_a_zero_count_says_nothing():
    assert describe(None) is None and describe({}) is None
    assert describe({"count": "0", "router_lost_s": "0.000", "sim_s_missed": "", "gaps": "[]"}) is None


def test_a_closed_recording_and_a_snapshot_carry_the_gap_record(tmp_path):
    gaps = GapTracker()
    gaps.connection(True, 0)
    gaps.connection(False, 10**9)
    gaps.connection(True, 3 * 10**9)
    writer = SessionWriter(tmp_path / "s.mcap", {"world": "w"})
    writer.write(Sample("lunar/w/world/clock", _clock(1), 10**9, 0))
    writer.close(gaps=gaps.metadata())
    assert read_metadata(tmp_path / "s.mcap")[GAPS_METADATA]["count"] == "1"
    buffer = RollingBuffer(60.0, tmp_path / "b.mcap", {"world": "w"}, "none", gaps)
    buffer(Sample("lunar/w/world/clock", _clock(1), 2 * 10**9, 0))
    assert read_metadata(buffer.snapshot())[GAPS_METADATA]["count"] == "1"
