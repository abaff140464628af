"""The bounds a scenario must keep, so a typo in a YAML file is refused at load time with a message, rather than
found later as a process killed for memory, a world that never ticks, or a run folder written outside ``runs/``.

The bounds are generous, not physical: each one only rules out values no mission on this simulator could use.
Kept free of the scenario models and of pydantic so ``schemas.params`` and the wire limits can use them too; the
pydantic types built on them are in ``schemas.scenario_types``.
"""

from __future__ import annotations

import math
import re
import stat

MAX_ROVERS = 1000
"""Rovers in one scenario (``rovers``, ``--rovers``, ``spawn.rover_count``): each is an OS process's worth of
agent, and the world's per-tick work grows with their pairs."""

MAX_SCENARIO_BYTES = 1024**2
"""Largest scenario or rover parameter file read, checked before a byte is parsed: parsed YAML costs about 100
times its size in memory and seconds per MB (a file at this bound, about 25,000 rocks, takes seconds and about
120 MB on a 2-core machine: ``benchmarks/scenario_load.py``). A shipped or generated scenario is a few kB; many
rocks are drawn by ``rock_fields`` rather than listed."""

MAX_YAML_NODES = MAX_SCENARIO_BYTES // 2
"""Values in a scenario file once its YAML aliases are expanded. A value takes at least two bytes (one character
and a separator), so only aliases reach this: ten nested lists of ten aliases each make 10**10 values out of a
few hundred bytes, which validation would walk one by one."""

MAX_CRATERS = 10_000
"""``craters``: each is carved into every terrain tile it touches and searched for every crater goal."""
MAX_ROCKS = 100_000
"""Rocks in a scenario, listed (``obstacles.rocks``) and scattered by rock fields together: the world makes an
object of each and keeps arrays of them all (``world_service.scene``), and the web view draws them all."""
MAX_ROCK_FIELDS = 1_000
"""``obstacles.rock_fields``."""
MAX_WALLS = 10_000
"""``obstacles.walls``: every radio link and move is tested against the walls it crosses."""
MAX_WALL_POINTS = 100_000
"""Corners of one wall."""
MAX_GOALS = 1_000
"""``mission``: goals a team visits in turn; the lander sends each one over the radio."""

MAX_MESH_BYTES = 256 * 1024**2
"""Largest terrain mesh file: about 5 million triangles as binary STL, whose rasterising arrays (about 120 bytes
a triangle, 600 MB) fit within ``MEMORY_LIMIT_BYTES``. A device (``/dev/zero``) or a wrong file named by mistake
is refused instead of read without end."""
MESH_SUFFIXES = (".obj", ".stl", ".ply", ".glb")
"""The mesh formats ``world_service.terrain.mesh`` loads (with trimesh): self-contained files, so a mesh is
read as one file and names no other."""

MAX_BEHAVIOUR_CHARS = 200
"""A behaviour's name or ``package.module:Class``."""

MAX_ECHO_CHARS = 200
"""Characters of a user's value repeated in an error line (``clip``): a 10 MB name is named by its start, not
printed whole."""

MAX_RATE_HZ = 100.0
"""Fastest sensor or status rate: the world's tick is 20 ms at its finest, so a faster rate only repeats samples
while flooding the router."""

SEED_LIMIT = 2**63
"""Seeds are 0 <= seed < 2**63: they travel as int64 (MCAP metadata, NumPy generators)."""

COORDINATE_LIMIT_M = 10_000_000.0
"""|x|, |z| of anything placed, m. Beyond this, float64 positions lose the millimetres a rover's step needs, and
no map of a lunar site is that wide (the Moon's circumference is 10,921 km)."""

MAX_TERRAIN_SIDE_M = 1_000_000.0
MIN_RESOLUTION_M = 0.01
MAX_CRATER_RADIUS_M = 100_000.0
"""A crater of 200 km across; larger basins are the landscape, not a crater on it (a terrain mesh)."""
MAX_ROCK_RADIUS_M = 100.0

MEMORY_LIMIT_BYTES = 2 * 1024**3
"""What the world's terrain (and the lander's traverse map) may hold: the target the tiled terrain was built to
(``benchmarks/terrain_memory.py``), and more than a small machine running the whole mission can spare."""

HELD_BYTES_PER_NODE = 12
"""A loaded terrain node: float32 height and two float32 gradients (``world_service.terrain.heightmap.Tile``)."""
BUILD_BYTES_PER_NODE = 24
"""While one tile is generated: float64 heights and both float64 gradients of that tile."""
MAP_MARGIN_M = 30.0
"""How far the lander's traverse map reaches beyond the mission area (``lander_agent.mapping``), m."""
MAP_BYTES_PER_CELL = 8
"""A traverse-map cell: the lander's five seen-as flags and its class, the world's truth masks when scoring."""

_SAFE_NAME = re.compile(r"[A-Za-z0-9][A-Za-z0-9_.-]{0,80}")


def clip(text: str, limit: int = MAX_ECHO_CHARS) -> str:
    """``text`` cut to ``limit`` characters and '...' when longer: how every error line about a scenario or a
    user's file repeats a value it was given."""
    return text if len(text) <= limit else text[:limit] + "..."


_FILE_KINDS = ((stat.S_ISREG, "a file"), (stat.S_ISDIR, "a folder"), (stat.S_ISFIFO, "a FIFO"),
               (stat.S_ISCHR, "a character device"), (stat.S_ISBLK, "a block device"), (stat.S_ISSOCK, "a socket"))


def file_kind(mode: int) -> str:
    """What a path with this ``st_mode`` is, for the line that refuses it (a FIFO, a character device...)."""
    return next((name for test, name in _FILE_KINDS if test(mode)), "not a file")


def safe_name(name: str) -> str:
    """The name becomes a run folder (``runs/<name>-<time>``) and a file stem, so it may hold no path."""
    if not _SAFE_NAME.fullmatch(name) or ".." in name:
        raise ValueError(f"{clip(repr(name))} is not a safe name: use letters, digits, '_', '-' or '.' (no '..', "
                         "no folders), starting with a letter or digit, at most 81 characters")
    return name


_PLUGIN_NAME = re.compile(r"[A-Za-z0-9_][A-Za-z0-9_.-]*")


def behaviour_spec(spec: str) -> str:
    """A behaviour as the rover agent finds it (``rover_agent.registry``): a built-in or plugin name, or
    ``package.module:Class``; checked here for its form only, since importing it is for the processes."""
    module, colon, attr = spec.partition(":")
    if colon:
        ok = attr.isidentifier() and all(part.isidentifier() for part in module.split("."))
    else:
        ok = _PLUGIN_NAME.fullmatch(spec) is not None
    if not ok or len(spec) > MAX_BEHAVIOUR_CHARS:
        raise ValueError(f"{clip(repr(spec))} is not a behaviour: give a name (default, straight, an installed "
                         "plugin) or 'package.module:Class'")
    return spec


def mesh_suffix(path: str) -> str:
    """A terrain mesh's format, from its name: one ``world_service.terrain.mesh`` loads."""
    suffix = path[path.rfind("."):].lower() if "." in path.rsplit("/", 1)[-1] else ""
    if suffix not in MESH_SUFFIXES:
        raise ValueError(f"{clip(repr(path))} is not a mesh file: its name must end in "
                         f"{', '.join(MESH_SUFFIXES)}")
    return suffix


def nodes_along(side_m: float, resolution_m: float) -> int:
    """Grid nodes along one side, as ``world_service.terrain.heightmap.Heightmap`` lays them out."""
    return math.ceil(side_m / resolution_m) + 1


def terrain_memory(size_m: tuple[float, float], resolution_m: float, tile_size_m: float,
                   max_tiles: int) -> tuple[int, int]:
    """(nodes in the whole grid, bytes the world can hold for it).

    The terrain is tiled and only ``max_tiles`` tiles are ever loaded, so a 50 km² terrain costs what its loaded
    tiles do, not its whole grid; one tile is built at a time, in float64."""
    nx, nz = nodes_along(size_m[0], resolution_m), nodes_along(size_m[1], resolution_m)
    tile_cells = max(1, round(tile_size_m / resolution_m))
    tile_nodes = min(tile_cells + 1, nx) * min(tile_cells + 1, nz)
    tiles = math.ceil((nx - 1) / tile_cells) * math.ceil((nz - 1) / tile_cells)
    held = min(nx * nz, min(max_tiles, tiles) * tile_nodes)
    return nx * nz, held * HELD_BYTES_PER_NODE + tile_nodes * BUILD_BYTES_PER_NODE


def check_terrain_memory(size_m: tuple[float, float], resolution_m: float, tile_size_m: float,
                         max_tiles: int) -> None:
    nodes, held = terrain_memory(size_m, resolution_m, tile_size_m, max_tiles)
    if held > MEMORY_LIMIT_BYTES:
        raise ValueError(
            f"a terrain of {size_m[0]:g} m x {size_m[1]:g} m at {resolution_m:g} m has {nodes:,} cells, and "
            f"{max_tiles} loaded tiles of {tile_size_m:g} m would hold {_gib(held)} (limit {_gib(MEMORY_LIMIT_BYTES)}):"
            " use a coarser resolution_m, smaller tile_size_m or fewer max_tiles_in_memory")


def check_map_memory(extent_m: tuple[float, float], cell_m: float) -> None:
    """The lander's traverse map covers the whole mission area at ``mapping.cell_m`` in one untiled grid."""
    cells = math.ceil(extent_m[0] / cell_m) * math.ceil(extent_m[1] / cell_m)
    if cells * MAP_BYTES_PER_CELL > MEMORY_LIMIT_BYTES:
        raise ValueError(
            f"the traverse map of the {extent_m[0]:,.0f} m x {extent_m[1]:,.0f} m mission area at cell_m {cell_m:g} m "
            f"has {cells:,} cells, {_gib(cells * MAP_BYTES_PER_CELL)} (limit {_gib(MEMORY_LIMIT_BYTES)}): use a "
            "larger cell_m")


def _gib(n: int) -> str:
    return f"{n / 1024**3:,.1f} GiB"
