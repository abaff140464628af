"""The processes of one scale measurement: what it runs (``Plan``: how many rovers, how many to a process, real
time or lockstep) and the router, world, lander, rover agents and witness it starts (``Cluster``)."""

from __future__ import annotations

import subprocess
import sys
import time
from dataclasses import dataclass
from functools import partial
from pathlib import Path

from control_loop_latency import BenchmarkError, free_port
from proc_meter import with_descendants
from scale_hosts import TwoHosts

from bus.priority import Priority, lower
from deploy.children import Children, wait_for_port
from rover_agent.commands.rover import PRELOAD
from schemas import keyspace as ks
from schemas.scenario import Scenario
from world_service.clock import tick_length, ticks_per_period

WORLD = "bench"
WITNESS = Path(__file__).resolve().parent / "scale_witness.py"
HOST = "127.0.0.1"

_t0 = time.monotonic()


def progress(text: str) -> None:
    print(f"[{time.monotonic() - _t0:6.0f} s] {text}", file=sys.stderr, flush=True)


@dataclass(frozen=True)
class Plan:
    """One measurement: how many rovers, how many agents share a process, real time or lockstep."""

    rovers: int
    per_process: int = 1
    lockstep: bool = False

    @property
    def processes(self) -> int:
        return -(-self.rovers // self.per_process)

    def rover_groups(self) -> list[list[str]]:
        """Command-line id arguments of each rover process."""
        if self.per_process == 1:
            return [["--id", str(i)] for i in range(1, self.rovers + 1)]
        starts = range(1, self.rovers + 1, self.per_process)
        return [["--ids", f"{a}-{min(a + self.per_process - 1, self.rovers)}"] for a in starts]

    def describe(self) -> str:
        share = "one process each" if self.per_process == 1 else f"{self.per_process} per process"
        return f"{self.rovers} rovers in {self.processes} processes ({share}), {self.mode}"

    @property
    def mode(self) -> str:
        return "lockstep" if self.lockstep else "real time"


class Cluster:
    """The router, world, lander and rover processes of one measurement; ``stop`` ends every one of them.

    With ``hosts`` (``scale_hosts.TwoHosts``) the world and the lander run on one host behind a router, the rovers
    and the witness on another behind a second router joined to the first; each host's processes connect to the
    router on their own loopback, and the benchmark to the first router over its link."""

    def __init__(self, logs: Path, plan: Plan, scenario_file: Path, scenario: Scenario,
                 router_process: bool = False, agents: Priority = "equal", hosts: TwoHosts | None = None) -> None:
        self.children = Children(logs, preload=PRELOAD)
        self.plan, self.scenario_file, self.scenario = plan, scenario_file, scenario
        self.agents = agents
        """The agents' CPU priority (``bus.priority``), as ``lunarsim run`` would give them."""
        self.hosts = hosts
        self.router_process = router_process or hosts is not None
        self.port = free_port()
        self.local_endpoint = f"tcp/{HOST}:{self.port}"
        """Where the world, the lander, the rovers and the witness connect: on each host, its router."""
        self.endpoint = f"tcp/{hosts.hub_from_here if hosts else HOST}:{self.port}"
        """Where the benchmark connects."""
        self.common = ["--world", WORLD, "--connect", self.local_endpoint]

    def on(self, role: str) -> tuple[str, ...]:
        """The command prefix of a process of ``role`` ("hub": world, lander and their router; "fleet": rovers)."""
        if self.hosts is None:
            return ()
        return self.hosts.on(self.hosts.hub if role == "hub" else self.hosts.fleet)

    def start_router(self, world_args: list[str]) -> None:
        """The router everyone connects to: the world itself, or a router process (see ``--routing``); on two
        hosts, one on each."""
        if self.router_process:
            listen = f"tcp/0.0.0.0:{self.port}" if self.hosts else self.endpoint
            hub = self.children.start("router", "deploy.router", "--listen", listen, prefix=self.on("hub"))
        else:
            hub = self.children.start("world", "world_service", str(self.scenario_file), "--world", WORLD,
                                      "--listen", self.endpoint, *world_args)
        host = self.hosts.hub_from_here if self.hosts else HOST
        if not wait_for_port(host, self.port, 30.0, hub):
            name = "router" if self.router_process else "world"
            raise BenchmarkError(f"the {name} did not open {self.endpoint}" + self.tail(name))
        if self.hosts:  # the rovers wait for it if they start first
            self.children.start("fleet_router", "deploy.router", "--listen", self.local_endpoint, "--connect",
                                f"tcp/{self.hosts.hub_from_fleet}:{self.port}", prefix=self.on("fleet"))

    def start_world_and_lander(self, world_args: list[str]) -> None:
        if self.router_process:
            self.children.start("world", "world_service", str(self.scenario_file), *self.common, *world_args,
                                prefix=self.on("hub"))
        self.children.start("lander", "lander_agent", str(self.scenario_file), *self.common, priority=self.agents,
                            prefix=self.on("hub"))

    def start_rovers(self) -> None:
        for ids in self.plan.rover_groups():
            self.children.start(f"rover{ids[1]}", "rover_agent", *ids, "--params", str(self.scenario_file),
                                "--behaviour", self.scenario.behaviour, *self.common, warm=True, priority=self.agents,
                                prefix=self.on("fleet"))

    def start_witness(self, out: Path, sampled: list[int]) -> None:
        """The second observer (scale_witness.py), stopped with the others; it writes ``out`` when stopped. It runs
        at the agents' priority, on their host, so what it receives, and when, is what a rover agent's Zenoh thread
        sees."""
        log = open(self.children.log_dir / "witness.log", "wb")  # noqa: SIM115 - the child's for its lifetime
        self.children.procs["witness"] = subprocess.Popen(
            [*self.on("fleet"), sys.executable, str(WITNESS), self.local_endpoint, WORLD, str(out), *map(str, sampled)],
            stdout=log, stderr=subprocess.STDOUT, stdin=subprocess.DEVNULL, preexec_fn=partial(lower, self.agents))
        log.close()
        deadline = time.monotonic() + 30.0
        while "witness ready" not in self.children.log_tail("witness", 1):
            if self.children.procs["witness"].poll() is not None or time.monotonic() > deadline:
                raise BenchmarkError("the witness did not start" + self.tail("witness"))
            time.sleep(0.05)

    def groups(self) -> dict[str, list[int]]:
        procs = self.children.procs
        roles = {"router": ["router", "fleet_router"], "world": ["world"], "lander": ["lander"],
                 "rovers": [n for n in procs if n.startswith("rover")], "witness": ["witness"]}
        groups = {role: [procs[n].pid for n in names if n in procs] for role, names in roles.items()}
        groups["world"] = [p for pid in groups["world"] for p in with_descendants(pid)]
        return groups

    def check(self) -> None:
        dead = self.children.dead()
        if dead:
            name = next(iter(dead))
            raise BenchmarkError(f"{len(dead)} process(es) exited during the measurement: "
                                 f"{dict(list(dead.items())[:5])}" + self.tail(name))

    def tail(self, name: str) -> str:
        return f"\n--- last lines of {name}'s log:\n{self.children.log_tail(name, 10) or '(empty)'}"

    def stop(self) -> None:
        hub = "router" if self.router_process else "world"
        self.children.stop([n for n in self.children.procs if n != hub], grace_s=10.0)
        self.children.stop([hub])


def sampled_ids(rovers: int, k: int) -> list[int]:
    """``k`` rover ids spread evenly over 1..rovers, first and last included."""
    k = min(k, rovers)
    return [1] if k == 1 else sorted({round(1 + i * (rovers - 1) / (k - 1)) for i in range(k)})


@dataclass
class Setting:
    """What every measurement shares, from the command line."""

    scenario: Path
    seconds: float
    warmup: float
    sample: int
    startup_timeout: float
    lockstep_sim_time: float
    lockstep_timeout: float
    work: Path
    witness: bool
    lockstep_sample: int = 0
    routing: str = "auto"
    agent_priority: str = "auto"
    hosts: TwoHosts | None = None
    """``--two-hosts``: every measurement on two hosts, each behind a router process of its own."""

    def router_process(self, plan: Plan) -> bool:
        """Whether ``plan`` runs behind a router process rather than the world routing (see ``--routing``)."""
        if self.hosts is not None:
            return True
        if self.routing == "auto":
            return plan.per_process > 1 and not plan.lockstep
        return self.routing == "process"


def periods(scenario: Scenario) -> tuple[float, dict[str, int]]:
    """The world's tick and each sensor's period in ticks, from the scenario's rover parameters."""
    p = scenario.rover_params
    dt = tick_length(p)
    return dt, {ks.PERCEPTION: ticks_per_period(p.perception.publish_frequency, dt),
                ks.GYROSCOPE: ticks_per_period(p.perception.gyroscope_frequency, dt),
                ks.NAVIGATION_STATUS: ticks_per_period(p.navigation.publish_frequency, dt)}
