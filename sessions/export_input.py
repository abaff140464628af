"""What every export of a recording starts from: the recording checked, the scenario it was made of, and the
warnings a user should see before the export runs."""

from __future__ import annotations

import sys
from pathlib import Path
from typing import TYPE_CHECKING

from sessions.recording import Recording, check_recording

if TYPE_CHECKING:
    from schemas.scenario import Scenario


def recording_to_export(path: Path, scenario_file: Path | None, without_scenario: str) -> tuple[Recording,
                                                                                               Scenario | None]:
    """The recording at ``path`` (``BadRecording`` if it is none) and its scenario: ``scenario_file``, else the one
    it embeds, else None, with a warning ending in ``without_scenario`` (what the export does without one).
    Foreign channels and recorder gaps are warned of too: the export is still written."""
    from schemas.scenario import load_scenario
    from sessions.format import embedded_scenario

    recording = check_recording(path)
    scenario = load_scenario(scenario_file) if scenario_file else embedded_scenario(recording.metadata, str(path))
    notes = [recording.foreign_note(), recording.gap_note()]
    if scenario is None:
        notes.insert(0, f"{path} embeds no scenario and none was given (--scenario): {without_scenario}")
    for note in notes:
        if note:
            print(f"warning: {note}", file=sys.stderr)
    return recording, scenario
