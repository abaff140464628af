"""The rover's state is kept across restarts by a writer thread, so an agent never waits for storage."""

from __future__ import annotations

from procs import wait_for

from rover_agent.restarts.saved_state import SavedState, StateWriter, load_state
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
