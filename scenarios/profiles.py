"""The report's scenario-editor profiles (appendix C.3): JSON with lander, rovers, craters and mission.

Profiles have no obstacles, terrain or parameters; importing gives the scenario defaults for those.
Mission goals inside a crater become crater goals, the others waypoints (the editor did the same).
"""

from __future__ import annotations

import json
import math
from pathlib import Path

from schemas.scenario import Goal, Scenario, ScenarioError, parse_scenario
from schemas.scenario_files import read_regular_file
from schemas.scenario_limits import MAX_SCENARIO_BYTES


def _heading_from_quaternion(rot: dict) -> float:
    """Unity yaw about +y: q = (0, sin(h/2), 0, cos(h/2)); 0 faces +z, 90 faces +x."""
    heading = math.degrees(2 * math.atan2(float(rot.get("y", 0.0)), float(rot.get("w", 1.0))))
    return round(heading % 360.0, 3)


def _quaternion_from_heading(heading_deg: float) -> dict:
    half = math.radians(heading_deg) / 2
    return {"x": 0.0, "y": math.sin(half), "z": 0.0, "w": math.cos(half)}


def _xz(obj: dict, what: str) -> tuple[float, float]:
    try:
        pos = obj["position"]
        return float(pos["x"]), float(pos["z"])
    except (KeyError, TypeError, ValueError, AttributeError):
        raise ScenarioError(f"profile: {what}: missing or malformed position") from None


def profile_to_scenario(profile: dict, name: str, seed: int = 0) -> Scenario:
    """Build a scenario from a parsed profile."""
    try:
        lander_x, lander_z = _xz(profile["landerDataObject"], "landerDataObject")
        rovers = [
            {"x": x, "z": z, "heading_deg": _heading_from_quaternion(r.get("rotation", {}))}
            for i, r in enumerate(profile["roverDataObjects"])
            for x, z in [_xz(r, f"roverDataObjects.{i}")]
        ]
        craters = [
            {"x": x, "z": z, "radius_m": float(c["radius"])}
            for i, c in enumerate(profile.get("craterDataObjects", []))
            for x, z in [_xz(c, f"craterDataObjects.{i}")]
        ]
        goals = sorted(profile["missionDataObjects"], key=lambda g: int(g.get("index", 0)))
    except KeyError as exc:
        raise ScenarioError(f"profile: missing {exc.args[0]!r}") from None
    except (TypeError, ValueError, AttributeError) as exc:
        raise ScenarioError(f"profile: malformed value: {exc}") from None
    mission = []
    for i, g in enumerate(goals):
        x, z = _xz(g, f"missionDataObjects.{i}")
        inside = any(math.hypot(x - c["x"], z - c["z"]) <= c["radius_m"] for c in craters)
        mission.append({"x": x, "z": z, "kind": "crater" if inside else "waypoint"})
    data = {"name": name, "seed": seed, "lander": {"x": lander_x, "z": lander_z},
            "rovers": rovers, "craters": craters, "mission": mission}
    return parse_scenario(data, f"profile {name}")


def scenario_to_profile(scenario: Scenario) -> dict:
    """The editor's profile of a scenario (heights are 0: the profile's y was Unity's terrain height)."""

    def place(x: float, z: float) -> dict:
        return {"x": x, "y": 0.0, "z": z}

    return {
        "landerDataObject": {"position": place(scenario.lander.x, scenario.lander.z),
                             "rotation": _quaternion_from_heading(0.0)},
        "roverDataObjects": [{"position": place(r.x, r.z), "rotation": _quaternion_from_heading(r.heading_deg)}
                             for r in scenario.rovers],
        "craterDataObjects": [{"position": place(c.x, c.z), "radius": c.radius_m} for c in scenario.craters],
        "missionDataObjects": [{"position": place(g.x, g.z), "index": i} for i, g in enumerate(scenario.mission)],
    }


def load_profile(path: str | Path, name: str | None = None) -> Scenario:
    path = Path(path)
    raw = read_regular_file(path, "profile", MAX_SCENARIO_BYTES)  # a FIFO or a device is refused, not read
    try:
        profile = json.loads(raw.decode("utf-8"))
    except json.JSONDecodeError as exc:
        raise ScenarioError(f"{path}: not valid JSON at line {exc.lineno}, column {exc.colno}: {exc.msg}") from None
    except UnicodeDecodeError as exc:
        raise ScenarioError(f"{path}: cannot read profile: not UTF-8 text (offset {exc.start})") from None
    except RecursionError:
        raise ScenarioError(f"{path}: cannot read profile: nested too deeply") from None
    if not isinstance(profile, dict):
        raise ScenarioError(f"{path}: a profile is a JSON object")
    return profile_to_scenario(profile, name or path.stem)


__all__ = ["Goal", "load_profile", "profile_to_scenario", "scenario_to_profile"]
