"""The traverse map: the rover's reports, the lander's grid and its files, the truth comparison, and a
whole simulated mission (in one process, through the agents' pure handlers) scored against ground truth."""

from __future__ import annotations

import hashlib
import io
import random
import zlib
from pathlib import Path

import msgspec
import numpy as np
import pytest
from PIL import Image

from harness.loopback import run_mission
from lander_agent import mapping
from rover_agent.behaviour import Hit
from rover_agent.mission.traverse_map import CRATER, FREE, OBSTACLE, MapRecorder
from rover_agent.registry import load_behaviour
from schemas import codec, radio
from schemas.params import MappingParams, PerceptionParams, RoverParams
from schemas.scenario import load_scenario, parse_scenario
from schemas.wire_limits import DISTANCE_LIMIT_M
from world_service.outcome import map_truth

SCENARIOS = Path(__file__).resolve().parents[3] / "scenarios"
PARAMS = RoverParams(perception=PerceptionParams(field_of_view_degrees=180.0, perception_radius=5.0,
                                                 perception_granularity=5))
"""Five rays: -90, -45, 0, 45 and 90 degrees, 5 m long."""
RADIUS = PARAMS.perception.perception_radius


def _cells(recorder: MapRecorder, kind: int) -> set[tuple[int, int]]:
    return {(ix, iz) for ix, iz, k in recorder.known if k == kind}


# ---- the rover's side ----


def test_the_cells_scans_mark_stay_those_of_the_first_implementation():
    """Forty scans of the default sensor at random poses with random hits: the cells marked, in the order they
    were found, are those the half-cell walk marked when it was first written (its SHA-256). A faster walk must
    mark the same ones: the lander's map, and lockstep runs, depend on them."""
    params = RoverParams()
    fov, radius = params.perception.field_of_view_degrees, params.perception.perception_radius
    rng = random.Random(9)
    recorder = MapRecorder(params)
    for _ in range(40):
        x, z, h = round(rng.uniform(-50, 50), 2), round(rng.uniform(-50, 50), 2), round(rng.uniform(0, 360), 1)
        hits = [Hit(round(rng.uniform(-fov / 2, fov / 2), 1), round(rng.uniform(0.2, radius), 2),
                    rng.choice(["rover", "obstacle", "terrain", "lander", "crater_terrain"]))
                for _ in range(rng.randint(0, 20))]
        recorder.fold_scan(x, z, h, hits)
    assert len(recorder.pending) == 5420
    assert hashlib.sha256(repr(recorder.pending).encode()).hexdigest() == (
        "38a2186d61acc62307a11e57ac743a5470542a301e0d48f744644944d78c8eb0")


def test_a_scan_marks_the_hit_cell_and_the_free_cells_before_it():
    recorder = MapRecorder(PARAMS)
    recorder.fold_scan(0.2, 0.2, 0.0, [Hit(0.0, 3.0, "obstacle"), Hit(90.0, 2.0, "crater_terrain"),
                                       Hit(-90.0, 1.5, "rover")])
    assert _cells(recorder, OBSTACLE) == {(0, 3)}  # ahead (+z): (0.2, 3.2)
    assert _cells(recorder, CRATER) == {(2, 0)}  # to the right (+x): (2.2, 0.2)
    free = _cells(recorder, FREE)
    assert {(0, 0), (0, 1), (0, 2)} <= free and (0, 3) not in free  # up to the hit, not its cell
    assert {(-1, 0)} <= free and (-2, 0) not in free  # a rover is not mapped; the ray is free up to it
    assert {(3, 3), (-3, 3)} <= free  # rays that met nothing: free out to the perception radius
    assert max(ix for ix, iz in free if iz == 0) <= 1  # the ray to the right stopped at the crater


def test_a_hit_beyond_the_perception_radius_frees_no_cell_beyond_it():
    """A forged perception may put a hit anywhere the wire allows (40,000 km): walked to it half a cell at a time,
    one such ray held the rover's agent for half a minute."""
    recorder = MapRecorder(PARAMS)
    recorder.fold_scan(0.5, 0.5, 0.0, [Hit(0.0, DISTANCE_LIMIT_M, "obstacle"), Hit(90.0, 25.0, "obstacle")])
    free = _cells(recorder, FREE)
    assert (0, int(RADIUS) - 1) in free and (int(RADIUS) - 1, 0) in free  # walked out to the radius...
    assert max(max(abs(ix), abs(iz)) for ix, iz in free) <= RADIUS  # ...and no farther


def test_the_same_pose_twice_adds_nothing_and_every_cell_is_kept_once():
    recorder = MapRecorder(PARAMS)
    recorder.fold_scan(0.0, 0.0, 0.0, [Hit(0.0, 3.0, "obstacle")])
    first = list(recorder.pending)
    recorder.fold_scan(0.0, 0.0, 0.0, [Hit(0.0, 1.0, "obstacle")])
    assert recorder.pending == first
    recorder.fold_scan(0.0, 0.1, 0.0, [Hit(0.0, 2.9, "obstacle")])  # moved a little: the same cells again
    assert len(recorder.pending) == len(set(recorder.pending)) == len(first)


def test_reports_are_bounded_sent_only_with_a_partner_and_kept_until_acknowledged():
    params = msgspec.structs.replace(PARAMS, mapping=MappingParams(report_period_s=3.0, max_cells_per_report=4,
                                                               max_reports_per_send=2))
    recorder = MapRecorder(params)
    recorder.fold_scan(0.0, 0.0, 0.0, [])
    cells = len(recorder.pending)
    assert recorder.due(10.0, 0.0, 0.0, reachable=False) == []  # packed, but nothing could carry them
    assert len(recorder.outbox) == -(-cells // 4) >= 4
    assert recorder.due(11.0, 0.0, 0.0, reachable=True) == []  # not yet time
    sent = recorder.due(13.0, 0.0, 0.0, reachable=True)
    assert [r.seq for r in sent] == [0, 1] and all(len(r.kinds) == 4 for r in sent)
    assert len(radio.pack(sent[0])) <= 5 * 4 + 100  # 5 bytes a cell and a fixed envelope
    recorder.ack([0, 1])
    assert [r.seq for r in recorder.due(16.0, 0.0, 0.0, reachable=True)] == [2, 3]
    together = [c for r in recorder.outbox.values() for c in r.cell_list()]
    assert len(together) == cells - 8


def test_a_map_report_round_trips_and_bad_ones_are_refused():
    cells = [(-3, 7, FREE), (32767, -32768, OBSTACLE), (0, 0, CRATER)]
    report = radio.MapReport.build(4, 1.0, 1.23456, -2.0, cells)
    back = radio.unpack(radio.pack(report))
    assert back == report and back.cell_list() == cells and back.x == 1.235
    with pytest.raises(ValueError, match="4 bytes a cell"):
        radio.MapReport(seq=0, cell_m=1.0, x=0, z=0, cells=b"\x00\x00", kinds=b"\x00")
    with pytest.raises(ValueError, match="outside"):
        radio.MapReport(seq=0, cell_m=1.0, x=0, z=0, cells=b"\x00" * 4, kinds=b"\x07")


# ---- the lander's side ----


def _map(width: int = 10, height: int = 8) -> mapping.TraverseMap:
    return mapping.TraverseMap(mapping.GridSpec(95.0, 197.0, 1.0, width, height), (100.0, 200.0))


def test_the_lander_folds_reports_in_map_coordinates_with_obstacles_over_free():
    grid = _map()
    first = radio.MapReport.build(0, 1.0, 0.5, 0.5, [(0, 0, FREE), (1, 0, FREE), (1, 0, OBSTACLE), (2, 1, CRATER)])
    assert grid.fold(3, first)
    assert not grid.fold(3, first)  # a resend whose ack was lost
    grid.fold(3, radio.MapReport.build(1, 1.0, 2.5, 1.5, [(1, 0, FREE), (99, 0, OBSTACLE)]))
    classes = grid.classes()
    # lander (100, 200) is column 5, row 3 of a grid starting at (95, 197)
    assert classes[3, 6] == mapping.OBSTACLE and classes[4, 7] == mapping.ROVER  # rover now at (102.5, 201.5)
    assert classes[3, 5] == mapping.FREE and classes[4, 5] == mapping.UNKNOWN
    assert np.count_nonzero(classes) == 3 and grid.cells_outside == 1
    grid.fold(3, radio.MapReport.build(2, 1.0, 0.0, 0.0, []))
    assert grid.classes()[4, 7] == mapping.CRATER  # the rover moved on: what it reported there shows again


def test_the_published_map_decodes_to_the_same_grid():
    grid = _map()
    grid.fold(1, radio.MapReport.build(0, 1.0, 0.0, 0.0, [(1, 1, OBSTACLE)]))
    msg = codec.decode(type(grid.to_message(5.0)), codec.encode(grid.to_message(5.0)))
    spec, classes = mapping.from_message(msg)
    assert spec == grid.spec and np.array_equal(classes, grid.classes()) and msg.classes == list(mapping.CLASSES)
    with pytest.raises(ValueError, match="10 x 8"):
        mapping.from_message(msgspec.structs.replace(msg, cells=zlib.compress(b"short")))


def test_map_files_hold_the_grid_and_a_north_up_picture(tmp_path):
    grid = _map()
    grid.fold(1, radio.MapReport.build(0, 1.0, 0.0, 0.0, [(-5, 4, OBSTACLE)]))  # top-left cell of the grid
    grid.save(tmp_path)
    spec, classes = mapping.load(tmp_path / "map.npz")
    assert spec == grid.spec and np.array_equal(classes, grid.classes())
    picture = np.asarray(Image.open(io.BytesIO((tmp_path / "map.png").read_bytes())).convert("RGB"))
    scale = mapping.PNG_MIN_SIDE_PX // 10
    assert picture.shape[0] > 8 * scale and picture.shape[1:] == (10 * scale, 3)  # the map, a legend below it
    assert tuple(picture[0, 0]) == tuple(mapping.COLOURS[mapping.OBSTACLE])  # +z is up
    assert tuple(picture[8 * scale - 1, -1]) == tuple(mapping.COLOURS[mapping.UNKNOWN])
    legend = picture[8 * scale:]
    for colour in mapping.COLOURS:  # a swatch of every class's colour
        assert (legend == colour).all(axis=2).any(), colour
    (tmp_path / "bad.npz").write_bytes(b"nope")
    with pytest.raises(ValueError, match=r"bad\.npz"):
        mapping.load(tmp_path / "bad.npz")


# ---- truth ----


@pytest.fixture
def line_scenario():
    """From A (0, 10) straight to B (0, 50); a rock of 1 m radius at (0, 30) on the way, another far off."""
    return parse_scenario({"name": "line", "lander": {"x": 0.0, "z": 0.0}, "rovers": [{"x": 0.0, "z": 10.0}],
                           "mission": [{"x": 0.0, "z": 50.0}],
                           "obstacles": {"rocks": [{"x": 0.0, "z": 30.0, "radius_m": 1.0},
                                                   {"x": 20.0, "z": 20.0, "radius_m": 1.0}]}})


def test_truth_corridor_and_obstacles_on_a_known_geometry(line_scenario):
    spec = mapping.GridSpec.for_scenario(line_scenario, 1.0)
    lane = map_truth.corridor(line_scenario, spec, half_width_m=2.0)
    # 40 rows of 4 cells between z 10 and 50, and at each end a row of 4 then a row of 2 (round caps)
    assert lane.sum() == 40 * 4 + 2 * (4 + 2)
    truth = map_truth.truth_obstacles(line_scenario, spec)
    i, j, _ = spec.index(np.array([-0.5, 0.5]), np.array([29.5, 30.5]))
    rock = np.zeros_like(truth)
    rock[np.ix_(j, i)] = True
    lander = map_truth.truth_obstacles(line_scenario.model_copy(update={"obstacles": parse_scenario(
        {"name": "x", "lander": {"x": 0.0, "z": 0.0}, "rovers": [{"x": 0.0, "z": 0.0}],
         "mission": [{"x": 0.0, "z": 1.0}]}).obstacles}), spec)
    assert truth.sum() == 4 + 4 + lander.sum() and (truth & rock).sum() == 4  # 2 x 2 cells per 1 m rock


def test_map_figures_reward_a_right_map_and_punish_a_wrong_one(line_scenario):
    spec = mapping.GridSpec.for_scenario(line_scenario, 1.0)
    lane = map_truth.corridor(line_scenario, spec, half_width_m=2.0)
    truth = map_truth.truth_obstacles(line_scenario, spec) & lane
    right = np.where(lane, mapping.FREE, mapping.UNKNOWN).astype(np.uint8)
    right[truth] = mapping.OBSTACLE
    figures = map_truth.map_figures(line_scenario, spec, right, half_width_m=2.0)
    assert (figures.corridor_mapped, figures.obstacles_found, figures.obstacle_precision) == (1.0, 1.0, 1.0)
    assert figures.truth_obstacle_cells == 4 and figures.corridor_cells == 172
    nudged = np.roll(right, 1, axis=1)  # one cell east: within the tolerance
    assert map_truth.map_figures(line_scenario, spec, nudged, half_width_m=2.0).obstacles_found == 1.0
    half = right.copy()
    half[: spec.height // 2 + 20] = mapping.UNKNOWN  # the southern part, rock included, unknown
    assert map_truth.map_figures(line_scenario, spec, half, half_width_m=2.0).corridor_mapped < 0.5
    wrong = np.where(lane, mapping.FREE, mapping.UNKNOWN).astype(np.uint8)
    wrong[spec.index(np.array([0.0]), np.array([40.0]))[1], spec.index(np.array([0.0]), np.array([40.0]))[0]] = (
        mapping.OBSTACLE)
    bad = map_truth.map_figures(line_scenario, spec, wrong, half_width_m=2.0)
    assert (bad.obstacles_found, bad.obstacle_precision, bad.corridor_mapped) == (0.0, 0.0, 1.0)
    assert map_truth.map_figures(line_scenario, spec, np.zeros_like(right)).obstacle_precision is None
    with pytest.raises(ValueError, match="do not match"):
        map_truth.map_figures(line_scenario, spec, right[:-1])


# ---- a simulated mission ----


def _mission_figures(tmp_path: Path, name: str, max_sim_time: float, behaviour: str | None = None):
    scenario = load_scenario(SCENARIOS / f"{name}.yaml")
    world = run_mission(scenario, max_sim_time, behaviour=load_behaviour(behaviour) if behaviour else None,
                        map_folder=tmp_path)
    spec, classes = mapping.load(tmp_path / "map.npz")
    return world, map_truth.map_figures(scenario, spec, classes)


def test_the_crater_mission_maps_its_corridor_and_its_rocks(tmp_path):
    world, figures = _mission_figures(tmp_path, "crater_observation", 300.0)
    assert world.report().rovers_reached_final_goal == 5
    # five rovers abreast see the whole 20 m wide corridor and nearly every rock; precision depends on how far
    # each rover's dead reckoning drifted under the scenario's slip noise: 0.86 to 0.95 over seeds 1 to 3
    assert figures.corridor_mapped > 0.9, figures
    assert figures.obstacles_found > 0.8 and figures.obstacle_precision > 0.8, figures
    assert (tmp_path / "map.png").stat().st_size > 1000


def test_a_behaviour_that_explores_more_maps_more_of_the_maze(tmp_path):
    _, default = _mission_figures(tmp_path / "default", "maze", 400.0)
    _, straight = _mission_figures(tmp_path / "straight", "maze", 150.0, "straight")  # stuck at the first baffle
    assert default.corridor_mapped > straight.corridor_mapped + 0.2, (default, straight)
    assert default.obstacles_found > straight.obstacles_found, (default, straight)
    assert default.obstacle_precision > 0.9, default
