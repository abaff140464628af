"""The scenario editor's server side: validate, save, load and launch scenarios, import and export profiles.

Reading and validation are the command line's own (``schemas.scenario_files.load_yaml_text``,
``schemas.scenario.parse_scenario``), so a scenario the page accepts is one ``lunarsim run`` accepts, with the same
one-line error when it is not. These functions are slow on large scenarios: the server runs them in its worker
process (``web.uploads``).
"""

from __future__ import annotations

import datetime as dt
import re
import subprocess
import sys
from pathlib import Path

import yaml

from scenarios.profiles import profile_to_scenario, scenario_to_profile
from schemas.scenario import Scenario, ScenarioError, dump_scenario, load_scenario, parse_scenario
from schemas.scenario_files import load_yaml_text
from schemas.scenario_limits import MAX_SCENARIO_BYTES, clip

NAME = re.compile(r"^[A-Za-z0-9][A-Za-z0-9_.-]{0,80}$")
LOOPBACK_ENDPOINT = re.compile(r"tcp/127\.0\.0\.1:(\d{1,5})")


def scenario_from_page(data: object) -> Scenario:
    """The page's scenario (the model's JSON shape, or YAML text as a file holds it) validated; ScenarioError names
    the field."""
    if isinstance(data, str):
        if len(data.encode("utf-8", "surrogatepass")) > MAX_SCENARIO_BYTES:
            raise ScenarioError(f"editor: the YAML is larger than the {MAX_SCENARIO_BYTES / 1024**2:g} MiB a "
                                "scenario file may be")
        try:
            data = load_yaml_text(data)
        except yaml.YAMLError as exc:
            raise ScenarioError(f"editor: not valid YAML: {clip(str(getattr(exc, 'problem', None) or exc))}") from None
        except (ValueError, RecursionError) as exc:  # a scalar YAML cannot build, deep nesting
            raise ScenarioError(f"editor: a YAML value cannot be read: {clip(str(exc))}") from None
    return parse_scenario(data, "editor")


def scenario_json(scenario: Scenario) -> dict:
    return scenario.model_dump(mode="json")


def profile_scenario(profile: object, name: str) -> Scenario:
    if not isinstance(profile, dict):
        raise ScenarioError("profile: a profile is a JSON object")
    return profile_to_scenario(profile, name or "profile")


def profile_of(scenario: Scenario) -> dict:
    return scenario_to_profile(scenario)


class Workspace:
    """Scenario files the page saves and loads: ``NAME.yaml`` in one folder, nowhere else."""

    def __init__(self, folder: Path) -> None:
        self.folder = folder

    def path(self, name: str) -> Path:
        stem = name.removesuffix(".yaml")
        if not NAME.match(stem):
            raise ScenarioError(f"bad scenario file name {name!r}: letters, digits, '_', '-' or '.', no folders")
        return self.folder / f"{stem}.yaml"

    def save(self, name: str, scenario: Scenario) -> Path:
        path = self.path(name)
        self.folder.mkdir(parents=True, exist_ok=True)
        path.write_text(dump_scenario(scenario), encoding="utf-8")
        return path

    def load(self, name: str) -> Scenario:
        path = self.path(name)
        if not path.is_file():
            raise ScenarioError(f"no saved scenario {path.name!r} in {self.folder}")
        return load_scenario(path)

    def names(self) -> list[str]:
        return sorted(p.stem for p in self.folder.glob("*.yaml")) if self.folder.is_dir() else []


def run_folder(runs: Path, name: str, now: dt.datetime) -> Path:
    """A new folder for a launch, named by the scenario and the second; a second launch within that second gets a
    number (``lunarsim run`` refuses a folder that holds a run)."""
    stamp = f"{name}-web-{now:%Y%m%d-%H%M%S}"
    return next(runs / f"{stamp}{suffix}" for suffix in ("", *(f"-{n}" for n in range(2, 10**6)))
                if not (runs / f"{stamp}{suffix}").exists())


class Launcher:
    """``lunarsim run`` for a scenario built in the editor, on the viewer's router and world; one at a time."""

    def __init__(self, runs: Path, endpoint: str, world: str) -> None:
        self.runs = runs
        self.endpoint = endpoint
        self.world = world
        self.proc: subprocess.Popen | None = None
        self.out: Path | None = None

    def running(self) -> bool:
        return self.proc is not None and self.proc.poll() is None

    def launch(self, scenario_file: Path, name: str, time_scale: float) -> Path:
        if self.running():
            raise ScenarioError("a launched mission is still running: stop it first")
        if not 0 < time_scale <= 1000:
            raise ScenarioError(f"time scale must be in (0, 1000], got {time_scale}")
        self.out = run_folder(self.runs, name, dt.datetime.now())
        self.out.mkdir(parents=True, exist_ok=True)
        log = (self.out / "launch.log").open("w")
        self.proc = subprocess.Popen(
            [sys.executable, "-P", "-m", "deploy.cli", "run", str(scenario_file), *self.router_args(), "--world",
             self.world, "--time-scale", str(time_scale), "--out", str(self.out), "--quiet"],
            stdout=log, stderr=subprocess.STDOUT)
        log.close()
        return self.out

    def router_args(self) -> list[str]:
        """Join the viewer's router when one listens; on a loopback endpoint where none does (the view started on its
        own), the run's world routes there, as ``lunarsim run`` does by default, and the waiting view connects."""
        from bus.zenoh_config import port_in_use

        match = LOOPBACK_ENDPOINT.fullmatch(self.endpoint)
        if match and not port_in_use("127.0.0.1", int(match[1])):
            return ["--port", match[1]]
        return ["--connect", self.endpoint]

    def status(self) -> dict:
        if self.proc is None:
            return {"launched": False}
        return {"launched": True, "running": self.running(), "exit_code": self.proc.poll(), "out": str(self.out)}

    def stop(self) -> None:
        """SIGTERM: the launcher stops its agents and still writes its report."""
        if self.running():
            self.proc.terminate()
            try:
                self.proc.wait(timeout=30)
            except subprocess.TimeoutExpired:
                self.proc.kill()
                self.proc.wait()
