"""Which rover agents ``lunarsim run`` starts: the rovers left to an outside ROS 2 node (``--external``) get none,
and the others go K to a process (``--agents-per-process``)."""

from __future__ import annotations

import argparse

from bus import process


def external_ids(text: str | None, rovers: int) -> frozenset[int]:
    """``--external IDS`` checked against the scenario's rovers; a bad list is a usage error."""
    from ros2_bridge.commands.ros2 import rover_ids

    try:
        ids = rover_ids(text) if text else frozenset()
    except argparse.ArgumentTypeError as exc:
        raise process.UsageError(f"--external: {exc}") from None
    if ids and max(ids) > rovers:
        raise process.UsageError(f"--external: the scenario has {rovers} rovers")
    return ids


def groups(ids: list[int], per: int) -> list[tuple[int, int]]:
    """Consecutive ids in runs of at most ``per`` (first, last): the rover processes to start."""
    runs: list[tuple[int, int]] = []
    for i in ids:
        if runs and i == runs[-1][1] + 1 and i - runs[-1][0] < per:
            runs[-1] = (runs[-1][0], i)
        else:
            runs.append((i, i))
    return runs
