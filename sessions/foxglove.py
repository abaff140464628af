"""LunarSim messages as Foxglove 3D-scene messages: pure conversion, no Zenoh, no files.

Used by ``lunarsim export-foxglove`` (a recording) and ``lunarsim view --foxglove`` (a live world), so
the two show the same scene. The lander's traverse map (``lander/map``) becomes a ``Grid`` on ``/map``.

Axes: LunarSim's ground plane is x/z with the height along y, heading 0 = +z and 90 = +x; Foxglove is
z-up. A LunarSim point (x, z, height) becomes the Foxglove point (x, y, z) = (x, z, height). The map
therefore looks as it does from above in our own plots (+x right, +z up the screen), and a heading h
becomes a yaw of 90° - h about Foxglove's +z (yaw 0 = +x, counter-clockwise). Everything is drawn in
one fixed frame ``world``; ``rover_<id>`` frames follow the rovers (``FrameTransform`` world -> rover,
rover +x = straight ahead) so photos and any panel can attach to a rover.
"""

from __future__ import annotations

import math
from collections import deque
from collections.abc import Callable
from dataclasses import dataclass

import foxglove.messages as fm
import numpy as np

from schemas import keyspace as ks
from schemas.messages import LanderMap, Photo, WorldState
from schemas.scenario import Scenario
from schemas.wire_limits import MAX_ID
from sessions.radio_links import drawn_links

FRAME = "world"
SCENE_TOPIC = "/scene"
TF_TOPIC = "/tf"
MAP_TOPIC = "/map"
MAP_ALPHA = 160
"""Opacity (of 255) of a known map cell, so the terrain shows through; unknown cells are clear."""
MAP_LIFT_M = 0.3
"""The flat map grid floats this far above the highest terrain node, so the relief never hides it."""
TERRAIN_CELLS = 128
"""Terrain nodes along the longer side of the exported mesh: enough to see craters, small to load fast."""
ROVER_SIZE = (1.4, 1.0, 0.6)
"""Box of a rover: length (ahead), width, height in metres; the report's rovers are about this big."""

Height = Callable[[np.ndarray, np.ndarray], np.ndarray]
"""Terrain height at arrays of (x, z), vectorised."""

STATE_COLORS: dict[str, tuple[float, float, float]] = {
    "waiting": (0.6, 0.6, 0.6), "migration": (0.2, 0.6, 1.0), "avoiding": (1.0, 0.8, 0.1),
    "climbing": (0.9, 0.5, 0.1), "observing": (0.3, 0.9, 0.3), "done": (0.1, 0.7, 0.2),
    "stuck": (1.0, 0.1, 0.1), "stopped": (0.5, 0.3, 0.3), "relay": (0.9, 0.3, 0.9),
}


def rover_frame(rover_id: int) -> str:
    return f"rover_{rover_id}"


def photo_topic(rover_id: int) -> str:
    return f"/rover_{rover_id}/photo"


def timestamp(ns: int) -> fm.Timestamp:
    """Foxglove time from a sample's log time (Unix ns): the time the viewer scrubs by."""
    return fm.Timestamp(sec=ns // 1_000_000_000, nsec=ns % 1_000_000_000)


def _color(rgb: tuple[float, float, float], a: float = 1.0) -> fm.Color:
    return fm.Color(r=rgb[0], g=rgb[1], b=rgb[2], a=a)


def _point(x: float, z: float, h: float = 0.0) -> fm.Point3:
    """Our (x, z, height) as a Foxglove z-up point."""
    return fm.Point3(x=float(x), y=float(z), z=float(h))


def _yaw_quaternion(yaw_rad: float) -> fm.Quaternion:
    return fm.Quaternion(x=0.0, y=0.0, z=math.sin(yaw_rad / 2), w=math.cos(yaw_rad / 2))


def heading_quaternion(heading_deg: float) -> fm.Quaternion:
    """Rotation that points Foxglove +x along a LunarSim heading (0 = +z, 90 = +x)."""
    return _yaw_quaternion(math.radians(90.0 - heading_deg))


def _pose(x: float, z: float, h: float, yaw_rad: float = 0.0) -> fm.Pose:
    return fm.Pose(position=fm.Vector3(x=float(x), y=float(z), z=float(h)), orientation=_yaw_quaternion(yaw_rad))


def _entity(entity_id: int | str, ns: int, **primitives: object) -> fm.SceneEntity:
    return fm.SceneEntity(timestamp=timestamp(ns), frame_id=FRAME, id=str(entity_id), **primitives)


# ---- terrain ----


@dataclass(frozen=True)
class TerrainGrid:
    """The terrain sampled on a coarse regular grid: heights[j, i] at (xs[i], zs[j])."""

    xs: np.ndarray
    zs: np.ndarray
    heights: np.ndarray

    def height_at(self, x: np.ndarray | float, z: np.ndarray | float) -> np.ndarray:
        """Nearest-node height, enough to set objects on the displayed surface."""
        i = np.clip(np.searchsorted(self.xs, x), 0, len(self.xs) - 1)
        j = np.clip(np.searchsorted(self.zs, z), 0, len(self.zs) - 1)
        return self.heights[j, i]


def build_heightmap(scenario: Scenario):
    """The world service's terrain for a scenario: same seed stream, so the same undulation and craters."""
    from world_service.terrain.heightmap import Heightmap

    return Heightmap.from_scenario(scenario, np.random.default_rng(scenario.seed))


def sample_terrain(scenario: Scenario, height: Height | None = None, cells: int = TERRAIN_CELLS) -> TerrainGrid:
    """A ``cells``-node grid over the scenario's terrain; ``height`` defaults to the world's own heightmap.

    Sampled point by point (uncached) rather than assembling the full grid, so a terrain of many km at
    1 m resolution costs only the samples drawn.
    """
    spec = scenario.terrain_spec()
    if height is None:
        terrain = build_heightmap(scenario)

        def height(x: np.ndarray, z: np.ndarray) -> np.ndarray:
            return terrain.height(x, z, cache=False)

    (ox, oz), (sx, sz) = spec.origin, spec.size_m
    step = max(sx, sz) / max(cells, 1)
    xs = np.linspace(ox, ox + sx, max(2, round(sx / step) + 1))
    zs = np.linspace(oz, oz + sz, max(2, round(sz / step) + 1))
    gx, gz = np.meshgrid(xs, zs)
    heights = np.asarray(height(gx.ravel(), gz.ravel()), float).reshape(gx.shape)
    return TerrainGrid(xs, zs, heights)


def terrain_triangles(grid: TerrainGrid) -> fm.TriangleListPrimitive:
    """The grid as an indexed triangle mesh, shaded grey by height so relief reads without lighting."""
    nz, nx = grid.heights.shape
    gx, gz = np.meshgrid(grid.xs, grid.zs)
    lo, hi = float(grid.heights.min()), float(grid.heights.max())
    shade = 0.35 + 0.45 * (grid.heights - lo) / (hi - lo) if hi > lo else np.full(grid.heights.shape, 0.55)
    points = [fm.Point3(x=float(x), y=float(z), z=float(h))
              for x, z, h in zip(gx.ravel(), gz.ravel(), grid.heights.ravel(), strict=True)]
    colors = [fm.Color(r=float(s), g=float(s), b=float(s), a=1.0) for s in shade.ravel()]
    node = np.arange(nx * nz).reshape(nz, nx)
    a, b, c, d = node[:-1, :-1], node[:-1, 1:], node[1:, :-1], node[1:, 1:]
    indices = np.stack([a, b, d, a, d, c], axis=-1).ravel()
    return fm.TriangleListPrimitive(pose=_pose(0, 0, 0), points=points, colors=colors,
                                    indices=[int(i) for i in indices])


# ---- static scene ----


def _ring(x: float, z: float, radius: float, height: float, segments: int = 48) -> list[fm.Point3]:
    return [_point(x + radius * math.sin(a), z + radius * math.cos(a), height)
            for a in np.linspace(0, 2 * math.pi, segments, endpoint=False)]


def _line(points: list[fm.Point3], rgb: tuple[float, float, float], thickness: float,
          kind: fm.LinePrimitiveLineType = fm.LinePrimitiveLineType.LineStrip) -> fm.LinePrimitive:
    return fm.LinePrimitive(type=kind, pose=_pose(0, 0, 0), thickness=thickness, scale_invariant=True,
                            points=points, color=_color(rgb))


def _text(x: float, z: float, h: float, text: str) -> fm.TextPrimitive:
    return fm.TextPrimitive(pose=_pose(x, z, h), billboard=True, font_size=14.0, scale_invariant=True,
                            color=_color((1.0, 1.0, 1.0)), text=text)


def _cylinder(x: float, z: float, h: float, radius: float, tall: float,
              rgb: tuple[float, float, float], alpha: float = 1.0) -> fm.CylinderPrimitive:
    return fm.CylinderPrimitive(pose=_pose(x, z, h + tall / 2), size=fm.Vector3(x=2 * radius, y=2 * radius, z=tall),
                                bottom_scale=1.0, top_scale=1.0, color=_color(rgb, alpha))


def _craters(scenario: Scenario, grid: TerrainGrid, ns: int) -> fm.SceneEntity:
    lines, texts = [], []
    for i, c in enumerate(scenario.craters):
        crest = float(grid.height_at(c.x, c.z + c.radius_m)) + 0.1
        lines.append(_line(_ring(c.x, c.z, c.radius_m, crest), (0.9, 0.6, 0.2), 2.0,
                           fm.LinePrimitiveLineType.LineLoop))
        texts.append(_text(c.x, c.z, crest + 2.0, f"crater {i + 1}"))
    return _entity("craters", ns, lines=lines, texts=texts)


def _rocks(scenario: Scenario, grid: TerrainGrid, ns: int) -> fm.SceneEntity:
    from world_service.scene import scatter_rock_fields

    rocks = list(scenario.obstacles.rocks) + scatter_rock_fields(scenario)
    if not rocks:
        return _entity("rocks", ns)
    base = grid.height_at(np.array([r.x for r in rocks]), np.array([r.z for r in rocks]))
    return _entity("rocks", ns, cylinders=[_cylinder(r.x, r.z, float(h), r.radius_m, r.radius_m, (0.55, 0.5, 0.45))
                                           for r, h in zip(rocks, base, strict=True)])


def _walls(scenario: Scenario, grid: TerrainGrid, ns: int) -> fm.SceneEntity:
    cubes = []
    for wall in scenario.obstacles.walls:
        for (x0, z0), (x1, z1) in zip(wall.points, wall.points[1:], strict=False):
            mx, mz = (x0 + x1) / 2, (z0 + z1) / 2
            base = float(grid.height_at(mx, mz))
            cubes.append(fm.CubePrimitive(
                pose=_pose(mx, mz, base + wall.height_m / 2, math.atan2(z1 - z0, x1 - x0)),
                size=fm.Vector3(x=math.hypot(x1 - x0, z1 - z0) + wall.thickness_m, y=wall.thickness_m,
                                z=wall.height_m),
                color=_color((0.7, 0.7, 0.75))))
    return _entity("walls", ns, cubes=cubes)


def _lander(scenario: Scenario, grid: TerrainGrid, ns: int) -> fm.SceneEntity:
    lander = scenario.lander
    base = float(grid.height_at(lander.x, lander.z))
    body = _cylinder(lander.x, lander.z, base, lander.radius_m, 2.5, (0.95, 0.85, 0.3))
    return _entity("lander", ns, cylinders=[body], texts=[_text(lander.x, lander.z, base + 4.0, "lander")])


def _goals(scenario: Scenario, grid: TerrainGrid, ns: int) -> fm.SceneEntity:
    cylinders, texts = [], []
    for i, goal in enumerate(scenario.mission):
        base = float(grid.height_at(goal.x, goal.z))
        cylinders.append(_cylinder(goal.x, goal.z, base, 0.6, 6.0, (0.2, 1.0, 0.4), 0.8))
        texts.append(_text(goal.x, goal.z, base + 7.0, f"goal {i + 1} ({goal.kind})"))
    return _entity("goals", ns, cylinders=cylinders, texts=texts)


def static_scene(scenario: Scenario, grid: TerrainGrid, ns: int) -> fm.SceneUpdate:
    """Everything that does not move: terrain, craters, rocks, walls, lander, mission goals.

    Entity ids differ from the dynamic ones, so rover updates on the same topic never replace them.
    """
    terrain = _entity("terrain", ns, triangles=[terrain_triangles(grid)])
    parts = [terrain] + [make(scenario, grid, ns) for make in (_craters, _rocks, _walls, _lander, _goals)]
    return fm.SceneUpdate(entities=parts)


# ---- dynamic scene ----


class DynamicScene:
    """World states to rover boxes, trails, radio links and the daisy chain; remembers trails between calls."""

    def __init__(self, scenario: Scenario, grid: TerrainGrid | None = None, trail_points: int = 300) -> None:
        self.lander = (scenario.lander.x, scenario.lander.z)
        self.grid = grid
        self.trail_points = trail_points
        self.trails: dict[int, deque[tuple[float, float, float]]] = {}

    def ground(self, x: float, z: float) -> float:
        return float(self.grid.height_at(x, z)) if self.grid is not None else 0.0

    def update(self, state: WorldState, ns: int) -> fm.SceneUpdate:
        where = {0: (*self.lander, self.ground(*self.lander) + 2.0)}
        for r in state.rovers:
            where[r.id] = (r.x, r.z, self.ground(r.x, r.z) + ROVER_SIZE[2])
            if self.trail_points:
                self.trails.setdefault(r.id, deque(maxlen=self.trail_points)).append(where[r.id])
        entities = [self._rovers(state, where, ns), self._links(state, where, ns)]
        if self.trail_points:
            entities.append(self._trails(ns))
        return fm.SceneUpdate(entities=entities)

    def _rovers(self, state: WorldState, where: dict[int, tuple[float, float, float]], ns: int) -> fm.SceneEntity:
        cubes, texts = [], []
        for r in state.rovers:
            x, z, h = where[r.id]
            rgb = STATE_COLORS.get(r.state, (1.0, 1.0, 1.0)) if r.alive else (0.2, 0.2, 0.2)
            cubes.append(fm.CubePrimitive(pose=fm.Pose(position=fm.Vector3(x=x, y=z, z=h - ROVER_SIZE[2] / 2),
                                                       orientation=heading_quaternion(r.heading_deg)),
                                          size=fm.Vector3(x=ROVER_SIZE[0], y=ROVER_SIZE[1], z=ROVER_SIZE[2]),
                                          color=_color(rgb)))
            texts.append(_text(x, z, h + 1.5, f"{r.id} {r.state}"))
        return _entity("rovers", ns, cubes=cubes, texts=texts,
                       metadata=[fm.KeyValuePair(key="stamp", value=f"{state.stamp:.3f}")])

    def _links(self, state: WorldState, where: dict[int, tuple[float, float, float]], ns: int) -> fm.SceneEntity:
        """Radio links thin and blue; links touching a relay (the daisy chain) thick and magenta
        (``radio_links.drawn_links``)."""
        chain, plain = drawn_links(state, where)
        kind = fm.LinePrimitiveLineType.LineList
        lines = [_line([_point(*where[i]) for pair in pairs for i in pair], rgb, width, kind)
                 for pairs, rgb, width in ((plain, (0.3, 0.6, 1.0), 1.5), (chain, (1.0, 0.3, 1.0), 4.0)) if pairs]
        return _entity("links", ns, lines=lines)

    def _trails(self, ns: int) -> fm.SceneEntity:
        return _entity("trails", ns, lines=[_line([_point(*p) for p in trail], (0.4, 0.8, 1.0), 1.0)
                                            for trail in self.trails.values() if len(trail) > 1])


def transforms(state: WorldState, ns: int, ground: Callable[[float, float], float] | None = None,
               ) -> list[fm.FrameTransform]:
    """world -> rover_<id> for each rover: rover +x ahead, +y left, +z up."""
    out = []
    for r in state.rovers:
        h = ground(r.x, r.z) if ground is not None else 0.0
        out.append(fm.FrameTransform(timestamp=timestamp(ns), parent_frame_id=FRAME, child_frame_id=rover_frame(r.id),
                                     translation=fm.Vector3(x=r.x, y=r.z, z=h),
                                     rotation=heading_quaternion(r.heading_deg)))
    return out


def photo_image(photo: Photo, rover_id: int, ns: int) -> fm.CompressedImage:
    """A rover's photo as the PNG it is, in the rover's frame."""
    return fm.CompressedImage(timestamp=timestamp(ns), frame_id=rover_frame(rover_id), data=photo.png, format="png")


def rover_of_key(key: str) -> int | None:
    """Rover id of ``lunar/<w>/rover/<id>/...``, None for other keys and for ids no rover has (the id names a
    Foxglove topic and frame: it must be a plain number in range)."""
    parts = key.split("/")
    if len(parts) != 5 or parts[2] != "rover":
        return None
    text = parts[3]
    if not (text.isascii() and text.isdigit() and len(text) <= len(str(MAX_ID))):
        return None
    return int(text) if int(text) <= MAX_ID else None


def is_state_key(key: str) -> bool:
    parts = key.split("/")
    return len(parts) == 4 and parts[2] == "world" and parts[3] == "state"


def is_photo_key(key: str) -> bool:
    return rover_of_key(key) is not None and key.endswith("/photo")


def is_map_key(key: str) -> bool:
    """``lunar/<w>/lander/map`` of any world."""
    parts = key.split("/")
    try:
        return len(parts) > 2 and key == ks.Keyspace(parts[1]).lander(ks.MAP)
    except ValueError:
        return False


def map_elevation(grid: TerrainGrid | None) -> float:
    return float(np.max(grid.heights)) + MAP_LIFT_M if grid is not None else 0.0


def map_grid(msg: LanderMap, ns: int, elevation: float = 0.0) -> fm.Grid:
    """The lander's map as a Foxglove Grid: per cell its class code (``class``, uint8) and its colour.

    The colours are the map PNG's (``lander_agent.mapping.COLOURS``, looked up by class name) with ``MAP_ALPHA``,
    unknown cells fully clear; Foxglove's 3D panel shows them in its "RGBA (separate fields)" colour mode.
    Row j, column i of the map is Foxglove's (x, y) = (origin_x + i * cell_m, origin_z + j * cell_m).
    A map past ``map_view.VIEW_CELLS`` cells is coarsened to fit. A payload that does not fit its shape, or a
    class code without a name, is a ValueError.
    """
    from lander_agent.map_view import for_viewers
    from lander_agent.mapping import CLASSES, COLOURS, from_message

    msg = for_viewers(msg)
    spec, codes = from_message(msg)
    if codes.size and int(codes.max()) >= len(msg.classes):
        raise ValueError(f"lander map: class code {int(codes.max())} but only {len(msg.classes)} classes named")
    table = np.zeros((256, 5), np.uint8)  # each code's five bytes: itself, then its colour (one lookup, one array)
    table[:, 0] = np.arange(256)
    for code, name in enumerate(msg.classes):
        if name in CLASSES and name != "unknown":
            table[code, 1:] = (*COLOURS[CLASSES.index(name)], MAP_ALPHA)
    cells = table[codes]
    fields = [fm.PackedElementField(name=name, offset=offset, type=fm.PackedElementFieldNumericType.Uint8)
              for offset, name in enumerate(("class", "red", "green", "blue", "alpha"))]
    return fm.Grid(timestamp=timestamp(ns), frame_id=FRAME,
                   pose=fm.Pose(position=fm.Vector3(x=spec.origin_x, y=spec.origin_z, z=elevation),
                                orientation=fm.Quaternion(x=0.0, y=0.0, z=0.0, w=1.0)),
                   column_count=spec.width, cell_size=fm.Vector2(x=spec.cell_m, y=spec.cell_m),
                   row_stride=spec.width * 5, cell_stride=5, fields=fields, data=cells.tobytes())
