"""Seeded scenario generator: varied, valid missions to measure the behaviour off the cases it was tuned on.

A figure from the shipped scenarios, which the behaviour was tuned against, says little about a site nobody has
looked at. ``generate(seed)`` draws a mission from one ``random.Random(seed)`` (a seed always gives the same
scenario) and labels what it drew (``GeneratedScenario.classes``, values in ``CLASS_VALUES``), so results can be
tabulated per class:

- family: crater (a crater goal, maybe a waypoint before and after), traverse (1-3 waypoints, maybe a crater among
  them), maze (a walled corridor with baffles before the first waypoint, as maze.yaml), daisy (the lander's radio
  only as long as the rovers', 25-40 m, and a goal 80-150 m away, as daisy_chain.yaml);
- terrain: flat or rough (0.3-0.8 m of undulation); density: rocks none, sparse or dense (fields of 0.003-0.006 or
  0.012-0.02 rocks a square metre); noise: none, low, shipped (the shipped scenarios') or high (``NOISE``);
- team: small (5-8 rovers), medium (9-14), large (15-20); start: normal (a formation), in_crater (1-4 rovers in a
  crater's bowl) or out_of_range (1-2 rovers out of any radio's reach: ``GeneratedScenario``);
- walls: yes or no; goals: 1-4; return: yes when the last goal is back at the start (a waypoint).

Goals are reachable in principle: rock fields, walls and craters keep clear of every start, the lander, each other
and each waypoint (with room for a formation there), free-standing walls are open at both ends, a maze's baffles
leave a gap, and a crater rovers start in is shallow enough to climb out of.
"""

from __future__ import annotations

import math
import random
from dataclasses import dataclass

from scenarios.generator_layout import (
    LANDER_COMM_RANGE_M,
    RIM_WIDTH,
    ROVER_COMM_RANGE_M,
    STATION_CLEAR_M,
    CraterSpot,
    Layout,
    Point,
    bearing_of,
    lerp,
    local,
    mm,
    pick_leg,
    toward,
)
from schemas.scenario import Scenario, parse_scenario
from schemas.scenario_limits import SEED_LIMIT

Goal = tuple[Point, str, bool, "CraterSpot | None"]
"""Where the goal marker stands, its kind, whether it is the return to the start, and its crater."""

FAMILIES = ("crater", "traverse", "maze", "daisy")
NOISE = {"none": (0.0, 0.0, 0.0), "low": (0.01, 0.1, 0.05), "shipped": (0.02, 0.3, 0.1), "high": (0.05, 1.0, 0.3)}
"""(slip_std, heading_noise_std_deg, gyroscope_noise_std_deg) per level; 'shipped' is scenarios/*.yaml's."""
TEAMS = {"small": (5, 8), "medium": (9, 14), "large": (15, 20)}
CLASS_VALUES: dict[str, tuple[str, ...]] = {
    "family": FAMILIES, "terrain": ("flat", "rough"), "density": ("none", "sparse", "dense"), "noise": tuple(NOISE),
    "team": tuple(TEAMS), "start": ("normal", "in_crater", "out_of_range"), "walls": ("yes", "no"),
    "goals": ("1", "2", "3", "4"), "return": ("yes", "no"),
}
"""Every label ``generate`` gives, and the values it can take."""

MAX_ROCK_M = 1.2
MAX_PATH_M = 480.0
"""Longest crow-flies route from the start through every goal: one mission stays well under a minute of wall."""
ATTEMPTS = 400


@dataclass(frozen=True)
class GeneratedScenario:
    """A generated mission and what it was drawn as.

    ``in_crater``: ids (1-based, as the world numbers rovers) of rovers that start within a crater's radius.
    ``out_of_range``: ids of rovers that start with no radio link at all: farther from the lander than
    ``lander_comm_range`` and farther from every other rover than ``comm_range``. Every other rover has a route
    to the lander by range alone (line of sight aside)."""

    scenario: Scenario
    classes: dict[str, str]
    in_crater: tuple[int, ...] = ()
    out_of_range: tuple[int, ...] = ()


def generate(seed: int, kind: str | None = None) -> GeneratedScenario:
    """A valid, varied mission from ``seed``; ``kind`` fixes the family (None: drawn from the seed too)."""
    if not 0 <= seed < SEED_LIMIT:
        raise ValueError(f"--seed must be at least 0 and below 2**63 (it is the scenario's seed too), got {seed}")
    if kind is not None and kind not in FAMILIES:
        raise ValueError(f"--kind {kind!r} is no family: choose one of {', '.join(FAMILIES)}")
    rng = random.Random(seed)
    classes = _draw_classes(rng, kind)
    return _build(rng, seed, classes)


def _draw_classes(rng: random.Random, kind: str | None) -> dict[str, str]:
    """Every class up front and independently, so each is spread evenly over the others."""
    family = kind or rng.choice(FAMILIES)
    return {"family": family, "terrain": "rough" if rng.random() < 0.4 else "flat",
            "density": rng.choices(CLASS_VALUES["density"], (0.3, 0.35, 0.35))[0], "noise": rng.choice(tuple(NOISE)),
            "team": rng.choice(tuple(TEAMS)),
            "start": rng.choices(CLASS_VALUES["start"], (0.5, 0.25, 0.25))[0],
            "walls": "yes" if family == "maze" or rng.random() < 0.3 else "no"}


def _build(rng: random.Random, seed: int, drawn: dict[str, str]) -> GeneratedScenario:
    """Place the team, the goals, then the obstacles around them (each keeping clear of what came before)."""
    family, start = drawn["family"], drawn["start"]
    team = rng.randint(*TEAMS[drawn["team"]])
    extra = {"normal": 0, "in_crater": rng.randint(1, min(4, max(1, team // 4))), "out_of_range": rng.randint(1, 2)}
    theta = rng.uniform(0.0, 360.0)  # the direction of travel
    layout, centre, spread, heading = _formation(rng, family, team - extra[start], theta)
    first = _maze(rng, layout, centre, spread, theta) if family == "maze" else None
    in_crater = _in_crater_start(rng, layout, centre, spread, theta, extra[start], drawn["terrain"]) \
        if start == "in_crater" else []
    goals = _goals(rng, layout, family, centre, spread, theta, first)
    comm = _radio(rng, layout, family, start)
    far = _out_of_range_start(rng, layout, goals, comm, extra[start]) if start == "out_of_range" else []
    if drawn["walls"] == "yes" and family != "maze":
        _free_walls(rng, layout, _route(centre, goals))
    rocks, fields = _rocks(rng, layout, drawn["density"], _route(centre, goals))
    headings = [heading] * (team - len(in_crater) - len(far)) + [mm(rng.uniform(0, 360)) for _ in in_crater + far]
    data = _scenario_data(seed, drawn, layout, headings, goals, (rocks, fields), comm)
    scenario = _with_terrain(rng, parse_scenario(data, f"generated seed {seed}"), drawn["terrain"])
    classes = {**drawn, "density": _density_label(rocks, fields), "walls": "yes" if layout.walls else "no",
               "goals": str(len(goals)), "return": "yes" if goals[-1][2] else "no"}
    ids = range(1, team + 1)
    return GeneratedScenario(scenario, classes, tuple(ids[team - len(far) - len(in_crater):team - len(far)]),
                             tuple(ids[team - len(far):]))


def _scenario_data(seed: int, drawn: dict[str, str], layout: Layout, headings: list[float], goals: list[Goal],
                   rocks: tuple[list, list], comm: tuple[float, float] | None) -> dict:
    slip, turn, gyro = NOISE[drawn["noise"]]
    params: dict = {"navigation": {"slip_std": slip, "heading_noise_std_deg": turn},
                    "perception": {"gyroscope_noise_std_deg": gyro}}
    if comm is not None:
        params["communication"] = {"comm_range": comm[0], "lander_comm_range": comm[1]}
    walls = [{"points": [[mm(x), mm(z)] for x, z in w], "thickness_m": 1.0} for w in layout.walls]
    return {"name": f"generated_{drawn['family']}_{seed}", "seed": seed, "lander": {"x": 0.0, "z": 0.0},
            "rovers": [{"x": mm(x), "z": mm(z), "heading_deg": h} for (x, z), h in zip(layout.rovers, headings,
                                                                                       strict=True)],
            "craters": [c.spec() for c in layout.craters],
            "obstacles": {"rocks": rocks[0], "walls": walls, "rock_fields": rocks[1]},
            "mission": [{"x": mm(p[0]), "z": mm(p[1]), "kind": kind} for p, kind, _, _ in goals],
            "rover_params": params}


# ---- the team and where it starts ----


def _formation(rng: random.Random, family: str, count: int, theta: float) -> tuple[Layout, Point, float, float]:
    """Rows of ceil(sqrt(count)) across the direction of travel, as ``SpawnParams.formation`` lays them out,
    at a random side of the lander (next to it for the daisy chain, whose lander reaches only tens of metres)."""
    spacing = rng.uniform(4.0, 6.0) if family == "daisy" else rng.uniform(5.0, 10.0)
    per_row = math.ceil(math.sqrt(count))
    rows = math.ceil(count / per_row)
    spread = math.hypot((per_row - 1) * spacing / 2, (rows - 1) * spacing / 2)
    side = theta + rng.uniform(-90, 90) if family == "maze" else rng.uniform(0, 360)  # maze: lander not ahead
    distance = spread + (rng.uniform(4, 8) if family == "daisy" else rng.uniform(10, 50))
    centre = toward((0.0, 0.0), side, distance)
    offsets = [((i % per_row - (per_row - 1) / 2) * spacing, ((rows - 1) / 2 - i // per_row) * spacing)
               for i in range(count)]
    layout = Layout(lander=(0.0, 0.0), rovers=[local(centre, theta, u, v) for v, u in offsets])
    return layout, centre, spread, mm((theta + rng.uniform(-60, 60)) % 360)


def _in_crater_start(rng: random.Random, layout: Layout, centre: Point, spread: float, theta: float, count: int,
                     terrain: str) -> list[Point]:
    """A crater beside the formation with ``count`` rovers in its bowl, shallow enough to climb out of: the bowl
    wall is 2 depth / radius steep at the crest, kept to 0.36 (20 degrees, under max_slope_deg's 25), to 0.3 when
    rough. The undulation can add up to 0.25 where all its waves happen to align: such a spot is too steep, rare,
    and the rover walks round it."""
    for attempt in range(ATTEMPTS):
        radius = rng.uniform(12.0, 22.0)
        depth = rng.uniform(0.1, 0.15 if terrain == "rough" else 0.18) * radius
        side = theta + rng.choice((-90, 90)) + rng.uniform(-40, 40)
        at = toward(centre, side, spread + (1 + RIM_WIDTH) * radius + rng.uniform(6, 15) + attempt / 4)
        crater = CraterSpot(*at, radius, depth, rng.uniform(0.02, 0.04) * radius)
        if layout.clear(at, crater.outer + 5):
            layout.craters.append(crater)
            break
    else:
        raise RuntimeError("no room for a start crater")  # the attempts move it ever farther out: unreachable
    spots: list[Point] = []
    while len(spots) < count:
        p = toward(at, rng.uniform(0, 360), rng.uniform(0, 0.6 * radius))
        if all(math.dist(p, q) >= 3.0 for q in spots):
            spots.append(p)
    layout.rovers += spots
    return spots


def _out_of_range_start(rng: random.Random, layout: Layout, goals: list[Goal], comm: tuple[float, float] | None,
                        count: int) -> list[Point]:
    """Rovers beyond the lander's radio and every other rover's, towards the goals, so the team may pass by."""
    rover_range, lander_range = comm if comm is not None else (ROVER_COMM_RANGE_M, LANDER_COMM_RANGE_M)
    towards = bearing_of(layout.lander, goals[0][0])
    spots: list[Point] = []
    for attempt in range(ATTEMPTS * count):
        p = toward(layout.lander, towards + rng.uniform(-100, 100),
                    lander_range * rng.uniform(1.15, 1.35) + attempt / 4)
        if layout.clear(p, 2.0, rover_gap=rover_range + 1):
            layout.rovers.append(p)
            spots.append(p)
            if len(spots) == count:
                return spots
    raise RuntimeError("no room out of radio range")  # each attempt steps farther out: unreachable


def _radio(rng: random.Random, layout: Layout, family: str, start: str) -> tuple[float, float] | None:
    """(comm_range, lander_comm_range) where they differ from the defaults, else None.

    The daisy family gives the lander the rovers' range, as ``daisy_chain.yaml``. Otherwise only a start out of
    range needs a shorter lander radio: one that still reaches every start and every goal (crater rims whole),
    so the rovers put out of its reach are the only ones."""
    if family == "daisy":
        radio = mm(rng.uniform(25.0, 40.0))
        return radio, radio
    if start != "out_of_range":
        return None
    reach = [math.dist(layout.lander, r) for r in layout.rovers]
    reach += [math.dist(layout.lander, w) + STATION_CLEAR_M for w in layout.waypoints]
    reach += [math.dist(layout.lander, (c.x, c.z)) + c.radius + 2 for c in layout.craters]
    return ROVER_COMM_RANGE_M, mm(max(60.0, max(reach) + rng.uniform(10.0, 25.0)))


# ---- goals ----


def _goal_kinds(rng: random.Random, family: str) -> list[str]:
    """Goal kinds in order; 'return' is a waypoint back at the start, as crater_and_return's."""
    if family == "crater":
        kinds = ["waypoint"] * (rng.random() < 0.25) + ["crater"] + ["waypoint"] * (rng.random() < 0.3)
    elif family == "traverse":
        kinds = ["crater" if rng.random() < 0.25 else "waypoint" for _ in range(rng.randint(1, 3))]
    elif family == "maze":
        kinds = ["waypoint"] + ["crater"] * (rng.random() < 0.5)
    else:
        kinds = ["crater" if rng.random() < 0.7 else "waypoint"]
    return kinds + ["return"] * (rng.random() < (0.3 if family == "daisy" else 0.5))


def _goals(rng: random.Random, layout: Layout, family: str, centre: Point, spread: float, theta: float,
           first: Point | None) -> list[Goal]:
    """The goals in order; the whole chain is drawn again until it fits."""
    kinds = _goal_kinds(rng, family)
    for _ in range(ATTEMPTS):
        trial = Layout(layout.lander, list(layout.rovers), list(layout.craters), list(layout.waypoints),
                        list(layout.walls))
        goals = _try_goals(rng, trial, family, kinds, centre, spread, theta, first)
        if goals is not None:
            layout.craters, layout.waypoints = trial.craters, trial.waypoints
            return goals
    raise RuntimeError(f"no goals fit for {kinds}")


def _try_goals(rng: random.Random, layout: Layout, family: str, kinds: list[str], centre: Point, spread: float,
               theta: float, first: Point | None) -> list[Goal] | None:
    """One draw of the goal chain into ``layout``; None if something does not fit or the route is too long."""
    here, bearing, path, goals = (layout.lander if family == "daisy" else centre), theta, 0.0, []
    for i, kind in enumerate(kinds):
        leg = rng.uniform(80.0, 150.0) if family == "daisy" else rng.uniform(70.0, 140.0) + (0 if i else spread)
        ahead = first if i == 0 and first is not None else toward(here, bearing, leg)
        crater = _add_crater(rng, layout, ahead, bearing) if kind == "crater" else None
        if kind == "return":  # the start: clear of craters and walls, since the formation stood there
            layout.waypoints.append(centre)
        elif kind == "waypoint" and not layout.clear(ahead, 10.0):
            return None
        elif kind == "waypoint":
            layout.waypoints.append(ahead)
        elif crater is None:
            return None
        spot = centre if kind == "return" else ahead if crater is None else _crater_mark(rng, crater)
        path += math.dist(here, spot)
        bearing, here = bearing_of(here, spot) + rng.uniform(-110, 110), spot
        goals.append((spot, "crater" if crater else "waypoint", kind == "return", crater))
    return goals if path <= MAX_PATH_M else None


def _add_crater(rng: random.Random, layout: Layout, crest: Point, bearing: float) -> CraterSpot | None:
    """A crater whose near crest is at ``crest``, coming along ``bearing``; None if it does not fit."""
    radius = rng.uniform(12.0, 35.0)
    crater = CraterSpot(*toward(crest, bearing, radius), radius, rng.uniform(0.1, 0.2) * radius,
                     rng.uniform(0.02, 0.05) * radius)
    if not layout.clear((crater.x, crater.z), crater.outer + 5):
        return None
    layout.craters.append(crater)
    return crater


def _crater_mark(rng: random.Random, crater: CraterSpot) -> Point:
    """The goal marker near the crater's centre, as the shipped scenarios have it."""
    return toward((crater.x, crater.z), rng.uniform(0, 360), rng.uniform(0, 0.3 * crater.radius))


def _route(centre: Point, goals: list[Goal]) -> list[Point]:
    """Start, then each goal where it is reached (a crater on the crest nearest the way in)."""
    route = [centre]
    for p, _, _, c in goals:
        route.append(p if c is None else toward((c.x, c.z), bearing_of((c.x, c.z), route[-1]), c.radius))
    return route


# ---- obstacles and terrain ----


def _maze(rng: random.Random, layout: Layout, centre: Point, spread: float, theta: float) -> Point:
    """A corridor ahead of the formation with 2-3 baffles from alternate sides, each leaving a 14-22 m gap, as
    ``maze.yaml``; returns the first waypoint, beyond the corridor."""
    start, length = spread + 8.0, rng.uniform(50.0, 75.0)
    width = max(2 * spread + 24.0, rng.uniform(55.0, 85.0))
    half = width / 2
    layout.walls += [(local(centre, theta, start, s * half), local(centre, theta, start + length, s * half))
                     for s in (-1, 1)]
    count, side = rng.randint(2, 3), rng.choice((-1, 1))
    for i in range(count):
        u, gap = start + length * (i + 1) / (count + 1), rng.uniform(14.0, 22.0)
        layout.walls.append((local(centre, theta, u, side * half), local(centre, theta, u, side * (gap - half))))
        side = -side
    return local(centre, theta, start + length + rng.uniform(25.0, 40.0), rng.uniform(-10.0, 10.0))


def _free_walls(rng: random.Random, layout: Layout, route: list[Point]) -> None:
    """1-2 straight walls across legs of the route: open at both ends, so there is always a way round."""
    for _ in range(rng.randint(1, 2)):
        for _ in range(ATTEMPTS // 10):
            a, b = pick_leg(rng, route)
            across, half = bearing_of(a, b) + 90 + rng.uniform(-20, 20), rng.uniform(7.0, 18.0)
            mid = toward(lerp(a, b, rng.uniform(0.35, 0.65)), across, rng.uniform(-0.5, 0.5) * half)
            wall = (toward(mid, across, -half), toward(mid, across, half))
            if layout.wall_clear(*wall):
                layout.walls.append(wall)
                break


def _rocks(rng: random.Random, layout: Layout, density: str, route: list[Point]) -> tuple[list, list]:
    """Rock fields on legs of the route (the world scatters their rocks from the scenario's seed) and a few
    single rocks; each field's disc, grown by the largest rock, keeps clear of everything placed."""
    if density == "none":
        return [], []
    per_m2 = (0.003, 0.006) if density == "sparse" else (0.012, 0.02)
    fields = []
    for _ in range(rng.randint(1, 2) if density == "sparse" else rng.randint(1, 3)):
        spot = _field_spot(rng, layout, route)
        if spot is not None:
            (x, z), radius = spot
            rounded = math.floor if density == "sparse" else math.ceil  # keeps a small field in its class
            count = max(1, rounded(rng.uniform(*per_m2) * math.pi * radius**2))
            fields.append({"x": mm(x), "z": mm(z), "radius_m": mm(radius), "count": count, "min_radius_m": 0.3,
                           "max_radius_m": MAX_ROCK_M})
    rocks = []
    for _ in range(rng.randint(2, 5)):
        a, b = pick_leg(rng, route)
        p, radius = toward(lerp(a, b, rng.uniform(0.2, 0.8)), rng.uniform(0, 360), rng.uniform(0, 6)), \
            rng.uniform(0.6, 1.5)
        if layout.clear(p, radius + 2):
            layout.fields.append((p, radius))
            rocks.append({"x": mm(p[0]), "z": mm(p[1]), "radius_m": mm(radius)})
    return rocks, fields


def _field_spot(rng: random.Random, layout: Layout, route: list[Point]) -> tuple[Point, float] | None:
    for _ in range(ATTEMPTS // 10):
        a, b = pick_leg(rng, route)
        p = toward(lerp(a, b, rng.uniform(0.2, 0.8)), rng.uniform(0, 360), rng.uniform(0, 10))
        radius = rng.uniform(12.0, 28.0)
        while radius >= 6.0 and not layout.clear(p, radius + MAX_ROCK_M + 2):
            radius *= 0.8
        if radius >= 6.0:
            layout.fields.append((p, radius + MAX_ROCK_M))
            return p, radius
    return None


def _density_label(rocks: list, fields: list) -> str:
    """What was placed, not what was drawn: a field that found no room does not count."""
    if not fields:
        return "sparse" if rocks else "none"
    per_m2 = max(f["count"] / (math.pi * f["radius_m"] ** 2) for f in fields)
    return "dense" if per_m2 >= 0.01 else "sparse"


def _with_terrain(rng: random.Random, scenario: Scenario, terrain: str) -> Scenario:
    """Rough: the fitted terrain, declared with a seeded undulation (its slope stays under about 14 degrees)."""
    if terrain == "flat":
        return scenario
    spec = scenario.terrain_spec().model_copy(update={"roughness_m": mm(rng.uniform(0.3, 0.8))})
    data = scenario.model_dump(mode="json", exclude_defaults=True)
    return parse_scenario({**data, "name": scenario.name, "seed": scenario.seed,
                           "terrain": spec.model_dump(mode="json", exclude_defaults=True)}, scenario.name)
