"""Scenario files: a declarative YAML description of one mission, validated by pydantic.

An invalid file raises ``ScenarioError`` naming the file, then every problem on a line of its own with its field
path, so one edit can fix them all. The bounds are in ``schemas.scenario_limits``.
"""

from __future__ import annotations

import importlib.util
import math
from pathlib import Path
from typing import Annotated, Literal, TypeVar

import msgspec
import yaml
from pydantic import BaseModel, ConfigDict, Field, ValidationError, ValidationInfo, field_validator, model_validator

from schemas import scenario_limits as limits
from schemas.params import RoverParams, SpawnParams
from schemas.scenario_errors import ScenarioError, error_lines, format_error
from schemas.scenario_files import check_mesh, read_yaml
from schemas.scenario_limits import clip
from schemas.scenario_types import BehaviourSpec, Coordinate, SafeName, mirror, struct_field, to_struct

M = TypeVar("M", bound=BaseModel)
S = TypeVar("S", bound=msgspec.Struct)
Side = Annotated[float, Field(gt=0, le=limits.MAX_TERRAIN_SIDE_M)]


class Spec(BaseModel):
    model_config = ConfigDict(extra="forbid", frozen=True, allow_inf_nan=False)


class TerrainSpec(Spec):
    origin: tuple[Coordinate, Coordinate] = Field(description="x, z of the terrain's minimum corner, m")
    size_m: tuple[Side, Side] = Field(description="extent along x and z, m")
    resolution_m: float = Field(1.0, ge=limits.MIN_RESOLUTION_M, le=100)
    roughness_m: float = Field(0.0, ge=0, description="amplitude of seeded random undulation, m")
    tile_size_m: float = Field(256.0, gt=0, le=limits.MAX_TERRAIN_SIDE_M,
                               description="side of a square terrain tile (chunk), loaded on first use")
    max_tiles_in_memory: int = Field(64, ge=1, description="tiles kept loaded at most (least recently used go)")
    chunk_activation_range_m: float = Field(
        500.0, gt=0, description="tiles within this distance of a rover stay loaded (report Table 6 "
                                 "rover_chunk_activation_range; 1000 m there)")
    mesh: str | None = Field(None, description="OBJ/STL/PLY/GLB surface (y up) rasterised into the heights; "
                                               "replaces the plain, so scenario craters are not carved into it. "
                                               f"A regular file of at most {limits.MAX_MESH_BYTES // 1024**2} MiB, "
                                               "relative to the scenario's folder")
    mesh_scale: float | tuple[float, float, float] = Field(1.0, description="mesh vertex scale (x, y, z or one)")
    mesh_offset: tuple[float, float, float] = Field((0.0, 0.0, 0.0), description="added to scaled vertices, m")

    @field_validator("mesh")
    @classmethod
    def _mesh_file(cls, mesh: str | None, info: ValidationInfo) -> str | None:
        """Read from a file (``load_scenario``), the mesh must be a readable mesh file, made an absolute path;
        validated from data alone (a page, a recording), only its name is checked: no file is looked at."""
        if mesh is None:
            return None
        base_dir = (info.context or {}).get("base_dir")
        if base_dir is None:
            limits.mesh_suffix(mesh)
            return mesh
        return check_mesh(mesh, Path(base_dir))

    @model_validator(mode="after")
    def _fits(self) -> TerrainSpec:
        if self.tile_size_m < self.resolution_m:
            raise ValueError("tile_size_m must be at least resolution_m")
        limits.check_terrain_memory(self.size_m, self.resolution_m, self.tile_size_m, self.max_tiles_in_memory)
        return self

    def contains(self, x: float, z: float) -> bool:
        ox, oz = self.origin
        return ox <= x <= ox + self.size_m[0] and oz <= z <= oz + self.size_m[1]


class LanderSpec(Spec):
    x: Coordinate
    z: Coordinate
    radius_m: float = Field(1.5, gt=0, le=100)


class RoverSpawn(Spec):
    x: Coordinate
    z: Coordinate
    heading_deg: float = 180.0


class Crater(Spec):
    """A bowl with a raised rim: crest at ``radius_m``, rim falling off outside over ``rim_width`` x radius."""

    x: Coordinate
    z: Coordinate
    radius_m: float = Field(gt=0, le=limits.MAX_CRATER_RADIUS_M)
    depth_m: float | None = Field(None, ge=0, description="default 0.2 x radius; at most the radius")
    rim_height_m: float | None = Field(None, ge=0, description="default 0.04 x radius; at most the radius")
    rim_width: float = Field(0.3, gt=0, le=2, description="outer rim width as a fraction of the radius")

    @model_validator(mode="after")
    def _shallower_than_wide(self) -> Crater:
        """A bowl deeper than its radius is no crater (simple ones are about a fifth as deep as wide)."""
        for what, value in (("depth_m", self.depth_m), ("rim_height_m", self.rim_height_m)):
            if value is not None and value > self.radius_m:
                raise ValueError(f"{what} ({value:g}) must be at most radius_m ({self.radius_m:g})")
        return self

    @property
    def depth(self) -> float:
        return self.depth_m if self.depth_m is not None else 0.2 * self.radius_m

    @property
    def rim_height(self) -> float:
        return self.rim_height_m if self.rim_height_m is not None else 0.04 * self.radius_m

    @property
    def outer_radius(self) -> float:
        """Where the rim starts to rise: what rovers perceive as crater terrain."""
        return self.radius_m * (1 + self.rim_width)


class Rock(Spec):
    x: Coordinate
    z: Coordinate
    radius_m: float = Field(gt=0, le=limits.MAX_ROCK_RADIUS_M)


class Wall(Spec):
    points: list[tuple[Coordinate, Coordinate]] = Field(min_length=2, max_length=limits.MAX_WALL_POINTS)
    thickness_m: float = Field(0.5, gt=0, le=1000)
    height_m: float = Field(1.0, gt=0, le=10_000, description="a radio line passing above the wall is not blocked")


class RockField(Spec):
    """Seeded random rocks scattered in a disc: where they fall follows from the scenario's seed."""

    x: Coordinate
    z: Coordinate
    radius_m: float = Field(gt=0, le=limits.MAX_TERRAIN_SIDE_M, description="radius of the area the rocks fall in")
    count: int = Field(ge=0, le=limits.MAX_ROCKS)
    min_radius_m: float = Field(0.3, gt=0, le=limits.MAX_ROCK_RADIUS_M)
    max_radius_m: float = Field(1.2, gt=0, le=limits.MAX_ROCK_RADIUS_M)

    @model_validator(mode="after")
    def _ordered(self) -> RockField:
        if self.max_radius_m < self.min_radius_m:
            raise ValueError("max_radius_m must be at least min_radius_m")
        return self


class Obstacles(Spec):
    rocks: list[Rock] = Field(default_factory=list, max_length=limits.MAX_ROCKS)
    walls: list[Wall] = Field(default_factory=list, max_length=limits.MAX_WALLS)
    rock_fields: list[RockField] = Field(default_factory=list, max_length=limits.MAX_ROCK_FIELDS)

    @model_validator(mode="after")
    def _rocks_in_all(self) -> Obstacles:
        total = len(self.rocks) + sum(f.count for f in self.rock_fields)
        if total > limits.MAX_ROCKS:
            raise ValueError(f"{total:,} rocks in all (listed, and every rock field's count): at most "
                             f"{limits.MAX_ROCKS:,}")
        return self


class Goal(Spec):
    x: Coordinate
    z: Coordinate
    kind: Literal["crater", "waypoint"] = "waypoint"


class Formation(Spec):
    """How a team stands at a waypoint or crater it shares (need N7): each rover gets its own station, in
    ``shape`` round a waypoint, all round the crest of a crater.

    ``none`` is the report's rule (every rover heads for the goal and stops once a waypoint is in view, or on
    the crest wherever it meets it), which crowds the goal with more than a handful of rovers.
    """

    shape: Literal["disc", "line", "none"] = "disc"
    spacing_m: float = Field(3.2, gt=0, description="between neighbouring stations; drawn closer, to no less than "
                             "a 1 m gap between bodies, where a large team would otherwise stand farther than 60% "
                             "of the perception radius from the waypoint, or not fit round the crater's crest")


class SunSpec(Spec):
    """Where the sun stands. Without this block there is no power model at all.

    Either fixed (``azimuth_deg`` and ``elevation_deg``) or from the site: ``latitude_deg`` and the time of the
    lunar day, the sun then moving with simulation time over a synodic day of 29.53 Earth days. Map axes:
    +z is north, +x east; azimuth like a heading (0 = from +z, 90 = from +x).
    """

    azimuth_deg: float | None = Field(None, description="fixed sun: direction it shines from")
    elevation_deg: float | None = Field(None, ge=-90, le=90, description="fixed sun: height above the horizon")
    latitude_deg: float | None = Field(None, ge=-90, le=90, description="site latitude (the report's far-side "
                                                                         "polar sites: about -85 to -89)")
    hours_after_noon: float = Field(0.0, description="local lunar time at t = 0, Earth hours after local noon")
    declination_deg: float = Field(0.0, ge=-1.6, le=1.6, description="the sun's declination at the Moon "
                                                                     "(within its 1.54 degree axial tilt)")
    step_deg: float = Field(0.05, gt=0, le=5, description="sun positions are quantised to this for the shadow "
                                                          "cache")
    max_shadow_m: float = Field(200.0, gt=0, description="longest shadow traced, m")

    @model_validator(mode="after")
    def _one_way(self) -> SunSpec:
        fixed = (self.azimuth_deg is not None, self.elevation_deg is not None)
        if fixed[0] != fixed[1]:
            raise ValueError("a fixed sun needs both azimuth_deg and elevation_deg")
        if fixed[0] == (self.latitude_deg is not None):
            raise ValueError("give either azimuth_deg and elevation_deg (a fixed sun) or latitude_deg (one moving "
                             "with the lunar day)")
        return self


class Scenario(Spec):
    name: SafeName = Field(description="also the run folder's name: no path in it")
    seed: int = Field(0, ge=0, lt=limits.SEED_LIMIT)
    terrain: TerrainSpec | None = None
    lander: LanderSpec
    rovers: list[RoverSpawn] = Field(min_length=1, max_length=limits.MAX_ROVERS)
    craters: list[Crater] = Field(default_factory=list, max_length=limits.MAX_CRATERS)
    obstacles: Obstacles = Obstacles()
    mission: list[Goal] = Field(min_length=1, max_length=limits.MAX_GOALS)
    rover_params: struct_field(RoverParams) = RoverParams()
    spawn: struct_field(SpawnParams) | None = Field(None, description="Table 3; used by --rovers N")
    formation: Formation = Formation()
    behaviour: BehaviourSpec = Field("default", description="default, straight, an installed plugin's name or "
                                      "package.module:Class (importable from the folder lunarsim runs in)")
    sun: SunSpec | None = Field(None, description="sunlight, shadows, battery and temperature; none: off")

    @model_validator(mode="after")
    def _consistent(self) -> Scenario:
        """Every problem at once, one a line starting with its field path (``error_lines`` splits them)."""
        problems = [f"mission.{i}: crater goal ({goal.x}, {goal.z}) lies in no crater"
                    for i, goal in enumerate(self.mission) if goal.kind == "crater" and self.crater_of(goal) is None]
        if self.terrain is not None:
            problems += [f"{what} ({x}, {z}) lies outside the terrain" for what, x, z in self._placed()
                         if not self.terrain.contains(x, z)]
        else:
            try:
                self.terrain_spec()
            except ValidationError as exc:
                width, depth = self._extent(0.0)
                problems += [f"terrain: none given, and one fitted around the lander, rovers, goals and craters "
                             f"({width:,.0f} m x {depth:,.0f} m) would not do: {line}" for line in error_lines(exc)]
        try:
            limits.check_map_memory(self._extent(limits.MAP_MARGIN_M), self.rover_params.mapping.cell_m)
        except ValueError as exc:
            problems.append(f"rover_params.mapping.cell_m: {exc}")
        if problems:
            raise ValueError("\n".join(problems))
        return self

    def _extent(self, margin_m: float) -> tuple[float, float]:
        """Width and depth of the box around everything placed and every crater's rim, plus ``margin_m``."""
        xs = [x for _, x, _ in self._placed()] + [c.x + s * c.outer_radius for c in self.craters for s in (-1, 1)]
        zs = [z for _, _, z in self._placed()] + [c.z + s * c.outer_radius for c in self.craters for s in (-1, 1)]
        return max(xs) - min(xs) + 2 * margin_m, max(zs) - min(zs) + 2 * margin_m

    def _placed(self) -> list[tuple[str, float, float]]:
        spots = [("lander", self.lander.x, self.lander.z)]
        spots += [(f"rovers.{i}", r.x, r.z) for i, r in enumerate(self.rovers)]
        spots += [(f"mission.{i}", g.x, g.z) for i, g in enumerate(self.mission)]
        return spots

    def crater_of(self, goal: Goal) -> Crater | None:
        """The crater a crater goal designates: the one whose rim encloses it (nearest centre first)."""
        inside = [c for c in self.craters if math.hypot(goal.x - c.x, goal.z - c.z) <= c.radius_m]
        return min(inside, key=lambda c: math.hypot(goal.x - c.x, goal.z - c.z), default=None)

    def terrain_spec(self, margin_m: float = 60.0) -> TerrainSpec:
        """The declared terrain, or one fitted around everything in the scenario."""
        if self.terrain is not None:
            return self.terrain
        xs = [x for _, x, _ in self._placed()] + [c.x - c.outer_radius for c in self.craters]
        xs += [c.x + c.outer_radius for c in self.craters]
        zs = [z for _, _, z in self._placed()] + [c.z - c.outer_radius for c in self.craters]
        zs += [c.z + c.outer_radius for c in self.craters]
        lo_x, lo_z = math.floor(min(xs) - margin_m), math.floor(min(zs) - margin_m)
        return TerrainSpec(origin=(lo_x, lo_z), size_m=(math.ceil(max(xs) + margin_m) - lo_x,
                                                         math.ceil(max(zs) + margin_m) - lo_z))

    def with_overrides(self, seed: int | None = None, rovers: int | None = None,
                       rover_params: RoverParams | None = None) -> Scenario:
        """Apply command-line overrides; ``rovers`` respawns N rovers in the Table 3 formation."""
        update: dict = {}
        if seed is not None:
            if not 0 <= seed < limits.SEED_LIMIT:
                raise ScenarioError(f"--seed must be at least 0 and below 2**63, got {seed}")
            update["seed"] = seed
        if rover_params is not None:
            update["rover_params"] = rover_params
        if rovers is not None:
            if rovers < 1:
                raise ScenarioError(f"--rovers must be at least 1, got {rovers}")
            if rovers > limits.MAX_ROVERS:
                raise ScenarioError(f"--rovers must be at most {limits.MAX_ROVERS}, got {rovers}")
            spawn = self.spawn or SpawnParams()
            update["rovers"] = [RoverSpawn(x=x, z=z, heading_deg=h) for x, z, h in spawn.formation(rovers)]
        return parse_scenario({**self.model_dump(), **{k: _dump(v) for k, v in update.items()}}, self.name)


def _dump(value: object) -> object:
    if isinstance(value, list):
        return [v.model_dump() if isinstance(v, BaseModel) else v for v in value]
    return value


def parse_scenario(data: object, source: str = "<scenario>", base_dir: Path | None = None) -> Scenario:
    """A scenario from parsed data; ``base_dir``, the folder of the file it was read from, is where the files it
    names are looked for and checked (without it, they are not looked at)."""
    if not isinstance(data, dict):
        raise ScenarioError(f"{source}: expected a mapping at the top level, got {type(data).__name__}")
    try:
        return Scenario.model_validate(data, context={"base_dir": base_dir} if base_dir is not None else None)
    except ValidationError as exc:
        raise ScenarioError(format_error(source, exc, Scenario)) from None


def shipped_scenarios() -> dict[str, Path]:
    """The scenarios that come with LunarSim, by name: the YAML files of the ``scenarios`` package, found where it is
    installed without importing it (it sits above this package)."""
    spec = importlib.util.find_spec("scenarios")
    folders = list(spec.submodule_search_locations or []) if spec is not None else []
    return {p.stem: p for folder in folders for p in sorted(Path(folder).glob("*.yaml"))}


def find_scenario(path: str | Path) -> Path:
    """``path`` as given if it names a file; else a bare name (``crater_observation``, with or without ``.yaml``)
    finds a shipped scenario, from any folder."""
    path = Path(path)
    if path.exists() or path.parent != Path("."):
        return path
    shipped = shipped_scenarios()
    if (found := shipped.get(path.name.removesuffix(".yaml"))) is None:
        raise ScenarioError(f"{clip(str(path))}: no such file, nor a shipped scenario of that name (shipped: "
                            f"{', '.join(shipped)}; 'lunarsim scenario list' shows them)")
    return found


def load_scenario(path: str | Path) -> Scenario:
    path = find_scenario(path)
    data = read_yaml(path, "scenario")
    if data is None:
        raise ScenarioError(f"{path}: the scenario file is empty (it should be a YAML mapping with name, lander, "
                            "rovers and mission)")
    return parse_scenario(data, str(path), path.parent)


def dump_scenario(scenario: Scenario) -> str:
    """YAML text of a scenario, without the parameters that still have their defaults."""
    data = scenario.model_dump(mode="json", exclude_defaults=True)
    data = {"name": scenario.name, "seed": scenario.seed, **data}
    return yaml.safe_dump(data, sort_keys=False, default_flow_style=None)


def load_dispatch_plan(path: str | Path | None) -> tuple[LanderSpec, list[RoverSpawn]] | None:
    """The lander and the rovers' spawns of a mission file, read once and nothing else of it; None unless ``path``
    is a scenario (a rover's ``--params`` may be a bare parameter file instead)."""
    if path is None:
        return None
    data = read_yaml(Path(path), "rover parameters")
    if not isinstance(data, dict) or "mission" not in data:
        return None
    return _validated(LanderSpec, data.get("lander"), path), [_validated(RoverSpawn, r, path)
                                                               for r in data.get("rovers") or []]


def load_rover_params(path: str | Path | None) -> RoverParams:
    """Rover parameters from a YAML file: either a bare parameter mapping or a scenario's ``rover_params``.

    A rover agent reads these (its own specification) and, from a scenario, only its planned dispatch pose
    (``load_dispatch_plan``, ``shared.mission.dispatch_pose``), never the rest: the world is for it to sense.
    """
    if path is None:
        return RoverParams()
    path = Path(path)
    data = read_yaml(path, "rover parameters") or {}
    if isinstance(data, dict) and ("rover_params" in data or "mission" in data):
        data = data.get("rover_params") or {}
    return _validated_struct(RoverParams, data, path)


def _validated(model: type[M], data: object, path: str | Path) -> M:
    try:
        return model.model_validate(data)
    except ValidationError as exc:
        raise ScenarioError(format_error(str(path), exc, model)) from None


def _validated_struct(struct: type[S], data: object, path: str | Path) -> S:
    """A Struct from a user's file, validated by its mirror (``schemas.scenario_types``): the loader's messages."""
    return to_struct(struct, _validated(mirror(struct), data, path))
