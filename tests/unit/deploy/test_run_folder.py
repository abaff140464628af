"""The run folder ``lunarsim run`` makes when no ``--out`` is given."""

from __future__ import annotations

import datetime
import types

from deploy import run_setup


class _Noon(datetime.datetime):
    @classmethod
    def now(cls, tz=None):  # every run below starts in the same second
        return cls(2026, 11, 30, 12, 0, 0)


def test_runs_started_in_the_same_second_get_a_folder_each(tmp_path, monkeypatch):
    """They shared one: one run failed on the other's state file, and the other ran the first's scenario."""
    monkeypatch.setattr(run_setup, "dt", types.SimpleNamespace(datetime=_Noon))
    folders = [run_setup.new_run_folder(tmp_path / "runs", "crater") for _ in range(3)]
    assert [f.name for f in folders] == ["crater-20261130-120000", "crater-20261130-120000-2",
                                        "crater-20261130-120000-3"]
    assert all(f.is_dir() for f in folders)
