"""What a mission leaves in its run folder at its end: ``report.json``, scored with the lander's traverse map when
the lander wrote one (``map.npz``). ``lunarsim run`` and ``lunarsim batch --in-process`` write it the same way."""

from __future__ import annotations

import importlib
import json
import threading
from pathlib import Path

import msgspec

REPORT_FILE = "report.json"
MAP_FIGURE_MODULES = ("lander_agent.mapping", "world_service.outcome.map_truth")
"""What ``with_map_figures`` imports (NumPy among them): a fifth of a second here."""


def import_map_figures_meanwhile() -> None:
    """Import what ``with_map_figures`` needs on a thread of its own while the mission runs, on a core the
    lockstep mission leaves mostly idle, instead of after the mission, where the command waits for it."""
    threading.Thread(target=lambda: [importlib.import_module(name) for name in MAP_FIGURE_MODULES],
                     name="map figure imports", daemon=True).start()


def with_map_figures(report, scenario, folder: Path):
    """The report scoring the lander's traverse map (``world_service.outcome.map_truth``), when the lander wrote one."""
    from lander_agent import mapping
    from schemas import codec
    from world_service.outcome.map_truth import map_figures

    path = folder / mapping.NPZ_FILE
    if not path.is_file():
        return report
    spec, classes = mapping.load(path)
    return codec.checked(msgspec.structs.replace(report, **map_figures(scenario, spec, classes).report_fields()))


def write_report(report, folder: Path) -> Path:
    """``report.json`` in ``folder``, whole or not at all: written aside and renamed, so a run stopped as it writes
    leaves no half of one for ``lunarsim batch`` to find."""
    path = folder / REPORT_FILE
    tmp = folder / (REPORT_FILE + ".tmp")
    tmp.write_text(json.dumps(msgspec.to_builtins(report), indent=2) + "\n")
    tmp.replace(path)
    return path
