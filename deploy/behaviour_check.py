"""Whether a rover behaviour keeps the contract (report 4.4; ``lunarsim check-behaviour``), and whether the rover
agents could load it at all (``lunarsim run`` and ``scenario check`` ask before anything starts).

``scripted_problems`` runs scripted views, no world: every decision is one of the allowed kinds; moves stay in view
and within the perception radius; the same inputs give the same decisions; a goal behind is turned towards; a goal
in view is finished. A ``package.module:Class`` is found as ``python -m`` finds modules: from the folder the
command runs in first, then the installed packages.
"""

from __future__ import annotations

import math
import os
import signal
import subprocess
import sys
from pathlib import Path

from bus import process

DEFAULT_SCENARIO = Path(__file__).resolve().parents[1] / "scenarios" / "crater_observation.yaml"
PROBE_TIMEOUT_S = 60.0
"""How long importing a behaviour's module may take when it is checked; a module that takes longer is refused
(its import would hold up every rover agent's start as long)."""
_VERDICT = "lunarsim-behaviour-verdict:"
_PROBE = f"""
import os, sys
out = os.fdopen(os.dup(1), "w")
quiet = os.open(os.devnull, os.O_WRONLY)
os.dup2(quiet, 1)
os.dup2(quiet, 2)
from rover_agent.registry import UnknownBehaviour, load_behaviour
try:
    load_behaviour(sys.argv[1])
    verdict = ""
except UnknownBehaviour as exc:
    verdict = str(exc)
except BaseException as exc:
    verdict = f"behaviour {{sys.argv[1]!r}} cannot be loaded: importing it raised {{type(exc).__name__}}: {{exc}}"
out.write({_VERDICT!r} + " ".join(verdict.split()) + "\\n")
out.flush()
os._exit(0)
"""
"""Run in a child Python (``python -c``: the current folder first on its path, as the agents' ``python -m``):
importing a module runs its code, which may exit, hang, print or open a browser (``antigravity`` does), none of
it in the command that checks it."""


def behaviour_problem(name: str) -> str | None:
    """Why the rover agents could not load behaviour ``name``, in one line, or None when they can.

    A built-in is known good; anything else is loaded as ``rover_agent.registry.load_behaviour`` loads it, in a
    child process given ``PROBE_TIMEOUT_S``. The current folder joins this process's module path too, so the
    agents this process starts (forked from it, ``deploy.warm_start``) find what the check found."""
    from rover_agent.registry import BUILT_IN, with_current_folder
    from schemas.scenario_errors import LINE_CHARS
    from schemas.scenario_limits import behaviour_spec, clip

    try:
        behaviour_spec(name)
    except ValueError as exc:
        return str(exc)
    if name in BUILT_IN:
        return None
    with_current_folder()
    probe = subprocess.Popen([sys.executable, "-P", "-c", _PROBE, name], stdin=subprocess.DEVNULL,
                             stdout=subprocess.PIPE, stderr=subprocess.DEVNULL, text=True, errors="replace",
                             start_new_session=True)
    try:
        out, _ = probe.communicate(timeout=PROBE_TIMEOUT_S)
    except subprocess.TimeoutExpired:
        os.killpg(probe.pid, signal.SIGKILL)  # its own session: the probe and whatever it started
        probe.communicate()
        return f"behaviour {clip(repr(name))} cannot be loaded: importing it took more than {PROBE_TIMEOUT_S:g} s"
    verdicts = [line.removeprefix(_VERDICT) for line in out.splitlines() if line.startswith(_VERDICT)]
    if not verdicts:
        return f"behaviour {clip(repr(name))} cannot be loaded: importing it ended Python (exit {probe.returncode})"
    return clip(verdicts[-1], LINE_CHARS) or None


def require_behaviour(name: str, source: str) -> None:
    """``behaviour_problem`` as the one-line error of a command (exit 2), naming where ``name`` came from."""
    problem = behaviour_problem(name)
    if problem is not None:
        raise process.UsageError(f"{source}: {problem}")


def scripted_problems(cls, params) -> list[str]:
    """Contract checks on scripted views; returns one line per problem."""
    from rover_agent import decisions as b
    from shared.pose import Pose

    problems: list[str] = []
    fov, radius = params.perception.field_of_view_degrees, params.perception.perception_radius
    rock = (b.Hit(0.0, 3.0, "obstacle"),)
    cases = {
        "goal ahead, nothing in view": (b.Goal(0, 1, "waypoint", 0.0, 60.0), ()),
        "goal ahead, a rock 3 m ahead": (b.Goal(0, 1, "waypoint", 0.0, 60.0), rock),
        "goal behind": (b.Goal(0, 1, "waypoint", 0.0, -60.0), ()),
        "crater goal ahead": (b.Goal(0, 1, "crater", 0.0, 60.0), ()),
        "goal ahead, battery low, in sunlight": (b.Goal(0, 1, "waypoint", 0.0, 60.0), (), 0.2, True),
        "goal ahead, battery low, in shadow": (b.Goal(0, 1, "waypoint", 0.0, 60.0), (), 0.2, False),
    }
    for label, (goal, hits, *power) in cases.items():
        runs = []
        for _ in range(2):
            behaviour = cls(1, params)
            behaviour.start_goal(goal)
            view = b.View(0.0, Pose(0.0, 0.0, 0.0), goal, hits, 0.0, *power)  # power sensors
            runs.append(behaviour.decide(view))
        decision = runs[0]
        if runs[0] != runs[1]:
            problems.append(f"{label}: not deterministic ({runs[0]} then {runs[1]})")
        if not isinstance(decision, b.MoveTo | b.Rotate | b.Hold | b.TakePhoto | b.Finish):
            problems.append(f"{label}: decided {decision!r}, not one of MoveTo, Rotate, Hold, TakePhoto, Finish")
        elif isinstance(decision, b.MoveTo):
            if abs(math.degrees(math.atan2(decision.x, decision.z))) > fov / 2:
                problems.append(f"{label}: {decision} is outside the {fov:g} degree field of view")
            if math.hypot(decision.x, decision.z) > radius * (1 + params.navigation.move_action_tolerance_factor):
                problems.append(f"{label}: {decision} is beyond the {radius:g} m perception radius")
            if hits and abs(decision.x) < 0.5 and decision.z >= 3.0:
                problems.append(f"{label}: {decision} walks into the rock")
        if label == "goal behind" and not isinstance(decision, b.Rotate):
            problems.append(f"{label}: expected a Rotate towards the goal, got {decision}")
    behaviour = cls(1, params)
    near = b.Goal(0, 1, "waypoint", 0.0, 1.0)
    behaviour.start_goal(near)
    if behaviour.decide(b.View(0.0, Pose(0.0, 0.0, 0.0), near, (), 0.0)) != b.Finish("reached"):
        problems.append("a waypoint 1 m ahead is in view: expected Finish('reached')")
    return problems
