"""Memory and speed of a 50 km² tiled terrain with rovers driving across it (report 10.7.1, chunk activation).

Builds a ~7,071 m x 7,071 m terrain at 0.5 m (with seeded roughness and craters), then drives ``--rovers``
simulated rovers in ``--teams`` teams across it for ``--rounds`` rounds. Each round moves the teams on,
calls ``keep_near`` with the rovers' positions (the report's rover_chunk_activation_range, 1000 m by
default: tiles within it are loaded, the rest dropped) and samples height and pitch at every rover. It
prints peak resident memory (``ru_maxrss``), tiles loaded and generated, and the time per round
(``--tracemalloc`` adds the NumPy/Python heap peak, at a cost in speed), next to what one whole in-memory
grid would take (computed, never allocated: 2.4 GB as float32 heights + gradients, 4.8 GB as float64, as
the untiled generator held them).

    python benchmarks/terrain_memory.py [--rounds 600] [--radius-m 1000] [--json FILE]
    python benchmarks/terrain_memory.py --quick    # a 2.25 km² terrain, 10 rovers, 30 rounds of 25 m

Target (issue): the 50 km² terrain runs in under 2 GB.
"""

from __future__ import annotations

import argparse
import json
import platform
import resource
import sys
import time
import tracemalloc
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import quick

from schemas.scenario import Crater, TerrainSpec
from world_service.terrain.heightmap import Heightmap

TARGET_BYTES = 2 * 1024**3
MIB = 1024**2
QUICK = {"size_m": 1500.0, "craters": 40, "rovers": 10, "teams": 2, "radius_m": 200.0, "rounds": 30, "step_m": 25.0,
         "max_tiles": 20}
"""Small enough for seconds, with tiles evicted as in the full run."""


def parse_args(argv: list[str] | None = None) -> argparse.Namespace:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--size-m", type=float, default=7071.0, help="side of the square terrain (7071 m: 50 km²)")
    p.add_argument("--resolution-m", type=float, default=0.5)
    p.add_argument("--tile-size-m", type=float, default=256.0)
    p.add_argument("--max-tiles", type=int, default=400, help="LRU cap (TerrainSpec.max_tiles_in_memory)")
    p.add_argument("--roughness-m", type=float, default=0.3)
    p.add_argument("--craters", type=int, default=2000, help="seeded craters, radius 3..150 m")
    p.add_argument("--rovers", type=int, default=100)
    p.add_argument("--teams", type=int, default=4, help="rovers travel in teams around their own lander")
    p.add_argument("--spread-m", type=float, default=150.0, help="how far a rover strays from its team's centre")
    p.add_argument("--radius-m", type=float, default=1000.0, help="chunk activation range (report Table 6)")
    p.add_argument("--rounds", type=int, default=600)
    p.add_argument("--step-m", type=float, default=10.0, help="how far each team moves per round")
    p.add_argument("--seed", type=int, default=0)
    p.add_argument("--tracemalloc", action="store_true",
                   help="also trace the Python/NumPy heap peak (slows sampling rounds several times)")
    p.add_argument("--json", type=Path, default=None, help="also write the figures here")
    return quick.parse_args(p, QUICK, argv)


def scenario_terrain(args: argparse.Namespace) -> tuple[TerrainSpec, list[Crater], np.random.Generator]:
    """The 50 km² scenario's terrain spec, craters and seeded generator."""
    rng = np.random.default_rng(args.seed)
    spec = TerrainSpec(origin=(0.0, 0.0), size_m=(args.size_m, args.size_m), resolution_m=args.resolution_m,
                       roughness_m=args.roughness_m, tile_size_m=args.tile_size_m, max_tiles_in_memory=args.max_tiles)
    centres = rng.uniform(0.0, args.size_m, (args.craters, 2))
    radii = np.exp(rng.uniform(np.log(3.0), np.log(150.0), args.craters))  # many small, few large
    craters = [Crater(x=float(x), z=float(z), radius_m=float(r)) for (x, z), r in zip(centres, radii, strict=True)]
    return spec, craters, rng


@dataclass
class Teams:
    """Team centres bouncing across the terrain; each rover keeps a fixed offset from its team's centre."""

    centre: np.ndarray  # (teams, 2)
    velocity: np.ndarray  # (teams, 2), m per round
    offset: np.ndarray  # (rovers, 2)
    team_of: np.ndarray  # (rovers,)
    size: float

    @classmethod
    def start(cls, args: argparse.Namespace) -> Teams:
        rng = np.random.default_rng(args.seed + 1)
        margin = args.spread_m
        centre = rng.uniform(margin, args.size_m - margin, (args.teams, 2))
        angle = rng.uniform(0.0, 2 * np.pi, args.teams)
        velocity = args.step_m * np.column_stack([np.sin(angle), np.cos(angle)])
        offset = np.clip(rng.normal(0.0, args.spread_m / 2, (args.rovers, 2)), -args.spread_m, args.spread_m)
        return cls(centre, velocity, offset, np.arange(args.rovers) % args.teams, args.size_m)

    def advance(self) -> None:
        self.centre += self.velocity
        out = (self.centre < 0.0) | (self.centre > self.size)
        self.velocity[out] *= -1.0
        self.centre = np.clip(self.centre, 0.0, self.size)

    def positions(self) -> np.ndarray:
        return np.clip(self.centre[self.team_of] + self.offset, 0.0, self.size)

    def headings_deg(self) -> np.ndarray:
        v = self.velocity[self.team_of]
        return np.degrees(np.arctan2(v[:, 0], v[:, 1]))


@dataclass
class Timings:
    keep_near_s: list[float] = field(default_factory=list)
    generated: list[int] = field(default_factory=list)  # tiles generated by each round's keep_near
    sample_s: list[float] = field(default_factory=list)
    tiles_loaded: list[int] = field(default_factory=list)
    tile_bytes: list[int] = field(default_factory=list)


def drive(terrain: Heightmap, args: argparse.Namespace) -> Timings:
    """Move the teams, activate tiles near the rovers, sample height and pitch at every rover each round."""
    teams, out = Teams.start(args), Timings()
    checksum = 0.0
    for _ in range(args.rounds):
        teams.advance()
        points = teams.positions()
        before = terrain.tiles_generated
        t0 = time.perf_counter()
        terrain.keep_near(points, args.radius_m)
        t1 = time.perf_counter()
        out.generated.append(terrain.tiles_generated - before)
        heights = terrain.height(points[:, 0], points[:, 1])
        pitch = terrain.pitch_deg(points[:, 0], points[:, 1], teams.headings_deg())
        t2 = time.perf_counter()
        checksum += float(heights.sum() + pitch.sum())
        out.keep_near_s.append(t1 - t0)
        out.sample_s.append(t2 - t1)
        out.tiles_loaded.append(len(terrain.loaded_tiles))
        out.tile_bytes.append(terrain.tile_bytes)
    if not np.isfinite(checksum):
        raise RuntimeError("non-finite terrain samples")
    return out


def peak_rss_bytes() -> int:
    """Peak resident set size of this process (ru_maxrss is KiB on Linux, bytes on macOS)."""
    peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
    return peak if sys.platform == "darwin" else peak * 1024


def _ms(values: list[float]) -> dict[str, float]:
    a = np.asarray(values) * 1e3
    return {"mean": float(a.mean()), "p50": float(np.percentile(a, 50)), "p99": float(np.percentile(a, 99)),
            "max": float(a.max())}


def figures(terrain: Heightmap, timings: Timings, args: argparse.Namespace, baseline_rss: int,
            build_s: float, heap_peak: int | None) -> dict:
    tile_side = terrain.tile_cells * terrain.resolution
    settled = [t for t, g in zip(timings.keep_near_s, timings.generated, strict=True) if g == 0]
    return {
        "terrain": {"size_m": args.size_m, "area_km2": args.size_m**2 / 1e6, "resolution_m": args.resolution_m,
                    "nodes": terrain.nx * terrain.nz, "tile_size_m": tile_side,
                    "tiles_total": terrain.tiles_x * terrain.tiles_z, "craters": args.craters,
                    "build_s": build_s},
        "run": {"rovers": args.rovers, "teams": args.teams, "rounds": args.rounds, "radius_m": args.radius_m,
                "step_m": args.step_m, "max_tiles": args.max_tiles},
        "tiles": {"loaded_max": max(timings.tiles_loaded), "loaded_end": timings.tiles_loaded[-1],
                  "generated": terrain.tiles_generated, "evicted": terrain.tiles_evicted,
                  "rounds_generating": sum(g > 0 for g in timings.generated),
                  "generate_ms_per_tile": 1e3 * sum(timings.keep_near_s) / max(terrain.tiles_generated, 1),
                  "bytes_max": max(timings.tile_bytes)},
        "memory": {"peak_rss": peak_rss_bytes(), "baseline_rss": baseline_rss, "tracemalloc_peak": heap_peak,
                   "full_grid_float32": terrain.full_grid_bytes(np.float32),
                   "full_grid_float64": terrain.full_grid_bytes(np.float64), "target": TARGET_BYTES},
        "round_ms": {"keep_near": _ms(timings.keep_near_s), "keep_near_no_new_tile": _ms(settled or [0.0]),
                     "sample": _ms(timings.sample_s),
                     "total": _ms([a + b for a, b in zip(timings.keep_near_s, timings.sample_s, strict=True)])},
        "host": {"python": platform.python_version(), "numpy": np.__version__, "machine": platform.machine()},
    }


def report(f: dict) -> bool:
    """Print the figures; True when peak resident memory is under the target."""
    t, r, tiles, mem, ms = f["terrain"], f["run"], f["tiles"], f["memory"], f["round_ms"]
    print(f"terrain  {t['size_m']:.0f} m square = {t['area_km2']:.1f} km² at {t['resolution_m']} m: "
          f"{t['nodes'] / 1e6:.0f} M nodes, {t['tiles_total']} tiles of {t['tile_size_m']:.0f} m, "
          f"{t['craters']} craters; built in {t['build_s'] * 1e3:.2f} ms (lazy)")
    print(f"run      {r['rovers']} rovers in {r['teams']} teams, {r['rounds']} rounds of {r['step_m']} m, "
          f"keep_near radius {r['radius_m']:.0f} m, LRU cap {r['max_tiles']}")
    print(f"tiles    loaded max {tiles['loaded_max']} ({tiles['bytes_max'] / MIB:.0f} MiB), at end "
          f"{tiles['loaded_end']}; generated {tiles['generated']} (in {tiles['rounds_generating']} rounds, "
          f"~{tiles['generate_ms_per_tile']:.0f} ms each), evicted {tiles['evicted']}")
    for name, v in ms.items():
        print(f"round    {name:<21} mean {v['mean']:.3f} ms  p50 {v['p50']:.3f}  p99 {v['p99']:.3f}  "
              f"max {v['max']:.3f}")
    heap = "not traced" if mem["tracemalloc_peak"] is None else f"{mem['tracemalloc_peak'] / MIB:.0f} MiB"
    print(f"memory   peak RSS {mem['peak_rss'] / MIB:.0f} MiB (baseline after imports "
          f"{mem['baseline_rss'] / MIB:.0f} MiB), tracemalloc peak {heap}")
    print(f"whole    grid in memory would be {mem['full_grid_float32'] / MIB:.0f} MiB as float32 heights + "
          f"gradients, {mem['full_grid_float64'] / MIB:.0f} MiB as float64 (computed, not allocated)")
    ok = mem["peak_rss"] < mem["target"]
    print(f"target   peak RSS under {mem['target'] / MIB:.0f} MiB: {'PASS' if ok else 'FAIL'}")
    return ok


def main(argv: list[str] | None = None) -> int:
    args = parse_args(argv)
    baseline_rss = peak_rss_bytes()
    if args.tracemalloc:
        tracemalloc.start()
    spec, craters, rng = scenario_terrain(args)
    t0 = time.perf_counter()
    terrain = Heightmap.build(spec, craters, rng)  # lazy: no tile is generated here
    build_s = time.perf_counter() - t0
    timings = drive(terrain, args)
    heap_peak = tracemalloc.get_traced_memory()[1] if args.tracemalloc else None
    f = figures(terrain, timings, args, baseline_rss, build_s, heap_peak)
    ok = report(f)
    if args.json is not None:
        args.json.write_text(json.dumps(f, indent=2) + "\n")
    return 0 if ok else 1


if __name__ == "__main__":
    raise SystemExit(main())
