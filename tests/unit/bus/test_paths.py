"""Paths a command writes to are refused before it starts when they are empty, or name what is not a plain file or
folder (a FIFO blocks a writer for ever, a device swallows the output)."""

from __future__ import annotations

import argparse
import os
from pathlib import Path

import pytest

from bus.paths import output_file, output_folder, output_path


@pytest.fixture
def things(tmp_path) -> dict[str, Path]:
    (tmp_path / "file").write_text("x")
    (tmp_path / "folder").mkdir()
    os.mkfifo(tmp_path / "fifo")
    return {"file": tmp_path / "file", "folder": tmp_path / "folder", "fifo": tmp_path / "fifo",
            "device": Path("/dev/zero"), "missing": tmp_path / "missing" / "x"}


@pytest.mark.parametrize(("check", "accepted"), [(output_file, {"file", "missing"}),
                                                 (output_folder, {"folder", "missing"}),
                                                 (output_path, {"file", "folder", "missing"})])
def test_only_a_plain_file_or_folder_or_a_new_path_is_taken(things, check, accepted):
    for name, path in things.items():
        if name in accepted:
            assert check(str(path)) == path
        else:
            with pytest.raises(argparse.ArgumentTypeError, match=r"FIFO|device|folder|file"):
                check(str(path))


@pytest.mark.parametrize("check", [output_file, output_folder, output_path])
@pytest.mark.parametrize("text", ["", "   "])
def test_an_empty_path_is_refused_rather_than_read_as_the_working_folder(check, text):
    with pytest.raises(argparse.ArgumentTypeError, match="empty path"):
        check(text)


def test_a_long_path_is_named_by_its_first_characters_only(tmp_path):
    through_a_file = tmp_path / "file"
    through_a_file.write_text("x")
    with pytest.raises(argparse.ArgumentTypeError) as refused:
        output_file(str(through_a_file / ("n" * 5000)))
    assert len(str(refused.value)) < 400
