"""Agents forked from the warm server (``deploy.warm_start``) behave as ``python -m`` processes would: their own
pid, their output in their log, their exit code, and they stop on SIGTERM."""

from __future__ import annotations

import os
import subprocess
import sys
import time
from pathlib import Path

import pytest
from procs import REPO, free_port, processes_mentioning, wait_for

from bus.process import EXIT_USAGE
from deploy.children import Children, wait_for_port
from rover_agent.commands.rover import PRELOAD


def _finished(children: Children, name: str, timeout_s: float = 30.0) -> int:
    proc = children.procs[name]
    wait_for(lambda: proc.poll() is not None, timeout_s, f"{name} to exit")
    return proc.returncode


def test_warm_child_writes_its_log_and_exits_with_its_code(tmp_path: Path) -> None:
    children = Children(tmp_path, preload=PRELOAD)
    children.start("help", "rover_agent", "--help", warm=True)
    children.start("bad", "rover_agent", "--world", "w", warm=True)
    try:
        assert _finished(children, "help") == 0
        assert "usage: python -m rover_agent" in (tmp_path / "help.log").read_text()
        assert _finished(children, "bad") == EXIT_USAGE
        assert "give the rover's --id" in children.log_tail("bad")
    finally:
        children.stop()


def test_warm_child_is_its_own_process_and_stops_on_sigterm(tmp_path: Path) -> None:
    children = Children(tmp_path, preload=PRELOAD)
    endpoint = f"tcp/127.0.0.1:{free_port()}"  # no router there: the agent waits for one, saying so
    proc = children.start("rover1", "rover_agent", "--id", "1", "--connect", endpoint, warm=True)
    try:
        wait_for(lambda: "waiting for a Zenoh router" in children.log_tail("rover1"), 30.0, "the rover's notice")
        assert proc.pid != os.getpid() and Path(f"/proc/{proc.pid}").exists()
        assert processes_mentioning(f"-m rover_agent --id 1 --connect {endpoint}") == [proc.pid]  # as in ps
        assert children.dead() == {}
        started = time.monotonic()
        children.stop(grace_s=10.0)
        assert proc.returncode is not None and time.monotonic() - started < 10.0
        assert children.dead() == {"rover1": proc.returncode}
    finally:
        children.stop()


LAUNCHER = """
import sys, time
from pathlib import Path
from deploy.children import Children, wait_for_port
from rover_agent.commands.rover import PRELOAD
children = Children(Path(sys.argv[1]), preload=PRELOAD)
proc = children.start("rover1", "rover_agent", "--id", "1", "--connect", sys.argv[2], warm=True)
print(proc.pid, flush=True)
time.sleep(600)
"""


def test_warm_children_end_when_their_launcher_is_killed(tmp_path: Path) -> None:
    """SIGKILL leaves the launcher no time to stop anything: the fork server and its agents must end by
    themselves, as Popen children do (they get SIGTERM when their parent dies)."""
    launcher = subprocess.Popen([sys.executable, "-c", LAUNCHER, str(tmp_path), f"tcp/127.0.0.1:{free_port()}"],
                                stdout=subprocess.PIPE, text=True, cwd=REPO)
    try:
        rover = int(launcher.stdout.readline())
        log = Children(tmp_path)
        wait_for(lambda: "waiting for a Zenoh router" in log.log_tail("rover1"), 30.0, "the rover to run")
    finally:
        launcher.kill()
        launcher.wait()
    wait_for(lambda: not _alive(rover), 15.0, f"rover process {rover} to end after its launcher was killed")


HEAVY_LAUNCHER = """
import sys
from pathlib import Path
with open(sys.argv[1] + "/runs.txt", "a") as runs:  # each run of this script, under the name it ran as
    runs.write(__name__ + "\\n")
if __name__ == "__main__":
    from deploy.children import Children
    from rover_agent.commands.rover import PRELOAD
    children = Children(Path(sys.argv[1]), preload=PRELOAD)
    children.start("help", "rover_agent", "--help", warm=True)
    children.procs["help"].wait(30)
    print("child exited", children.procs["help"].returncode, flush=True)
"""


def test_a_warm_child_does_not_run_its_launchers_script_again(tmp_path: Path) -> None:
    """multiprocessing would run the parent's main script again in each child, as ``__mp_main__``: a heavy one
    (the scale benchmark's) cost each of 100 rovers 0.2 CPU seconds and 14 MiB."""
    script = tmp_path / "launcher.py"
    script.write_text(HEAVY_LAUNCHER)
    out = subprocess.run([sys.executable, str(script), str(tmp_path)], capture_output=True, text=True, cwd=REPO,
                         timeout=60)
    assert "child exited 0" in out.stdout, out.stdout + out.stderr
    assert "usage: python -m rover_agent" in (tmp_path / "help.log").read_text()
    assert (tmp_path / "runs.txt").read_text().split() == ["__main__"]


def _alive(pid: int) -> bool:
    try:
        return Path(f"/proc/{pid}/stat").read_text().split()[2] != "Z"
    except OSError:
        return False


def _thread_policies(pid: int) -> dict[str, int]:
    """Each thread's scheduling policy (field 41 of /proc/<pid>/task/<tid>/stat), by thread id and name."""
    policies = {}
    for tid in os.listdir(f"/proc/{pid}/task"):
        stat = Path(f"/proc/{pid}/task/{tid}/stat").read_text()
        name, rest = stat[stat.index("(") + 1:stat.rindex(")")], stat[stat.rindex(")") + 2:].split()
        policies[f"{tid} {name}"] = int(rest[38])
    return policies


@pytest.mark.parametrize("warm", [True, False], ids=["warm", "cold"])
def test_an_agent_started_idle_runs_every_thread_in_the_idle_class(tmp_path: Path, warm: bool) -> None:
    """Lowered before it starts any thread, so Zenoh's threads, started later, inherit the class; the router
    started beside it keeps the default. A cold start is lowered before ``exec``: its first thread is already in
    the class, and the kernel gives every later one the same. A warm one is forked from a process that has
    imported everything, so its Zenoh threads are checked. On a machine busy with other work an idle-class process
    gets almost no CPU: the wait for them is long."""
    children = Children(tmp_path, preload=PRELOAD)
    port = free_port()
    endpoint = f"tcp/127.0.0.1:{port}"
    router = children.start("router", "deploy.router", "--listen", endpoint)
    assert wait_for_port("127.0.0.1", port, 30.0, router)
    proc = children.start("rover1", "rover_agent", "--id", "1", "--connect", endpoint, warm=warm, priority="idle")
    try:
        def connected() -> dict[str, int] | None:  # Zenoh's link is up: its sending thread is there
            policies = _thread_policies(proc.pid)
            return policies if any(" tx-" in thread for thread in policies) else None

        policies = wait_for(connected, 180.0, "the rover's Zenoh threads") if warm else _thread_policies(proc.pid)
        assert policies and set(policies.values()) == {os.SCHED_IDLE}, policies
        assert set(_thread_policies(router.pid).values()) == {os.SCHED_OTHER}
    finally:
        children.stop()


FORKING_LAUNCHER = """
import logging, sys, threading
from pathlib import Path
from deploy.children import Children
logging.basicConfig(level=logging.WARNING)  # the launcher's own log set-up, which the world must not keep
if sys.argv[3] == "with a thread":
    threading.Thread(target=threading.Event().wait, daemon=True).start()
children = Children(Path(sys.argv[1]))
proc = children.start("world", "world_service", sys.argv[4], "--no-state", "--start-timeout", "600", "--listen",
                      sys.argv[2], forked=True)
print(type(proc).__name__, proc.pid, flush=True)
sys.stdin.readline()
children.stop(grace_s=30.0)
print("world exited", proc.returncode, flush=True)
"""


@pytest.mark.parametrize("threads", ["alone", "with a thread"])
def test_the_world_forked_from_its_launcher_is_a_world_process_of_its_own(tmp_path: Path, threads: str) -> None:
    """``lunarsim run`` forks its world from itself, which has imported the scenario's models, unless a thread
    runs in it (Zenoh's, once it has opened a session): a forked child keeps only the thread that forked, so then
    the world starts cold. Either way it is the world: its own pid and command line, its log at INFO, its camera
    process (which a daemonic child could not start), and it stops on SIGTERM with status 0."""
    port = free_port()
    endpoint = f"tcp/127.0.0.1:{port}"
    launcher = subprocess.Popen([sys.executable, "-c", FORKING_LAUNCHER, str(tmp_path), endpoint, threads,
                                 str(REPO / "scenarios" / "crater_observation.yaml")], cwd=REPO, text=True,
                                stdin=subprocess.PIPE, stdout=subprocess.PIPE)
    try:
        kind, pid = launcher.stdout.readline().split()
        assert kind == ("WarmProcess" if threads == "alone" else "Popen")
        assert wait_for_port("127.0.0.1", port, 60.0)
        log = Children(tmp_path)
        wait_for(lambda: "waiting up to 600 s for 6 agent(s)" in log.log_tail("world", 20), 30.0, "the world's log")
        assert processes_mentioning(f"-m world_service {REPO / 'scenarios'}") == [int(pid)]
        wait_for(lambda: len(_children_of(int(pid))) >= 1, 30.0, "the world's camera process")
        out, _ = launcher.communicate("\n", timeout=60)
        assert out == "world exited 0\n", log.log_tail("world", 20)
    finally:
        launcher.kill()
        launcher.wait()


def _children_of(pid: int) -> list[int]:
    try:
        return [int(c) for c in Path(f"/proc/{pid}/task/{pid}/children").read_text().split()]
    except OSError:
        return []


LEAVES_ITS_POOL = """
import sys
from concurrent.futures import ProcessPoolExecutor
pool = ProcessPoolExecutor(max_workers=1)
pool.submit(print, "pool up").result()
sys.exit(3)  # without shutting its pool down
"""

FORKS_IT = """
import sys
from pathlib import Path
from deploy import warm_start
sys.path.insert(0, sys.argv[1])
child = warm_start.fork_here("leaves_its_pool", [], Path(sys.argv[1]) / "child.log")
print(child.wait(timeout=60), flush=True)
"""


def test_a_forked_child_that_leaves_its_pool_running_still_ends_with_its_own_code(tmp_path: Path) -> None:
    """A forked child's end waits for its processes before ``concurrent.futures`` would stop its pools (a plain
    interpreter stops them first): the world, stopped by Ctrl-C as its camera started, waited for the camera for
    ever. Here a program ends without shutting its pool down, as that world did."""
    (tmp_path / "leaves_its_pool.py").write_text(LEAVES_ITS_POOL)
    done = subprocess.run([sys.executable, "-c", FORKS_IT, str(tmp_path)], capture_output=True, text=True, cwd=REPO,
                          timeout=120)
    assert done.stdout == "3\n", done.stdout + done.stderr + (tmp_path / "child.log").read_text()


COUNTS_ITS_HEAP = """
import gc
print(gc.get_freeze_count(), len(gc.get_objects()))
"""

FORKS_THE_COUNTER = """
import sys
from pathlib import Path
from deploy import warm_start
from schemas import scenario  # a launcher's heap: the scenario's models
sys.path.insert(0, sys.argv[1])
child = warm_start.fork_here("counts_its_heap", [], Path(sys.argv[1]) / "child.log")
print(child.wait(timeout=60), flush=True)
"""


def test_a_child_forked_here_leaves_its_parents_heap_out_of_its_collections(tmp_path: Path) -> None:
    """The world and the lander are forked from the launcher, which has imported the scenario's models: their
    start-up freeze's full collection scanned all that again (52 ms of the lander's start, 22 ms of the world's
    before its clock). Forked from a frozen heap, a child's collections scan only what it made itself."""
    (tmp_path / "counts_its_heap.py").write_text(COUNTS_ITS_HEAP)
    done = subprocess.run([sys.executable, "-c", FORKS_THE_COUNTER, str(tmp_path)], capture_output=True, text=True,
                          cwd=REPO, timeout=120)
    assert done.stdout == "0\n", done.stdout + done.stderr
    frozen, scanned = map(int, (tmp_path / "child.log").read_text().split())
    assert frozen > 10 * scanned, f"{frozen} objects frozen, {scanned} left to scan"


CTRL_C_AS_THE_SERVER_STARTS = """
import os, signal, sys
from pathlib import Path
from multiprocessing import forkserver
from deploy.children import Children
from rover_agent.commands.rover import PRELOAD
children = Children(Path(sys.argv[1]), preload=PRELOAD)
children.warm_up()
server = forkserver._forkserver._forkserver_pid
ignored = int(Path(f"/proc/{server}/status").read_text().split("SigIgn:")[1].split()[0], 16)
print("ignores Ctrl-C from its start:", bool(ignored & 1 << (signal.SIGINT - 1)), flush=True)
os.kill(server, signal.SIGINT)  # a Ctrl-C while it imports
children.start("help", "rover_agent", "--help", warm=True)
print(children.procs["help"].wait(60), flush=True)
"""


def test_a_ctrl_c_while_the_warm_server_imports_leaves_it_serving_and_quiet(tmp_path: Path) -> None:
    """The standard library's server ignores Ctrl-C only once its imports are done; before that one ended it with
    a traceback on the user's terminal, and the launcher's next agent with "EOFError" when it came as the agent
    started. Read as the server has just been spawned, before any import: it ignores Ctrl-C already."""
    done = subprocess.run([sys.executable, "-c", CTRL_C_AS_THE_SERVER_STARTS, str(tmp_path)], capture_output=True,
                          text=True, cwd=REPO, timeout=120)
    assert (done.stdout, done.stderr) == ("ignores Ctrl-C from its start: True\n0\n", ""), done.stderr
    assert "usage: python -m rover_agent" in (tmp_path / "help.log").read_text()
