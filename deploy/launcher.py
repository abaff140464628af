"""A whole mission on this machine, every part its own OS process (``lunarsim run``, ``deploy.commands.run``).

``launch`` starts the world service, the lander agent and a process per rover agent (``agents_per_process`` groups
them, as ``lunarsim rover --ids`` runs them); the world is the Zenoh router the others connect to, unless
``connect`` names a router for all of them. It shows progress, and warns when an agent falls behind the world's
clock (``deploy.agent_lag``); stops when every rover is done or stuck, or at ``max_sim_time``; writes
``report.json`` into the run folder (scoring the lander's traverse map, ``map.npz`` and ``map.png`` there); and
stops every process it started, also on Ctrl-C or SIGTERM.
"""

from __future__ import annotations

import importlib
import shutil
import threading
import time
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

import msgspec

from bus import priority, process
from bus.zenoh_config import DEFAULT_PORT
from deploy.agent_lag import AgentLag
from deploy.rover_groups import groups
from deploy.run_report import REPORT_FILE, import_map_figures_meanwhile, with_map_figures, write_report
from deploy.run_setup import check_port_free, new_run_folder
from schemas.scenario_limits import clip

if TYPE_CHECKING:
    from schemas.scenario import Scenario

START_TIMEOUT_S = 30.0
SESSION_FILE = "session.mcap"
VIEW_PERIOD_S = 0.25
"""The progress view and the check on the processes run this often, however fast the world publishes: a
lockstep world sends its state 75 times a second at 15 x real time, and the launcher shares the cores."""


@dataclass(frozen=True)
class LaunchOptions:
    """How to run a mission: the options of ``lunarsim run`` (its ``--help`` says what each does)."""

    world: str = "default"
    port: int = DEFAULT_PORT
    connect: str | None = None
    time_scale: float = 1.0
    max_sim_time: float | None = None
    lockstep: bool = False
    agents_per_process: int = 1
    agent_priority: str = "auto"
    quiet: bool = False
    record: bool = True
    ros2: bool = False
    external: frozenset[int] = frozenset()
    """Rovers an outside ROS 2 node drives: no agent is started for them."""
    fault_loss: float = 0.0
    verbose: bool = False


def launch(scenario: Scenario, options: LaunchOptions, out: Path | None = None) -> int:
    """Run ``scenario`` to its end in the run folder ``out`` (default runs/<scenario>-<timestamp>); the exit code."""
    from rich.console import Console

    from schemas.scenario import dump_scenario

    if not options.connect:
        check_port_free(options.port)  # before the run folder is made: a run that cannot start leaves nothing
    if out is None:
        out = new_run_folder(Path("runs"), scenario.name)
    elif held := [name for name in (REPORT_FILE, SESSION_FILE) if (out / name).exists()]:
        raise process.UsageError(f"{clip(str(out))} already holds a run ({', '.join(held)}): choose another --out, so "
                                 "no run replaces another's recording and report")
    out.mkdir(parents=True, exist_ok=True)
    scenario_file = out / "scenario.yaml"
    scenario_file.write_text(dump_scenario(scenario))
    console = Console()
    console.print(f"[bold]{scenario.name}[/]: {len(scenario.rovers)} rovers, seed {scenario.seed}, "
                  f"run folder {out}")
    return Mission(options, scenario, scenario_file, out, console).run()


class Mission:
    def __init__(self, options: LaunchOptions, scenario, scenario_file: Path, out: Path, console) -> None:
        from deploy.children import Children
        from rover_agent.commands.rover import PRELOAD

        self.options = options
        self.scenario = scenario
        self.scenario_file = scenario_file
        self.out = out
        self.console = console
        self.children = Children(out / "logs", preload=PRELOAD)
        self.endpoint = options.connect or f"tcp/127.0.0.1:{options.port}"
        self.reported_dead: set[str] = set()
        self.lag = AgentLag()
        self.rejected = 0  # malformed samples on the keys the launcher follows

    def run(self) -> int:
        started = time.monotonic()
        report, interrupted = None, True
        with process.stop_on_signals() as stop:  # to the end: a SIGTERM cannot cut the report short either
            try:
                self._start_processes(stop)
                if not stop.is_set():  # else a Ctrl-C as the run started: there is nothing to follow
                    report, interrupted = self._monitor(stop)
            finally:
                self._shutdown()
            code = process.EXIT_INTERRUPTED if interrupted else 0
            if report is None:
                self.console.print("[yellow]stopped before the world reported any statistics: no report.json[/]")
                return code or 1
            self._report(report, started)
        return code

    def _report(self, report, started: float) -> None:
        from sessions.summary import summary_table

        report = msgspec.structs.replace(report, wall_time_s=round(time.monotonic() - started, 3))
        report = with_map_figures(report, self.scenario, self.out)
        path = write_report(report, self.out)
        self.console.print(summary_table(report))
        if behind := self.lag.summary():
            self.console.print(f"[yellow]{behind}[/]")
        if self.rejected:
            self.console.print(f"[yellow]ignored {self.rejected} malformed sample(s) on the world's statistics, "
                               "state and status keys (not from this mission's processes)[/]")
        self.console.print(f"report written to {path}")

    def _start_processes(self, stop: threading.Event) -> None:
        """Each process in turn, the agents last; none more once ``stop`` is set (a Ctrl-C as the run starts)."""
        self.children.warm_up()  # the rover agents' server imports while the world starts
        common = ["--world", self.options.world, "--connect", self.endpoint]
        shutil.rmtree(self.out / "state", ignore_errors=True)  # a reused run folder must not resume old poses
        (self.out / "state").mkdir()
        if self.options.connect:  # a router is there: everyone joins it, the recorder first
            self._start_recorder(common, stop)
            self.children.start("world", "world_service", *self._world_args(), *common)
        else:
            self._start_world_as_router(stop)
            self._start_recorder(common, stop)
        if stop.is_set():
            return
        agents = priority.for_mode(self.options.agent_priority, self.options.lockstep, len(self.scenario.rovers))
        external = self.options.external
        if self.options.ros2 or external:
            drive = ["--drive", ",".join(map(str, sorted(external)))] if external else []
            self.children.start("ros2", "ros2_bridge", "--params", str(self.scenario_file), *drive, *common)
        # forked from here (else warm): it needs what the rovers' server has imported and more, and came last
        self.children.start("lander", "lander_agent", str(self.scenario_file), "--archive",
                            str(self.out / "lander_archive"), "--map-out", str(self.out), "--state",
                            str(self.out / "state"), *common, forked=True, warm=True, priority=agents)
        count, per = len(self.scenario.rovers), self.options.agents_per_process
        for first, last in groups([i for i in range(1, count + 1) if i not in external], per):
            name, which = self._rover_group(first, last)
            self.children.start(name, "rover_agent", *which, "--params", str(self.scenario_file),
                                "--behaviour", self.scenario.behaviour, *common, warm=True, priority=agents)

    def _rover_group(self, first: int, last: int) -> tuple[str, list[str]]:
        """The child's name and which rovers it runs, each keeping its pose in state/rover<N>.json."""
        state = self.out / "state"
        if first == last:
            return f"rover{first}", ["--id", str(first), "--state", str(state / f"rover{first}.json")]
        return f"rovers{first}-{last}", ["--ids", f"{first}-{last}", "--state", str(state)]

    def _world_args(self) -> list[str]:
        args = [str(self.scenario_file), "--world", self.options.world, "--time-scale", str(self.options.time_scale),
                "--start-timeout", str(START_TIMEOUT_S), "--photos", str(self.out / "photos"),
                "--state", str(self.out / "state" / "world.state")]
        if self.options.max_sim_time is not None:
            args += ["--max-sim-time", str(self.options.max_sim_time)]
        if self.options.lockstep:
            args.append("--lockstep")
        if self.options.fault_loss:
            args += ["--fault-loss", str(self.options.fault_loss)]
        if self.options.verbose:
            args.append("--verbose")  # its progress (and lockstep's summary) into world.log
        return args

    def _start_world_as_router(self, stop: threading.Event) -> None:
        """The world is the run's Zenoh router: every agent's sample reaches it, and its samples every agent, in
        one hop instead of two through a router process (a lockstep tick waits about a quarter less for its acks).
        """
        from lander_agent.commands.lander import PRELOAD as LANDER_PRELOAD
        from world_service.commands.world import listening_line

        check_port_free(self.options.port)
        world = self.children.start("world", "world_service", *self._world_args(), "--listen", self.endpoint,
                                    forked=True)
        for name in LANDER_PRELOAD:  # while the world starts: the lander, forked from here, starts with them
            importlib.import_module(name)
        if self.children.wait_for_line("world", listening_line([self.endpoint]), START_TIMEOUT_S, stop):
            return
        if world.poll() == process.EXIT_USAGE:  # another run took the port between the check and the world's bind
            raise process.UsageError(f"the world could not start: {self.children.log_tail('world', 1)}")
        if not stop.is_set():
            raise RuntimeError(f"the world did not open {self.endpoint}: {self.children.log_tail('world')}")

    def _start_recorder(self, common: list[str], stop: threading.Event) -> None:
        """The recorder subscribes before the world's clock starts (the world waits for the agents, started
        after it), so the session is complete from the first tick."""
        if not self.options.record or stop.is_set():
            return
        self.children.start("recorder", "deploy.cli", "record", "-o", str(self.out / SESSION_FILE), "--scenario",
                            str(self.scenario_file), *common)
        if not self.children.wait_for_line("recorder", "recording", START_TIMEOUT_S, stop) and not stop.is_set():
            raise RuntimeError(f"the recorder did not start: {self.children.log_tail('recorder')}")

    def _open_session(self, open_session, build_config, stop):
        """The launcher's own session; None when ``stop`` ends the wait for it. When the run's router is its own
        world and that world has died, say so: "no router reachable" would send the user to start one."""
        from bus.errors import RouterUnreachable

        try:
            return open_session(build_config(connect=[self.endpoint]), self.endpoint, 10.0, who="lunarsim run",
                                stop=stop)
        except RouterUnreachable:
            if stop.is_set():
                return None
            world = self.children.procs.get("world")
            if world is not None and world.poll() is not None:
                raise RuntimeError(f"the world service exited (code {world.returncode}) before the run could "
                                   f"connect: {self.children.log_tail('world')}") from None
            raise

    def _monitor(self, stop) -> tuple:
        """Follow the world's statistics until the final report; returns (report, interrupted)."""
        from bus.bus import Bus
        from bus.zenoh_config import build_config, open_session
        from deploy.progress import ProgressView, StartUp
        from schemas import messages as m
        from schemas.keyspace import STATUS, Keyspace

        keys = Keyspace(self.options.world)
        state: bytes | None = None  # the latest WorldState, decoded only when shown
        last: m.WorldState | None = None
        report = None
        deadline = self._wall_deadline()
        next_view = 0.0

        def shown() -> m.WorldState | None:
            nonlocal state, last
            if state is not None:
                last = self._decoded(m.WorldState, state) or last
                state = None
            return last

        session = self._open_session(open_session, build_config, stop)
        if session is None:
            return None, True
        start_up = StartUp(len(self.scenario.rovers), keys.alive_lander)
        with Bus(session) as bus, ProgressView(self.console, self.scenario.name, self.options.quiet) as view:
            bus.wake_on(stop)  # Ctrl-C answered at once, not at the view's next refresh
            bus.watch_liveliness(keys.alive_rovers)
            bus.watch_liveliness(keys.alive_lander)
            bus.subscribe(keys.stats)
            bus.subscribe(keys.state)
            if not self.options.lockstep:  # in lockstep the world waits for its agents
                bus.subscribe(keys.rovers(STATUS))
            while not stop.is_set():
                if time.monotonic() >= next_view:
                    next_view = time.monotonic() + VIEW_PERIOD_S
                    self._check_world_alive()
                    view.update(shown(), report, start_up)
                if deadline is not None and time.monotonic() > deadline:
                    self.console.print("[yellow]warning: the world did not finish in time; reporting what it "
                                       "had[/]")
                    return report, False
                item = bus.receive(timeout=VIEW_PERIOD_S)
                if item is None:
                    continue
                if item.alive is not None:
                    start_up.note(item.key, item.alive)
                    continue
                if item.key == keys.state:
                    state = item.payload
                    continue
                if item.key != keys.stats:
                    self._note_status(keys, item)
                    continue
                stats = self._decoded(m.WorldStats, item.payload)
                if stats is None:
                    continue
                self.lag.world(stats.stamp)
                if report is None:  # the mission runs: the start-up's burst of CPU is over
                    import_map_figures_meanwhile()
                report = stats.report
                if stats.final:
                    view.update(shown(), report)
                    return report, False
        return report, True

    def _note_status(self, keys, item) -> None:
        """A rover's status: is its agent keeping up with the world (``deploy.agent_lag``)?"""
        from schemas import messages as m

        try:
            rover_id, _ = keys.parse_rover_key(item.key)
        except ValueError:
            return
        status = self._decoded(m.RoverStatus, item.payload)
        if status is None or not 1 <= rover_id <= len(self.scenario.rovers):
            return  # nothing to judge an agent of this mission by
        if self.lag.status(rover_id, status.stamp):
            self.console.print(f"[yellow]warning: rover {rover_id}'s agent is {self.lag.worst[rover_id]:.1f} s behind "
                               "the world's clock, deciding on old samples. If this machine is short of CPU: in real "
                               "time the agents run below the world's priority, and --agent-priority equal slows the "
                               "world instead[/]")

    def _decoded(self, model, payload: bytes):
        """A sample on the world's keys, or None for one that is not a ``model``: anyone on the router may publish
        there, and the launcher must still end the mission and write its report (counted, said at the end)."""
        from schemas import codec

        try:
            return codec.decode(model, payload)
        except codec.DecodeError:
            self.rejected += 1
            return None

    def _wall_deadline(self) -> float | None:
        if self.options.max_sim_time is None or self.options.lockstep:
            return None
        return time.monotonic() + START_TIMEOUT_S + 60.0 + 2.0 * self.options.max_sim_time / self.options.time_scale

    def _check_world_alive(self) -> None:
        """The world (the router too) is essential; a lost agent is reported once and its rover stops."""
        for name, code in self.children.dead().items():
            if name == "world":
                raise RuntimeError(f"the {name} process exited with status {code}:\n{self.children.log_tail(name)}")
            if name not in self.reported_dead:
                self.reported_dead.add(name)
                self.console.print(f"[red]{name} exited with status {code}[/]: {self.children.log_tail(name, 2)}")

    def _shutdown(self) -> None:
        """Agents first, then the recorder (it has heard everything by then), then the world (and router)."""
        agents = [n for n in self.children.procs if n not in ("world", "recorder")]
        self.children.stop(agents)
        self.children.stop(["recorder"], grace_s=30.0)  # it writes its index and drop counts on the way out
        self.children.stop(["world"])
