"""How LunarSim rides out faults, measured over real processes on loopback (``lunarsim run``).

- reconnect: a mission on a router this script starts (``--connect``); once every rover is under way the router
  is SIGKILLed and, after ``--outage`` seconds, restarted on its port (``--restarts`` times). Measured from each
  restart: the first world state through the new router (the world and this script's own session have both
  reconnected), and every rover agent alive again in the world's state (each agent has reconnected and its
  liveliness token is back).
- loss: the crater mission in lockstep with ``--fault-loss P`` for each P: rovers that reached their final goal,
  rovers the watchdog counted stalled, simulated and wall time.
- recovery: a second recorder beside the run's own, SIGKILLed mid-mission after ``--record-s`` seconds;
  ``lunarsim recover`` rewrites its file; the share of the samples the run's own recorder holds up to the kill
  that the recovered file has.

    python benchmarks/chaos.py [--scenario FILE] [--losses 0 0.01 0.05 0.2] [--outage 1.5] [--restarts 2]
                               [--record-s 10] [--json FILE]
    python benchmarks/chaos.py --quick    # 1 rover, one restart, one loss level, missions cut short
"""

from __future__ import annotations

import argparse
import json
import signal
import subprocess
import sys
import tempfile
import time
from collections.abc import Callable
from pathlib import Path

import quick
import zenoh
from control_loop_latency import free_port
from host import describe, line

from bus.zenoh_config import build_config
from deploy.children import wait_for_port
from schemas import codec
from schemas import messages as m
from schemas.keyspace import Keyspace
from sessions.format import read_samples

REPO = Path(__file__).resolve().parents[1]
SCENARIO = REPO / "scenarios" / "crater_observation.yaml"
QUICK = {"losses": [0.05], "outage": 0.5, "restarts": 1, "record_s": 2.0, "time_scale": 6.0, "rovers": 1,
         "max_sim_time": 20.0}


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--scenario", type=Path, default=SCENARIO)
    parser.add_argument("--losses", type=float, nargs="+", default=[0.0, 0.01, 0.05, 0.2], metavar="P")
    parser.add_argument("--outage", type=float, default=1.5, metavar="S", help="seconds the router stays down")
    parser.add_argument("--restarts", type=int, default=2, help="router restarts in the reconnect mission")
    parser.add_argument("--record-s", type=float, default=10.0, metavar="S",
                        help="seconds the second recorder records before it is killed")
    parser.add_argument("--time-scale", type=float, default=4.0, help="of the real-time missions (default 4)")
    parser.add_argument("--rovers", type=int, help="respawn the scenario with this many rovers (default: its own)")
    parser.add_argument("--max-sim-time", type=float, metavar="S", help="stop each mission after S simulated "
                        "seconds (default: when it ends)")
    parser.add_argument("--json", type=Path)
    args = quick.parse_args(parser, QUICK, argv)
    result: dict = {"host": describe()}
    with tempfile.TemporaryDirectory(prefix="chaos-") as tmp:
        folder = Path(tmp)
        result["reconnect"] = reconnect(folder / "reconnect", args)
        result["loss"] = [loss(folder / f"loss-{p:g}", args, p) for p in args.losses]
        result["recovery"] = recovery(folder / "recovery", args)
    show(result)
    if args.json:
        args.json.write_text(json.dumps(result, indent=2) + "\n")
    return 0


# ---- processes ----


def _router(port: int, log: Path) -> subprocess.Popen:
    with open(log, "a") as out:
        proc = subprocess.Popen([sys.executable, "-m", "deploy.router", "--listen", f"tcp/127.0.0.1:{port}"],
                                cwd=REPO, stdout=out, stderr=subprocess.STDOUT)
    if not wait_for_port("127.0.0.1", port, 15, proc):
        raise SystemExit(f"the router did not start: {log.read_text()}")
    return proc


def _run(out: Path, args: argparse.Namespace, *flags: str) -> subprocess.Popen:
    out.parent.mkdir(parents=True, exist_ok=True)
    log = open(out.parent / f"{out.name}.out", "w")  # noqa: SIM115 (the child holds it; closed at exit)
    sizes = [*(["--rovers", str(args.rovers)] if args.rovers else []),
             *(["--max-sim-time", str(args.max_sim_time)] if args.max_sim_time else [])]
    return subprocess.Popen([sys.executable, "-m", "deploy.cli", "run", str(args.scenario), "--quiet", "--out",
                             str(out), *sizes, *flags], cwd=REPO, stdout=log, stderr=subprocess.STDOUT)


def _finish(run: subprocess.Popen, out: Path, timeout: float = 600) -> dict:
    if run.wait(timeout=timeout) != 0:
        raise SystemExit(f"lunarsim run exited {run.returncode}: {(out.parent / f'{out.name}.out').read_text()}")
    return json.loads((out / "report.json").read_text())


def _wait(predicate: Callable[[], object], timeout: float, what: str) -> None:
    deadline = time.monotonic() + timeout
    while not predicate():
        if time.monotonic() > deadline:
            raise SystemExit(f"timed out after {timeout:g} s waiting for {what}")
        time.sleep(0.01)


def _stop(*procs: subprocess.Popen | None) -> None:
    for proc in procs:
        if proc is not None and proc.poll() is None:
            proc.send_signal(signal.SIGTERM)
            try:
                proc.wait(timeout=30)
            except subprocess.TimeoutExpired:
                proc.kill()


class States:
    """World states heard through the router: the latest, and when each arrived with every rover agent alive."""

    def __init__(self, endpoint: str, keys: Keyspace) -> None:
        self.state: m.WorldState | None = None
        self.arrivals: list[tuple[float, bool]] = []  # (monotonic time, every rover alive)
        self.session = zenoh.open(build_config(connect=[endpoint]))
        self.session.declare_subscriber(keys.state, self._on_state)

    def _on_state(self, sample: zenoh.Sample) -> None:
        self.state = codec.decode(m.WorldState, sample.payload.to_bytes())
        self.arrivals.append((time.monotonic(), all(r.alive for r in self.state.rovers)))

    def first_after(self, t: float, all_alive: bool = False) -> float | None:
        """Seconds from ``t`` to the first state after it (with every rover alive)."""
        return next((at - t for at, alive in self.arrivals if at > t and (alive or not all_alive)), None)

    def under_way(self, metres: float) -> bool:
        return self.state is not None and all(r.distance_covered_m > metres for r in self.state.rovers)

    def close(self) -> None:
        self.session.close()


# ---- the three measurements ----


def reconnect(out: Path, args: argparse.Namespace) -> dict:
    port = free_port()
    endpoint = f"tcp/127.0.0.1:{port}"
    keys = Keyspace("chaos")
    out.parent.mkdir(parents=True, exist_ok=True)
    router = _router(port, out.parent / "router.log")
    run = _run(out, args, "--connect", endpoint, "--world", keys.world, "--time-scale", str(args.time_scale),
               "--no-record")
    states = States(endpoint, keys)
    restarts = []
    try:
        for n in range(args.restarts):
            _wait(lambda n=n: states.under_way(5 + 20 * n), 120, "every rover under way")
            router.kill()
            router.wait()
            time.sleep(args.outage)  # the outage itself
            router = _router(port, out.parent / "router.log")
            restarted = time.monotonic()
            _wait(lambda r=restarted: states.first_after(r, all_alive=True) is not None, 60,
                  "world states with every rover agent back")
            restarts.append({"first_state_s": round(states.first_after(restarted), 2),
                             "all_agents_s": round(states.first_after(restarted, all_alive=True), 2)})
        report = _finish(run, out)
    finally:
        states.close()
        _stop(run, router)
    return {"outage_s": args.outage, "restarts": restarts, "reached": report["rovers_reached_final_goal"],
            "total": report["rovers_total"], "complete": report["complete"]}


def loss(out: Path, args: argparse.Namespace, share: float) -> dict:
    run = _run(out, args, "--lockstep", "--fault-loss", str(share), "--port", str(free_port()), "--no-record")
    report = _finish(run, out)
    return {"loss": share, "reached": report["rovers_reached_final_goal"], "total": report["rovers_total"],
            "stalled": report["rovers_stalled"], "sim_s": report["mission_duration_s"],
            "wall_s": report["wall_time_s"]}


def recovery(out: Path, args: argparse.Namespace) -> dict:
    port = free_port()
    endpoint = f"tcp/127.0.0.1:{port}"
    keys = Keyspace("chaos-rec")
    out.parent.mkdir(parents=True, exist_ok=True)
    router = _router(port, out.parent / "router.log")
    victim_file, fixed = out.parent / "victim.mcap", out.parent / "recovered.mcap"
    victim = subprocess.Popen([sys.executable, "-m", "deploy.cli", "record", "-o", str(victim_file), "--world",
                               keys.world, "--connect", endpoint], cwd=REPO, stdout=subprocess.PIPE,
                              stderr=subprocess.STDOUT, text=True)
    run = states = None
    try:
        if "recording" not in victim.stdout.readline():
            raise SystemExit("the second recorder did not start")
        run = _run(out, args, "--connect", endpoint, "--world", keys.world, "--time-scale", str(args.time_scale))
        states = States(endpoint, keys)
        _wait(lambda: states.state is not None, 120, "the mission to start")
        started = time.monotonic()
        _wait(lambda: time.monotonic() - started > args.record_s, args.record_s + 1, "the recording time")
        victim.kill()
        killed_ns = time.time_ns()
        victim.wait()
        report = _finish(run, out)
        done = subprocess.run([sys.executable, "-m", "deploy.cli", "recover", str(victim_file), "-o", str(fixed)],
                              cwd=REPO, capture_output=True, text=True, timeout=120)
        if done.returncode != 0:
            raise SystemExit(f"lunarsim recover failed: {done.stdout}{done.stderr}")
    finally:
        if states is not None:
            states.close()
        _stop(run, victim, router)
    reference = sum(1 for s in read_samples(out / "session.mcap") if s.log_time_ns <= killed_ns)
    recovered = list(read_samples(fixed))
    tail_s = (killed_ns - max(s.log_time_ns for s in recovered)) / 1e9 if recovered else None
    return {"recorded_s": args.record_s, "reference": reference, "recovered": len(recovered),
            "fraction": round(len(recovered) / reference, 4) if reference else None,
            "lost_tail_s": round(tail_s, 2) if tail_s is not None else None,
            "mission_complete": report["complete"]}


# ---- output ----


def show(r: dict) -> None:
    print(line(r["host"]))
    c = r["reconnect"]
    print(f"\nrouter killed and restarted on its port, {c['outage_s']:g} s down (mission: {c['reached']}/{c['total']} "
          f"reached, {'complete' if c['complete'] else 'NOT complete'})")
    print(f"{'restart':>8} {'first world state (s)':>22} {'every agent back (s)':>21}")
    for n, restart in enumerate(c["restarts"], 1):
        print(f"{n:>8} {restart['first_state_s']:>22.2f} {restart['all_agents_s']:>21.2f}")
    print("\nlockstep crater mission with the world losing a share of what it sends (--fault-loss)")
    print(f"{'loss':>6} {'reached':>8} {'stalled':>8} {'sim time (s)':>13} {'wall time (s)':>14}")
    for row in r["loss"]:
        print(f"{row['loss']:>6.0%} {row['reached']:>4}/{row['total']:<3} {row['stalled']:>8} {row['sim_s']:>13.1f} "
              f"{row['wall_s']:>14.1f}")
    v = r["recovery"]
    fraction = f"{v['fraction']:.1%}" if v["fraction"] is not None else "n/a"
    print(f"\nrecorder SIGKILLed after {v['recorded_s']:g} s: 'lunarsim recover' kept {v['recovered']} of the "
          f"{v['reference']} samples recorded until the kill ({fraction}); last recovered sample "
          f"{v['lost_tail_s']} s before the kill")


if __name__ == "__main__":
    sys.exit(main())
