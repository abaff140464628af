"""World service cost per simulated second for 10, 100 and 1,000 rovers at the report's sensor rates.

Each rover is driven as an agent would drive it: whenever it is idle it is sent a MoveAction 5 m ahead
(a RotateAction when that is refused), through ``World.receive`` so decoding and validation are paid.
Every message the world produces is encoded as the service would publish it; the network is left out
(see benchmarks/control_loop_latency.py for that). Prints, per rover count: wall seconds per simulated
second, the real-time factor one core could sustain, messages per simulated second, and peak memory.

    python benchmarks/world_scale.py [--rovers 10 100 1000] [--sim-seconds 10] [--json FILE]
    python benchmarks/world_scale.py --quick    # 10 and 100 rovers for 1 simulated second
"""

from __future__ import annotations

import argparse
import json
import resource
import time
from pathlib import Path

import host
import quick

from schemas import codec
from schemas import keyspace as ks
from schemas import messages as m
from schemas.scenario import load_scenario
from world_service.sim import World

SCENARIO = Path(__file__).resolve().parents[1] / "scenarios" / "crater_observation.yaml"
MOVE = codec.encode(m.MoveAction(x=0.0, z=5.0))
TURN = codec.encode(m.RotateAction(degrees=90.0))
QUICK = {"rovers": [10, 100], "sim_seconds": 1.0}


def drive(world: World, out: list[tuple[str, m.Message]], keys: ks.Keyspace) -> None:
    """Answer the world like a trivial agent: move when a move ends, turn when a move is refused."""
    for key, message in out:
        if isinstance(message, m.NavigationStatus) and message.outcome != "running":
            rid, _ = keys.parse_rover_key(key)
            world.receive(keys.rover(rid, ks.MOVE_ACTION), MOVE)
        elif isinstance(message, m.ActionRejected) and message.reason != "action_in_progress":
            rid, _ = keys.parse_rover_key(key)
            world.receive(keys.rover(rid, ks.ROTATE_ACTION), TURN)


def measure(rovers: int, sim_seconds: float) -> dict:
    keys = ks.Keyspace("bench")
    scenario = load_scenario(SCENARIO).with_overrides(rovers=rovers)
    world = World(scenario, keys)
    for rid in world.rover_ids:
        world.receive(keys.rover(rid, ks.MOVE_ACTION), MOVE)
    ticks = round(sim_seconds / world.clock.dt)
    messages = 0
    start = time.perf_counter()
    for _ in range(ticks):
        out = world.step()
        for _key, message in out:
            codec.encode(message)
        messages += len(out)
        drive(world, out, keys)
    wall = time.perf_counter() - start
    simulated = ticks * world.clock.dt
    return {
        "rovers": rovers,
        "sim_seconds": round(simulated, 3),
        "wall_seconds": round(wall, 3),
        "wall_per_sim_second": round(wall / simulated, 4),
        "real_time_factor": round(simulated / wall, 2),
        "messages_per_sim_second": round(messages / simulated),
        "distance_covered_m": round(sum(b.distance_covered for b in world.actuator.bodies.values()), 1),
        "peak_rss_mb": round(resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024, 1),
    }


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--rovers", type=int, nargs="+", default=[10, 100, 1000])
    parser.add_argument("--sim-seconds", type=float, default=10.0)
    parser.add_argument("--json", type=Path, metavar="FILE")
    args = quick.parse_args(parser, QUICK)
    machine = host.describe()
    rows = [measure(n, args.sim_seconds) for n in args.rovers]
    print(host.line(machine))
    print(f"{'rovers':>7} {'wall s / sim s':>15} {'real-time factor':>17} {'msgs / sim s':>13} {'peak RSS MB':>12}")
    for r in rows:
        print(f"{r['rovers']:>7} {r['wall_per_sim_second']:>15.4f} {r['real_time_factor']:>17.2f} "
              f"{r['messages_per_sim_second']:>13} {r['peak_rss_mb']:>12.1f}")
    target = next((r for r in rows if r["rovers"] == 1000), None)
    if target:
        verdict = "PASS" if target["real_time_factor"] >= 1.0 else "FAIL"
        print(f"target: 1,000 rovers at a real-time factor of at least 1 on one core: "
              f"{target['real_time_factor']:.2f}  {verdict}")
    if args.json:
        args.json.write_text(json.dumps({"host": machine, "rows": rows}, indent=2) + "\n")


if __name__ == "__main__":
    main()
