"""A recording's rover paths on the map, as one PNG: the figure for a report or a quick look after a run.

Drawn from above with the scenario's axes (+x right, +z up the page): terrain hillshade, craters,
rocks and walls, the lander and goals, each rover's path from the world states, and the radio links of
the last state (the daisy chain in magenta). Pure apart from writing the PNG: no pyplot state, Agg only.
"""

from __future__ import annotations

from collections.abc import Iterable
from pathlib import Path

import numpy as np

from schemas.messages import WorldState
from schemas.scenario import Scenario
from sessions.format import Sample
from sessions.radio_links import drawn_links

SIZE_PX = (1200, 900)
DPI = 100


def rover_paths(samples: Iterable[Sample]) -> tuple[dict[int, np.ndarray], WorldState | None]:
    """Each rover's (x, z) path over the world states of a recording, and the last state (a state that does not
    decode is skipped: ``lunarsim report`` counts it)."""
    from schemas.codec import DecodeError
    from sessions.format import decode
    from sessions.foxglove import is_state_key

    paths: dict[int, list[tuple[float, float]]] = {}
    last: WorldState | None = None
    for sample in samples:
        if not is_state_key(sample.key):
            continue
        try:
            state = decode(sample)
        except DecodeError:
            continue
        if not isinstance(state, WorldState):
            continue
        last = state
        for r in state.rovers:
            paths.setdefault(r.id, []).append((r.x, r.z))
    return {i: np.array(p, float) for i, p in sorted(paths.items())}, last


def draw_trajectories(path_or_samples: str | Path | Iterable[Sample], scenario: Scenario, out_png: str | Path,
                      size_px: tuple[int, int] = SIZE_PX, terrain_cells: int = 200) -> Path:
    """Plot the rover paths of a recording (a file or its samples) over the scenario; returns the PNG path."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    from sessions.format import read_samples

    samples = read_samples(path_or_samples) if isinstance(path_or_samples, (str, Path)) else path_or_samples
    paths, last = rover_paths(samples)
    fig = Figure(figsize=(size_px[0] / DPI, size_px[1] / DPI), dpi=DPI)
    FigureCanvasAgg(fig)
    ax = fig.add_subplot()
    _terrain(ax, scenario, terrain_cells)
    _obstacles(ax, scenario)
    _paths(ax, paths)
    if last is not None:
        _links(ax, scenario, last)
    _landmarks(ax, scenario)
    ax.set_aspect("equal")
    ax.set_xlabel("x (m)")
    ax.set_ylabel("z (m)")
    ax.set_title(f"{scenario.name}: rover paths" + (f" (t = {last.stamp:.0f} s)" if last is not None else ""))
    ax.legend(loc="upper right", fontsize="small", framealpha=0.8)
    out = Path(out_png)
    out.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(out, dpi=DPI)
    return out


def _terrain(ax, scenario: Scenario, cells: int) -> None:
    """Hillshade of the terrain the world generated, so craters and undulation read at a glance."""
    from matplotlib.colors import LightSource

    from sessions.foxglove import sample_terrain

    try:
        grid = sample_terrain(scenario, cells=cells)
    except (OSError, ValueError, MemoryError):
        return  # a mesh that cannot be loaded here: the paths still matter more than the relief
    step = float(grid.xs[1] - grid.xs[0]) if len(grid.xs) > 1 else 1.0
    # hillshade takes row 0 as the top of the image; our rows grow with z (drawn bottom up), so flip twice.
    shade = LightSource(azdeg=315, altdeg=45).hillshade(grid.heights[::-1], dx=step, dy=step, vert_exag=3.0)[::-1]
    ax.imshow(shade, cmap="gray", origin="lower", vmin=0, vmax=1, alpha=0.9,
              extent=(grid.xs[0], grid.xs[-1], grid.zs[0], grid.zs[-1]))


def _obstacles(ax, scenario: Scenario) -> None:
    from matplotlib.patches import Circle

    from world_service.scene import scatter_rock_fields

    for i, c in enumerate(scenario.craters):
        ax.add_patch(Circle((c.x, c.z), c.radius_m, fill=False, ec="darkorange", lw=1.5,
                            label="crater rim" if i == 0 else None))
    rocks = list(scenario.obstacles.rocks) + scatter_rock_fields(scenario)
    for i, r in enumerate(rocks):
        ax.add_patch(Circle((r.x, r.z), r.radius_m, fc="saddlebrown", ec="none", label="rock" if i == 0 else None))
    for i, wall in enumerate(scenario.obstacles.walls):
        xs, zs = zip(*wall.points, strict=True)
        ax.plot(xs, zs, color="slategray", lw=3, solid_capstyle="butt", label="wall" if i == 0 else None)


def _paths(ax, paths: dict[int, np.ndarray]) -> None:
    for rover_id, path in paths.items():
        line, = ax.plot(path[:, 0], path[:, 1], lw=1.5, label=f"rover {rover_id}")
        ax.plot(path[0, 0], path[0, 1], "o", ms=4, color=line.get_color())
        ax.plot(path[-1, 0], path[-1, 1], "s", ms=6, color=line.get_color(), mec="black")


def _links(ax, scenario: Scenario, state: WorldState) -> None:
    """Radio links of the last state (``radio_links.drawn_links``); those touching a relay rover are the daisy
    chain. Each kind is one collection of segments, however many links."""
    from matplotlib.collections import LineCollection

    where = {0: (scenario.lander.x, scenario.lander.z)} | {r.id: (r.x, r.z) for r in state.rovers}
    chain, plain = drawn_links(state, where)
    for pairs, label, style in ((plain, "radio link", dict(colors="deepskyblue", linewidths=0.8, linestyles="--")),
                                (chain, "daisy chain", dict(colors="magenta", linewidths=2.5, linestyles="-"))):
        if pairs:
            ax.add_collection(LineCollection([[where[a], where[b]] for a, b in pairs], label=label, zorder=4,
                                             **style))


def _landmarks(ax, scenario: Scenario) -> None:
    lander = scenario.lander
    ax.plot(lander.x, lander.z, "^", ms=12, color="gold", mec="black", label="lander", zorder=5)
    gx = [g.x for g in scenario.mission]
    gz = [g.z for g in scenario.mission]
    ax.plot(gx, gz, "*", ms=14, color="limegreen", mec="black", label="mission goal", zorder=5)
