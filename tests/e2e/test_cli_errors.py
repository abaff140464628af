"""Bad input to real ``lunarsim`` processes: a non-zero exit code, a message naming the problem, never a traceback.

Every case is its own process; they all run at once (most exit in about a second, the ones waiting for a router
that is not there within their router timeout), so the table costs about as long as its slowest case. A case
still running after ``HUNG_S`` is killed and fails as hung (a FIFO read without end, a hung import): that bound
only tells a hang from a slow machine, it times nothing.
"""

from __future__ import annotations

import argparse
import os
import socket
import subprocess
import sys
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass
from pathlib import Path

import pytest
from procs import REPO, SCENARIOS, free_port, lunarsim

from bus.process import EXIT_NO_ROUTER, EXIT_USAGE

SCENARIO = str(SCENARIOS / "crater_observation.yaml")
NO_ROUTER = f"tcp/127.0.0.1:{free_port()}"
WAIT_S = 2
"""``--router-timeout`` for agents, which wait for their router for ever unless told otherwise."""
TAKEN = socket.create_server(("127.0.0.1", 0))
"""A port something else listens on, for the whole module."""
HUNG_S = 300.0
"""A case not done by then hangs: every one ends in seconds, or in its router timeout, even on a busy machine."""
PADDING = 5 * 1024**2
"""A comment this long makes a scenario file larger than ``MAX_SCENARIO_BYTES``."""
ENV = {**os.environ, "BROWSER": "true"}
"""Importing ``antigravity`` (a behaviour refused for its missing class) opens a web browser: here, ``true``."""


@dataclass(frozen=True)
class Case:
    name: str
    args: tuple[str, ...]
    message: str
    code: int = EXIT_USAGE


def _files(folder: Path) -> None:
    (folder / "broken.yaml").write_text("name: broken\nrovers: [\n")
    (folder / "latin1.yaml").write_bytes("name: caf\xe9\n".encode("latin-1"))
    (folder / "nan.yaml").write_text(Path(SCENARIO).read_text().replace("lander: {x: -560.0", "lander: {x: .nan"))
    (folder / "empty.yaml").write_text("")
    (folder / "list.yaml").write_text("- a\n- b\n")
    (folder / "escape.yaml").write_text(Path(SCENARIO).read_text().replace("name: crater_observation",
                                                                           "name: ../../escape"))
    (folder / "garbage.mcap").write_bytes(b"this is not a recording\n" * 10)
    (folder / "empty.mcap").write_bytes(b"")
    (folder / "a_folder").mkdir()
    os.mkfifo(folder / "fifo.yaml")
    text = Path(SCENARIO).read_text()
    (folder / "twice.yaml").write_text(text + "seed: 7\n")
    (folder / "huge.yaml").write_text(text + "#" * PADDING + "\n")
    (folder / "long_name.yaml").write_text(text.replace("name: crater_observation", "name: " + "n" * 900_000))
    terrain = "terrain: {origin: [-700, -131], size_m: [270, 291], mesh: %s}\n"
    (folder / "zero_mesh.yaml").write_text(text + terrain % "/dev/zero")
    (folder / "passwd_mesh.yaml").write_text(text + terrain % "/etc/passwd")
    (folder / "device.stl").symlink_to("/dev/zero")
    (folder / "device_mesh.yaml").write_text(text + terrain % "device.stl")
    (folder / "antigravity.yaml").write_text(text + "behaviour: 'antigravity:Foo'\n")


def _cases(d: Path) -> list[Case]:
    port = str(free_port())

    def run(out: str) -> tuple[str, ...]:
        return "run", "--port", port, "--out", str(d / "runs" / out)

    return [
        Case("missing scenario", ("scenario", "check", str(d / "missing.yaml")), "missing.yaml: cannot read scenario"),
        Case("run a missing scenario", (*run("r1"), str(d / "missing.yaml")), "missing.yaml: cannot read scenario"),
        Case("broken YAML", ("scenario", "check", str(d / "broken.yaml")), "broken.yaml: cannot read scenario: not "
             "valid YAML at line 3"),
        Case("run broken YAML", (*run("r2"), str(d / "broken.yaml")), "not valid YAML"),
        Case("non-UTF-8 file", ("scenario", "check", str(d / "latin1.yaml")), "latin1.yaml: cannot read scenario: "
             "not UTF-8 text"),
        Case("run a non-UTF-8 file", (*run("r3"), str(d / "latin1.yaml")), "not UTF-8 text"),
        Case("non-UTF-8 parameters", (*run("r4"), SCENARIO, "--params", str(d / "latin1.yaml")),
             "cannot read rover parameters: not UTF-8"),
        Case("nan in a field", ("scenario", "check", str(d / "nan.yaml")), "nan.yaml: lander.x: Input should be a "
             "finite number"),
        Case("run nan in a field", (*run("r5"), str(d / "nan.yaml")), "lander.x: Input should be a finite number"),
        Case("empty scenario", ("scenario", "check", str(d / "empty.yaml")), "the scenario file is empty"),
        Case("a list, not a mapping", ("scenario", "check", str(d / "list.yaml")), "expected a mapping"),
        Case("unsafe scenario name", (*run("r6"), str(d / "escape.yaml")), "name: '../../escape' is not a safe name"),
        Case("a directory as scenario", ("scenario", "check", str(d / "a_folder")), "a_folder: cannot read "
             "scenario: Is a directory"),
        Case("run a directory", (*run("r7"), str(d / "a_folder")), "Is a directory"),
        Case("a FIFO as scenario", ("scenario", "check", str(d / "fifo.yaml")), "fifo.yaml: cannot read scenario: "
             "not a regular file (a FIFO)"),
        Case("run a FIFO", (*run("r19"), str(d / "fifo.yaml")), "not a regular file (a FIFO)"),
        Case("a FIFO as parameters", (*run("r20"), SCENARIO, "--params", str(d / "fifo.yaml")),
             "fifo.yaml: cannot read rover parameters: not a regular file (a FIFO)"),
        Case("a key given twice", ("scenario", "check", str(d / "twice.yaml")), "twice.yaml: cannot read scenario: "
             "not valid YAML at line 32, column 1: duplicate key 'seed' (first given at line 6)"),
        Case("a file over the size bound", ("scenario", "check", str(d / "huge.yaml")), "huge.yaml: cannot read "
             f"scenario: {len(Path(SCENARIO).read_bytes()) + PADDING + 1:,} bytes, more than the 1 MiB allowed"),
        Case("run a file over the size bound", (*run("r24"), str(d / "huge.yaml")), "bytes, more than the 1 MiB "
             "allowed"),
        Case("a 900 kB name", ("scenario", "check", str(d / "long_name.yaml")), "long_name.yaml: name: 'nnnn"),
        Case("/dev/zero as mesh", ("scenario", "check", str(d / "zero_mesh.yaml")), "zero_mesh.yaml: terrain.mesh: "
             "'/dev/zero' is not a mesh file: its name must end in .obj, .stl, .ply, .glb"),
        Case("run /dev/zero as mesh", (*run("r21"), str(d / "zero_mesh.yaml")), "'/dev/zero' is not a mesh file"),
        Case("/etc/passwd as mesh", ("scenario", "check", str(d / "passwd_mesh.yaml")), "'/etc/passwd' is not a mesh"),
        Case("a device named as a mesh", ("scenario", "check", str(d / "device_mesh.yaml")), "device_mesh.yaml: "
             "terrain.mesh: /dev/zero: not a regular file (a character device)"),
        Case("run a device named as a mesh", (*run("r22"), str(d / "device_mesh.yaml")), "not a regular file"),
        Case("a behaviour without its class", ("scenario", "check", str(d / "antigravity.yaml")),
             "antigravity.yaml: behaviour 'antigravity:Foo' cannot be loaded: module 'antigravity' has no attribute "
             "'Foo'"),
        Case("run a behaviour without its class", (*run("r23"), str(d / "antigravity.yaml")),
             "behaviour 'antigravity:Foo' cannot be loaded"),
        Case("check a behaviour without its class", ("check-behaviour", "antigravity:Foo"),
             "behaviour 'antigravity:Foo' cannot be loaded"),
        Case("a checking mission too short to drive", ("check-behaviour", "default", "--max-sim-time", "1e-300"),
             "--max-sim-time must be between 10 and"),
        Case("ground steeper than a wall", ("emulate-device", "--slope", "95"), "--slope must be between -89 and 89"),
        Case("a router on a port no client is told of", ("router", "--listen", "tcp/127.0.0.1:0"),
             "port 0 would listen on a port no client is told of"),
        Case("a folder as the Zenoh config", ("router", "--config", str(d)), "is a folder, not a json5 file"),
        Case("unknown flag", (*run("r8"), SCENARIO, "--bogus"), "lunarsim run: error: unrecognized arguments: --bogus"),
        Case("port taken", ("run", "--port", str(TAKEN.getsockname()[1]), "--out", str(d / "runs" / "r18"), SCENARIO),
             f"port {TAKEN.getsockname()[1]} on 127.0.0.1 is already in use"),
        Case("unknown command", ("fly",), "invalid choice: 'fly'"),
        Case("unknown flag after a command's own 'command' argument", ("command", "stop", "--rover", "3", "--bogus"),
             "lunarsim command: error: unrecognized arguments: --bogus"),
        Case("seek before the start", ("command", "seek", "--seconds", "-1"), "--seconds: Expected `float` >= 0.0"),
        Case("a target beyond any scenario", ("command", "set-target", "--x", "1e12", "--z", "0"),
             "--x: Expected `float` <= 10000000.0"),
        Case("--rovers 0", (*run("r9"), SCENARIO, "--rovers", "0"), "--rovers must be at least 1, got 0"),
        Case("--rovers -1", (*run("r10"), SCENARIO, "--rovers", "-1"), "--rovers must be at least 1, got -1"),
        Case("--rovers 1001", (*run("r11"), SCENARIO, "--rovers", "1001"), "--rovers must be at most 1000"),
        Case("--seed -1", (*run("r12"), SCENARIO, "--seed", "-1"), "--seed must be at least 0"),
        Case("a batch's seeds past 2**63", ("batch", SCENARIO, "--seed", str(2**63 - 2), "--runs", "3", "--out",
                                            str(d / "batch")), "leave every run's seed (BASE + i, 3 runs) below 2**63"),
        Case("a batch from seed -1", ("batch", SCENARIO, "--seed", "-1", "--out", str(d / "batch")),
             "--seed must be at least 0"),
        Case("--port 0", ("run", "--port", "0", "--out", str(d / "runs" / "r25"), SCENARIO),
             "--port must be between 1 and 65535, got 0"),
        Case("--port 65536 for the web view", ("view", "--port", "65536"), "--port must be between 1 and 65535"),
        Case("an empty run folder", ("run", "--out", "", SCENARIO), "argument --out: an empty path names no file"),
        Case("a device as the world's state", ("world", SCENARIO, "--state", "/dev/zero"),
             "argument --state: /dev/zero is not a regular file (a character device)"),
        Case("a FIFO as a rover's state", ("rover", "--id", "1", "--state", str(d / "fifo.yaml")),
             "is neither a regular file nor a folder (a FIFO)"),
        Case("a FIFO as the report's JSON", ("report", str(d / "garbage.mcap"), "--json", str(d / "fifo.yaml")),
             "argument --json:"),
        Case("a folder as a recording", ("record", "-o", str(d / "a_folder")), "a_folder is a folder; give a file"),
        Case("a time scale of 1e-20", (*run("r26"), SCENARIO, "--time-scale", "1e-20"),
             "--time-scale must be 0 or at least 0.001, got 1e-20"),
        Case("a rover id past any scenario's", ("command", "stop", "--rover", "99999999999999999999"),
             "--rover must be a rover id from 1 to 1000"),
        Case("a replay at 1e-300 times", ("replay", str(d / "garbage.mcap"), "--rate", "1e-300"),
             "--rate must be between"),
        Case("a terrain mesh of 1e10 nodes", ("export-foxglove", str(d / "garbage.mcap"), "-o", str(d / "x.mcap"),
                                              "--terrain-cells", "100000"), "--terrain-cells must be between 2 and"),
        Case("an agent for 10**14 rovers", ("rover", "--ids", "1-99999999999999"), "must be ids from 1 to 1000"),
        Case("a recording over a recording", ("record", "-o", str(d / "garbage.mcap")),
             "garbage.mcap already exists; remove it or give another path"),
        Case("a scenario over a scenario", ("scenario", "generate", "--seed", "1", "-o", str(d / "broken.yaml")),
             "broken.yaml already exists"),
        Case("a plot that is no PNG", ("report", str(d / "garbage.mcap"), "--plot", str(d / "plot.txt")),
             "the plot is a PNG; give a path ending in .png"),
        Case("a link that loses nearly all", (*run("r27"), SCENARIO, "--fault-loss", "0.99"),
             "--fault-loss must be between 0 and 0.5, got 0.99"),
        Case("world name with '/' and '*'", (*run("r13"), SCENARIO, "--world", "a/b*"), "invalid world name 'a/b*'"),
        Case("world name with '@'", ("world", SCENARIO, "--world", "@w"), "invalid world name '@w'"),
        Case("world name for a command", ("command", "stop", "--world", "w?"), "invalid world name 'w?'"),
        Case("negative --max-sim-time", (*run("r14"), SCENARIO, "--max-sim-time", "-5"),
             "--max-sim-time must be more than 0"),
        Case("nan --time-scale", (*run("r15"), SCENARIO, "--time-scale", "nan"),
             "--time-scale must be a finite number"),
        Case("replay a missing file", ("replay", str(d / "missing.mcap")), "missing.mcap: no such file"),
        Case("replay garbage", ("replay", str(d / "garbage.mcap")), "garbage.mcap: not an MCAP file"),
        Case("report garbage", ("report", str(d / "garbage.mcap")), "garbage.mcap: not an MCAP file"),
        Case("report an empty file", ("report", str(d / "empty.mcap")), "(the file is empty)"),
        Case("recover an empty file", ("recover", str(d / "empty.mcap"), "-o", str(d / "fixed.mcap")),
             "empty.mcap: empty"),
        Case("recover into a missing folder", ("recover", str(d / "garbage.mcap"), "-o", str(d / "no" / "x.mcap")),
             "x.mcap"),
        Case("export into a missing folder", ("scenario", "export", SCENARIO, "-o", str(d / "no" / "x.json")),
             "no/x.json: No such file or directory"),
        Case("not an endpoint", (*run("r16"), SCENARIO, "--connect", "localhost"),
             "--connect localhost: not a Zenoh endpoint"),
        Case("run --connect to no router", (*run("r17"), SCENARIO, "--connect", NO_ROUTER),
             f"no Zenoh router reachable at {NO_ROUTER}", EXIT_NO_ROUTER),
        *[Case(f"{what} --connect to no router", (what, *extra, "--connect", NO_ROUTER, "--router-timeout",
                                                  str(WAIT_S)),
               f"no Zenoh router reachable at {NO_ROUTER} after {WAIT_S} s", EXIT_NO_ROUTER)
          for what, extra in [("world", (SCENARIO,)), ("rover", ("--id", "1")), ("lander", (SCENARIO,)),
                              ("record", ("-o", str(d / "rec" / "s.mcap")))]],
    ]


@dataclass(frozen=True)
class Outcome:
    code: int
    output: str
    stderr: str
    hung: bool


def _run(case: Case) -> Outcome:
    proc = lunarsim(*case.args, env=ENV)
    try:
        stdout, stderr = proc.communicate(timeout=HUNG_S)
    except subprocess.TimeoutExpired:
        proc.kill()
        stdout, stderr = proc.communicate()
        return Outcome(proc.returncode, stdout + stderr, stderr, hung=True)
    return Outcome(proc.returncode, stdout + stderr, stderr, hung=False)


@pytest.fixture(scope="module")
def outcomes(tmp_path_factory) -> tuple[Path, dict[str, Outcome]]:
    folder = tmp_path_factory.mktemp("bad_input")
    _files(folder)
    cases = _cases(folder)
    with ThreadPoolExecutor(max_workers=len(cases)) as pool:
        return folder, dict(zip([c.name for c in cases], pool.map(_run, cases), strict=True))


CASES = [c.name for c in _cases(Path("/placeholder"))]


@pytest.mark.parametrize("name", CASES)
def test_bad_input_is_named_without_a_traceback(outcomes, name):
    folder, results = outcomes
    case = next(c for c in _cases(folder) if c.name == name)
    out = results[name]
    assert not out.hung, f"still running after {HUNG_S:g} s, killed:\n{out.output}"
    assert out.code == case.code, f"exit {out.code}, expected {case.code}:\n{out.output}"
    assert case.message in out.stderr, out.output
    assert "Traceback" not in out.output, out.output
    if "--out" in case.args and (folder := case.args[case.args.index("--out") + 1]):
        assert not Path(folder).exists(), f"a run folder was left:\n{out.output}"


def test_a_run_folder_that_holds_a_run_is_refused_and_left_as_it_was(tmp_path):
    """A second ``lunarsim run --out`` into a finished run's folder would replace its recording and report."""
    out = tmp_path / "run"
    out.mkdir()
    (out / "report.json").write_text('{"kept": true}\n')
    proc = lunarsim("run", "--out", str(out), "--port", str(free_port()), SCENARIO, env=ENV)
    _, stderr = proc.communicate(timeout=HUNG_S)
    assert proc.returncode == EXIT_USAGE and "already holds a run (report.json): choose another --out" in stderr
    assert sorted(p.name for p in out.iterdir()) == ["report.json"]
    assert (out / "report.json").read_text() == '{"kept": true}\n'


def test_the_error_is_one_line(outcomes):
    """Besides a notice that it is waiting for the router, a failing command says one line, starting 'error:'."""
    _, results = outcomes
    for name, out in results.items():
        said = [line for line in out.stderr.splitlines() if "waiting for a Zenoh router" not in line]
        errors = [line for line in said if line.startswith("error:") or ": error:" in line]
        assert len(errors) == 1, f"{name}:\n{out.stderr}"


def test_an_echoed_value_is_cut_short(outcomes):
    """A 900 kB scenario name (in a file within its size bound) is named by its first 200 characters only."""
    _, results = outcomes
    line = results["a 900 kB name"].stderr.strip()
    assert "n" * 150 + "..." in line and "n" * 201 not in line
    assert len(line) < 500, line


def test_a_behaviour_module_is_found_in_the_folder_lunarsim_runs_in(tmp_path):
    """``lunarsim`` (the installed command, whose own folder is first on its path) finds ``my_rovers.slow:Slow``
    in the folder it runs in, as the agents' ``python -m`` will; a missing class there is named."""
    (tmp_path / "my_rovers").mkdir()
    (tmp_path / "my_rovers" / "__init__.py").write_text("")
    (tmp_path / "my_rovers" / "slow.py").write_text(
        "from rover_agent.behaviour import DefaultBehaviour\n\n\nclass Slow(DefaultBehaviour):\n    pass\n")
    text = Path(SCENARIO).read_text()
    for what, spec in (("good", "my_rovers.slow:Slow"), ("bad", "my_rovers.slow:Fast")):
        (tmp_path / f"{what}.yaml").write_text(text + f"behaviour: '{spec}'\n")
    command = str(Path(sys.executable).with_name("lunarsim"))
    runs = {what: subprocess.run([command, "scenario", "check", f"{what}.yaml"], cwd=tmp_path, capture_output=True,
                                 text=True, timeout=HUNG_S) for what in ("good", "bad")}
    assert runs["good"].returncode == 0, runs["good"].stderr
    assert "good.yaml: ok: 'crater_observation'" in runs["good"].stdout
    assert runs["bad"].returncode == EXIT_USAGE
    assert runs["bad"].stderr == ("error: bad.yaml: behaviour 'my_rovers.slow:Fast' cannot be loaded: module "
                                  "'my_rovers.slow' has no attribute 'Fast'\n")


def _error_classes() -> dict[str, type[BaseException]]:
    """Every exception class LunarSim's packages define: found in the source (a class whose base is an exception,
    also through other classes of ours), then imported."""
    import ast
    import builtins
    import importlib

    defined: dict[tuple[str, str], set[str]] = {}
    for path in sorted(REPO.glob("*/**/*.py")):
        parts = path.relative_to(REPO).with_suffix("").parts
        if not (REPO / parts[0] / "__init__.py").is_file() or "node_modules" in parts:
            continue
        module = ".".join(parts).removesuffix(".__init__")
        for node in ast.walk(ast.parse(path.read_text(), str(path))):
            if isinstance(node, ast.ClassDef):
                defined[(module, node.name)] = {getattr(base, "id", getattr(base, "attr", "")) for base in node.bases}
    known = {name for name in dir(builtins) if isinstance(getattr(builtins, name), type)
             and issubclass(getattr(builtins, name), BaseException)}
    errors: set[tuple[str, str]] = set()
    while new := {key for key, bases in defined.items() if key not in errors and bases & known}:
        errors |= new
        known |= {name for _, name in new}
    return {f"{module}.{name}": getattr(importlib.import_module(module), name) for module, name in sorted(errors)}


def test_every_lunarsim_error_sits_under_one_root():
    from schemas.errors import LunarSimError

    classes = _error_classes()
    assert len(classes) > 15, sorted(classes)  # the search finds them
    assert not [name for name, cls in classes.items() if not issubclass(cls, LunarSimError)]


def test_an_error_worded_for_the_user_carries_its_exit_code():
    from bus.errors import RouterUnreachable, UsageError
    from bus.process import run_guarded
    from schemas.scenario_errors import ScenarioError

    def failing(exc: BaseException):
        def run(args) -> int:
            raise exc

        return run

    args = argparse.Namespace(verbose=False)
    assert run_guarded(failing(UsageError("no")), args) == EXIT_USAGE
    assert run_guarded(failing(ScenarioError("no")), args) == EXIT_USAGE
    assert run_guarded(failing(RouterUnreachable("none")), args) == EXIT_NO_ROUTER
    assert run_guarded(failing(ValueError("a bug")), args) == 1
