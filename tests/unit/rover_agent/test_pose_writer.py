"""The rover's state is kept across restarts by a writer thread, so an agent never waits for storage."""

from __future__ import annotations

import os
import threading
import time
from pathlib import Path

from procs import wait_for

from rover_agent.restarts.saved_state import (
    MAX_OPEN_FILES,
    RECORD_BYTES,
    SavedState,
    StateWriter,
    load_state,
    save_state,
)
from shared.pose import Pose


def _state(x: float, z: float, h: float) -> SavedState:
    return SavedState("run", Pose(x, z, h))


def load_pose(path):
    state = load_state(path)
    return state.pose if state is not None else None


def test_the_latest_pose_of_each_file_is_written_in_the_background(tmp_path):
    writer = StateWriter()
    files = [tmp_path / "rover1.json", tmp_path / "rover2.json"]
    for step in range(200):
        for i, path in enumerate(files):
            writer.save(path, _state(float(step), float(i), 90.0))
    wait_for(lambda: all(load_pose(p) == Pose(199.0, float(i), 90.0) for i, p in enumerate(files)), 10,
             "the last poses on disk")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["rover1.json", "rover2.json"], "no temporary file left"


def test_flush_writes_what_is_pending_before_an_agent_stops(tmp_path):
    writer = StateWriter()
    path = tmp_path / "rover3.json"
    writer.save(path, _state(1.0, 2.0, 3.0))
    writer.save(path, _state(4.0, 5.0, 6.0))
    writer.flush()
    assert load_pose(path) == Pose(4.0, 5.0, 6.0)


def test_a_pose_that_cannot_be_written_is_logged_and_the_writer_goes_on(tmp_path, caplog):
    writer = StateWriter()
    writer.save(tmp_path / "missing" / "rover4.json", _state(0.0, 0.0, 0.0))
    writer.flush()
    assert "could not save the rover state" in caplog.text
    good = tmp_path / "rover4.json"
    writer.save(good, _state(7.0, 8.0, 9.0))
    wait_for(lambda: load_pose(good) == Pose(7.0, 8.0, 9.0), 10, "the next pose on disk")


def test_a_shorter_state_over_a_longer_one_reads_back_whole(tmp_path):
    """States are overwritten in place, padded to the longest one written: the shorter one reads back alone."""
    path = tmp_path / "rover5.json"
    long = SavedState("a-run-with-a-long-name" * 2, Pose(123456.789, -98765.4321, 359.999),
                      next_action=10**15, cov=[[1.5, 0.1, 0.0], [0.1, 2.5, 0.0], [0.0, 0.0, 0.25]])
    writer = StateWriter()
    writer.save(path, long)
    writer.flush()
    writer.save(path, _state(1.0, 2.0, 3.0))
    writer.flush()
    assert load_state(path) == _state(1.0, 2.0, 3.0)
    assert path.stat().st_size == len(long.to_json()), "padded, not truncated"


def test_a_state_file_removed_while_its_agent_runs_is_written_again(tmp_path):
    writer = StateWriter()
    path = tmp_path / "rover6.json"
    writer.save(path, _state(1.0, 1.0, 1.0))
    writer.flush()
    path.unlink()
    writer.save(path, _state(2.0, 2.0, 2.0))
    writer.flush()
    assert load_pose(path) == Pose(2.0, 2.0, 2.0)


def test_a_file_longer_than_any_state_is_replaced_not_followed(tmp_path):
    path = tmp_path / "rover7.json"
    path.write_text("x" * (RECORD_BYTES + 100))
    save_state(path, _state(3.0, 4.0, 5.0))
    assert load_pose(path) == Pose(3.0, 4.0, 5.0)


def test_more_agents_than_open_files_keep_every_state(tmp_path):
    writer = StateWriter()
    files = [tmp_path / f"rover{i}.json" for i in range(MAX_OPEN_FILES + 20)]
    for step in range(2):
        for i, path in enumerate(files):
            writer.save(path, _state(float(step), float(i), 0.0))
        writer.flush()
    assert all(load_pose(p) == Pose(1.0, float(i), 0.0) for i, p in enumerate(files))


def test_a_state_saved_while_the_writer_is_held_is_written_once_the_hold_ends(tmp_path):
    """An agent holds the writer while its answer goes out (``rover_agent.runtime``): the write would otherwise take
    the interpreter's lock from the thread publishing the answer."""
    writer = StateWriter()
    path = tmp_path / "rover8.json"
    with writer.held():
        writer.save(path, _state(1.0, 2.0, 3.0))
        with writer.held():  # nested holds: the outer one still holds
            pass
        assert writer.holding
        deadline = time.monotonic() + 0.3  # the writer's thread, started by the save, is awake and would write
        while time.monotonic() < deadline:
            assert not path.exists(), "written while held"
            threading.Event().wait(0.01)
    assert not writer.holding
    wait_for(lambda: load_pose(path) == Pose(1.0, 2.0, 3.0), 10, "the state on disk once the hold ended")


def test_a_state_path_to_something_endless_or_blocking_is_ignored_not_read(tmp_path, caplog):
    """A FIFO would block the agent's start and ``/dev/zero`` fill its memory: only a regular file is read, and
    only as far as a state can reach."""
    fifo = tmp_path / "fifo.json"
    os.mkfifo(fifo)
    big = tmp_path / "big.json"
    big.write_text(" " * (RECORD_BYTES + 1))
    for path in (fifo, Path("/dev/zero"), big):
        assert load_state(path) is None
    assert caplog.text.count("ignoring the saved rover state") == 3
