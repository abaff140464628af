"""What ``lunarsim run`` checks and prepares before it starts a process: the router it joins, the port it takes,
the scenario it runs, its run folder, and the rover agents' warm server, started first so that its imports overlap
the launcher's own (``deploy.launcher`` then starts the mission)."""

from __future__ import annotations

import datetime as dt
from pathlib import Path
from typing import TYPE_CHECKING

from bus import process

if TYPE_CHECKING:
    from schemas.scenario import Scenario


def new_run_folder(parent: Path, name: str) -> Path:
    """``parent/<name>-<timestamp>``, made now and by this run alone: two runs started in the same second get a
    folder each (``-2``, ``-3``...), where they shared one and a run took the other's scenario."""
    stem = f"{name}-{dt.datetime.now():%Y%m%d-%H%M%S}"
    parent.mkdir(parents=True, exist_ok=True)
    folder, n = parent / stem, 1
    while True:
        try:
            folder.mkdir()
            return folder
        except FileExistsError:
            n += 1
            folder = parent / f"{stem}-{n}"


def check_router(endpoint: str) -> None:
    """Reach the router of ``connect`` before anything starts. The mission would start its recorder and world against
    it, write the run folder, and give up on them only after half a minute; this fails within
    ``ONE_SHOT_TIMEOUT_S``, exit code 3, with nothing written."""
    from bus.zenoh_config import ONE_SHOT_TIMEOUT_S, build_config, open_session

    open_session(build_config(connect=[endpoint]), endpoint, ONE_SHOT_TIMEOUT_S, who="lunarsim run").close()


def check_port_free(port: int) -> None:
    from bus.zenoh_config import port_in_use

    if port_in_use("127.0.0.1", port):
        raise process.UsageError(f"port {port} on 127.0.0.1 is already in use (another run, or another program): "
                                 f"pass --port to run elsewhere; only if a LunarSim router or world listens there, "
                                 f"--connect tcp/127.0.0.1:{port} joins it")


def base_scenario(scenario: Path | None, recording: Path | None) -> Scenario:
    """The scenario file, or the one a recording embeds (``--from``): it holds the recorded seed too."""
    from schemas.scenario import load_scenario

    if (scenario is None) == (recording is None):
        raise process.UsageError("give a scenario file or --from FILE.mcap (one of them)")
    if scenario is not None:
        return load_scenario(scenario)
    from sessions.format import scenario_for

    found = scenario_for(recording, None)  # a recording that is missing or not a file is refused there
    if found is None:
        raise process.UsageError(f"{recording} embeds no scenario: it cannot be re-run")
    return found


def warm_up() -> None:
    """Start the rover agents' warm server (``deploy.warm_start``) before the launcher loads its scenario: the
    server's imports then take the other core while the launcher's own do, instead of while the world starts."""
    from deploy import warm_start
    from rover_agent.commands.rover import PRELOAD

    if warm_start.available():
        warm_start.prestart(PRELOAD)
