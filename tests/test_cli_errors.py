"""Bad input to real ``lunarsim`` processes: a non-zero exit code, a message naming the problem, never a traceback.

Every case is its own process; they all run at once (most exit in about a second, the ones waiting for a router
that is not there within their router timeout), so the table costs about as long as its slowest case.
"""

from __future__ import annotations

import socket
import subprocess
import time
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass
from pathlib import Path

import pytest
from procs import SCENARIOS, free_port, lunarsim

from bus.process import EXIT_NO_ROUTER, EXIT_USAGE
from bus.zenoh_config import ONE_SHOT_TIMEOUT_S

SCENARIO = str(SCENARIOS / "crater_observation.yaml")
NO_ROUTER = f"tcp/127.0.0.1:{free_port()}"
WAIT_S = 2
"""``--router-timeout`` for agents, which wait for their router for ever unless told otherwise."""
TAKEN = socket.create_server(("127.0.0.1", 0))
"""A port something else listens on, for the whole module."""


@dataclass(frozen=True)
class Case:
    name: str
    args: tuple[str, ...]
    message: str
    code: int = EXIT_USAGE
    within_s: float = 30.0


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
        Case("unknown flag", (*run("r8"), SCENARIO, "--bogus"), "lunarsim run: error: unrecognized arguments: --bogus"),
        Case("port taken", ("run", "--port", str(TAKEN.getsockname()[1]), "--out", str(d / "runs" / "r18"), SCENARIO),
             f"port {TAKEN.getsockname()[1]} on 127.0.0.1 is already in use"),
        Case("unknown command", ("fly",), "invalid choice: 'fly'"),
        Case("unknown flag after a command's own 'command' argument", ("command", "stop", "--rover", "3", "--bogus"),
             "lunarsim command: error: unrecognized arguments: --bogus"),
        Case("seek before the start", ("command", "seek", "--seconds", "-1"), "--seconds: Input should be greater"),
        Case("a target beyond any scenario", ("command", "set-target", "--x", "1e12", "--z", "0"),
             "--x: Input should be less than or equal to 10000000"),
        Case("--rovers 0", (*run("r9"), SCENARIO, "--rovers", "0"), "--rovers must be at least 1, got 0"),
        Case("--rovers -1", (*run("r10"), SCENARIO, "--rovers", "-1"), "--rovers must be at least 1, got -1"),
        Case("--rovers 1001", (*run("r11"), SCENARIO, "--rovers", "1001"), "--rovers must be at most 1000"),
        Case("--seed -1", (*run("r12"), SCENARIO, "--seed", "-1"), "--seed must be at least 0"),
        Case("world name with '/' and '*'", (*run("r13"), SCENARIO, "--world", "a/b*"), "invalid world name 'a/b*'"),
        Case("world name with '@'", ("world", SCENARIO, "--world", "@w"), "invalid world name '@w'"),
        Case("world name for a command", ("command", "stop", "--world", "w?"), "invalid world name 'w?'"),
        Case("negative --max-sim-time", (*run("r14"), SCENARIO, "--max-sim-time", "-5"),
             "--max-sim-time must be more than 0"),
        Case("nan --time-scale", (*run("r15"), SCENARIO, "--time-scale", "nan"),
             "--time-scale must be a finite number"),
        Case("replay a missing file", ("replay", str(d / "missing.mcap")), "missing.mcap: no such file"),
        Case("replay garbage", ("replay", str(d / "garbage.mcap")), "garbage.mcap: not an MCAP file"),
        Case("report garbage", ("report", str(d / "garbage.mcap")), "garbage.mcap: not a readable MCAP recording"),
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
             f"no Zenoh router reachable at {NO_ROUTER}", EXIT_NO_ROUTER, ONE_SHOT_TIMEOUT_S + 15),
        *[Case(f"{what} --connect to no router", (what, *extra, "--connect", NO_ROUTER, "--router-timeout",
                                                  str(WAIT_S)),
               f"no Zenoh router reachable at {NO_ROUTER} after {WAIT_S} s", EXIT_NO_ROUTER, WAIT_S + 15)
          for what, extra in [("world", (SCENARIO,)), ("rover", ("--id", "1")), ("lander", (SCENARIO,)),
                              ("record", ("-o", str(d / "rec" / "s.mcap")))]],
    ]


@dataclass(frozen=True)
class Outcome:
    code: int
    output: str
    stderr: str
    seconds: float


def _run(case: Case) -> Outcome:
    start = time.monotonic()
    proc = lunarsim(*case.args)
    try:
        stdout, stderr = proc.communicate(timeout=60)
    except subprocess.TimeoutExpired:
        proc.kill()
        stdout, stderr = proc.communicate()
    return Outcome(proc.returncode, stdout + stderr, stderr, time.monotonic() - start)


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
    assert out.code == case.code, f"exit {out.code}, expected {case.code}:\n{out.output}"
    assert case.message in out.stderr, out.output
    assert "Traceback" not in out.output, out.output
    assert out.seconds < case.within_s, f"took {out.seconds:.1f} s"
    if "--out" in case.args:
        assert not Path(case.args[case.args.index("--out") + 1]).exists(), f"a run folder was left:\n{out.output}"


def test_the_error_is_one_line(outcomes):
    """Besides a notice that it is waiting for the router, a failing command says one line, starting 'error:'."""
    _, results = outcomes
    for name, out in results.items():
        said = [line for line in out.stderr.splitlines() if "waiting for a Zenoh router" not in line]
        errors = [line for line in said if line.startswith("error:") or ": error:" in line]
        assert len(errors) == 1, f"{name}:\n{out.stderr}"
