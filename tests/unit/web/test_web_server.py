"""The web view's server side without a browser: editor endpoints over real HTTP, message conversion, uploads
read in the worker process within the scenario limits.

The live path (Zenoh to the page, commands to the lander) is driven end to end in test_web_browser.py; who may use
the view (Host, Origin, token) in test_web_guard.py.
"""

from __future__ import annotations

import asyncio
import base64
import json
import zlib
from pathlib import Path

import msgspec
import numpy as np
import pytest
import yaml
from aiohttp.test_utils import TestClient, TestServer
from hostile import huge_lander_map
from procs import SCENARIOS

from lander_agent import mapping
from schemas import codec, radio
from schemas import messages as m
from schemas.scenario import Scenario, load_scenario
from schemas.scenario_limits import MAX_ROCK_FIELDS, MAX_ROCKS, MAX_SCENARIO_BYTES
from web import editor, live
from web.page_commands import CommandError, Commands, command_from_request
from web.scene import scenario_scene
from web.server import BUNDLE, Viewer, build_app
from web.uploads import MAX_REQUEST_BYTES

SCENARIO = SCENARIOS / "crater_observation.yaml"


def _unsent(command: m.GroundCommand) -> None:
    raise AssertionError(f"no command should reach Zenoh in these tests, got {command}")


def _viewer(tmp_path: Path, scenario: Scenario | None = None) -> Viewer:
    return Viewer("test", live.Latest(), Commands(_unsent), editor.Workspace(tmp_path / "ws"),
                  editor.Launcher(tmp_path / "runs", "tcp/127.0.0.1:1", "test"), scenario)


def _call(tmp_path: Path, requests: list[tuple[str, str, dict | None]]) -> list[tuple[int, dict]]:
    """Serve a viewer (no Zenoh) on a real loopback port and make the requests in order."""
    viewer = _viewer(tmp_path)

    async def go() -> list[tuple[int, dict]]:
        async with TestClient(TestServer(build_app(viewer))) as client:
            out = []
            for method, path, body in requests:
                res = await client.request(method, path, json=body)
                out.append((res.status, await res.json()))
            return out

    return asyncio.run(go())


def _page_scenario() -> dict:
    return load_scenario(SCENARIO).model_dump(mode="json")


def test_validate_accepts_a_scenario_and_names_the_bad_field(tmp_path: Path):
    bad = _page_scenario()
    bad["craters"][0]["radius_mm"] = bad["craters"][0].pop("radius_m")
    (ok_status, ok), (bad_status, err), (_, scene) = _call(tmp_path, [
        ("POST", "/api/scenario/validate", {"scenario": _page_scenario(), "scene": True}),
        ("POST", "/api/scenario/validate", {"scenario": bad}),
        ("POST", "/api/scenario/validate", {"scenario": "name: x\nlander: {x: 0, z: 0}\n"}),
    ])
    assert ok_status == 200 and ok["ok"] and ok["scenario"]["name"] == "crater_observation"
    assert ok["scene"]["terrain"]["nx"] > 10 and len(ok["scene"]["rocks"]) == 9
    assert bad_status == 400 and "craters.0.radius_mm: unknown field (did you mean 'radius_m'?)" in err["error"]
    assert not scene["ok"] and "rovers" in scene["error"]


def test_save_list_load_round_trip_writes_scenario_yaml(tmp_path: Path):
    sc = _page_scenario()
    sc["name"] = "edited"
    sc["lander"]["x"] = -555.5
    results = _call(tmp_path, [
        ("POST", "/api/scenario/save", {"name": "edited", "scenario": sc}),
        ("GET", "/api/scenario/list", None),
        ("GET", "/api/scenario/load?name=edited", None),
        ("POST", "/api/scenario/save", {"name": "../escape", "scenario": sc}),
        ("GET", "/api/scenario/load?name=missing", None),
    ])
    (_, saved), (_, listing), (_, loaded), (esc_status, esc), (miss_status, miss) = results
    path = Path(saved["path"])
    assert path == tmp_path / "ws" / "edited.yaml"
    assert yaml.safe_load(path.read_text())["lander"]["x"] == -555.5
    assert load_scenario(path).lander.x == -555.5  # the command line reads what the page wrote
    assert listing["names"] == ["edited"]
    assert loaded["scenario"]["lander"]["x"] == -555.5 and loaded["scenario"]["name"] == "edited"
    assert esc_status == 400 and "bad scenario file name" in esc["error"]
    assert miss_status == 404 and "no saved scenario 'missing.yaml'" in miss["error"]


def test_profile_export_then_import_keeps_lander_rovers_craters_and_goals(tmp_path: Path):
    (_, exported), = _call(tmp_path, [("POST", "/api/profile/export", {"scenario": _page_scenario()})])
    profile = exported["profile"]
    assert len(profile["roverDataObjects"]) == 5 and len(profile["missionDataObjects"]) == 1
    (_, imported), (bad_status, bad) = _call(tmp_path, [
        ("POST", "/api/profile/import", {"profile": profile, "name": "back"}),
        ("POST", "/api/profile/import", {"profile": {"roverDataObjects": []}, "name": "broken"}),
    ])
    sc = imported["scenario"]
    original = load_scenario(SCENARIO)
    assert sc["name"] == "back" and (sc["lander"]["x"], sc["lander"]["z"]) == (original.lander.x, original.lander.z)
    assert [(r["x"], r["z"]) for r in sc["rovers"]] == [(r.x, r.z) for r in original.rovers]
    assert sc["mission"][0]["kind"] == "crater"
    assert bad_status == 400 and "landerDataObject" in bad["error"]


def test_launch_refuses_an_invalid_scenario_and_starts_nothing(tmp_path: Path):
    sc = _page_scenario()
    sc["mission"] = []
    (status, body), (_, state) = _call(tmp_path, [("POST", "/api/scenario/launch", {"scenario": sc}),
                                                 ("GET", "/api/launch", None)])
    assert status == 400 and "mission" in body["error"]
    assert state == {"ok": True, "launched": False}


def test_command_requests_are_checked_like_the_command_line():
    cmd = command_from_request({"command": "set-target", "x": "-590", "z": -20, "kind": "crater", "rover_id": ""})
    assert (cmd.command, cmd.x, cmd.z, cmd.kind, cmd.rover_id) == ("set_target", -590.0, -20.0, "crater", None)
    assert command_from_request({"command": "stop", "rover_id": "3"}).rover_id == 3
    for bad, message in [({"command": "launch"}, "unknown command 'launch'"),
                         ({"command": "set-target", "x": 1}, "set-target needs x and z"),
                         ({"command": "return"}, "return needs a rover"),
                         ({"command": "stop", "rover_id": "two"}, "rover_id must be a number"),
                         ({"command": "set-target", "x": 1, "z": 2, "kind": "crate"}, "kind"),
                         ({"command": "set-target", "x": 1e12, "z": 2}, "x: Expected `float` <= 10000000")]:
        with pytest.raises(CommandError, match=message):
            command_from_request(bad)


def test_latest_keeps_only_the_newest_state_and_decodes_it():
    latest = live.Latest()
    truth = [m.RoverTruth(id=1, x=float(i), z=2.0, heading_deg=90.0, action="move", state="migration", goal_index=0,
                          distance_to_goal_m=10.0, distance_covered_m=float(i), alive=True) for i in range(3)]
    for i in range(3):
        latest.put("state", codec.encode(m.WorldState(stamp=float(i), rovers=[truth[i]], comm_links=[(0, 1)])))
    latest.put("stats", b"not msgpack")
    seen: dict = {}
    newer = latest.newer(seen)
    state = live.stream_message("state", newer["state"])
    assert state["stamp"] == 2.0 and state["rovers"][0]["x"] == 2.0 and state["links"] == [[0, 1]]
    assert live.stream_message("stats", newer["stats"]) is None
    assert latest.newer(seen) == {}  # nothing new since
    json.dumps(state)


def _lander_map() -> tuple[m.LanderMap, np.ndarray]:
    """The lander's map of polar_night_edge after one rover report: a rover cell, free ground and an obstacle."""
    scenario = load_scenario(SCENARIOS / "polar_night_edge.yaml")
    traverse = mapping.TraverseMap.for_scenario(scenario)
    cells = np.array([[0, 0], [1, 0], [2, 0], [5, 1]], "<i2")
    kinds = np.array([radio.MAP_KINDS.index(k) for k in ("free", "free", "free", "obstacle")], np.uint8)
    traverse.fold(1, radio.MapReport(seq=0, x=0.5, z=0.5, cell_m=traverse.spec.cell_m, cells=cells.tobytes(),
                                     kinds=kinds.tobytes()))
    return traverse.to_message(5.0), traverse.classes()


def test_the_lander_map_is_decoded_and_forwarded_compressed_with_counts_and_colours():
    msg, classes = _lander_map()
    latest = live.Latest()
    latest.put("map", codec.encode(msg))
    page = live.stream_message("map", latest.newer({})["map"])
    assert (page["width"], page["height"], page["cell_m"]) == (msg.width, msg.height, msg.cell_m)
    assert page["classes"] == list(mapping.CLASSES) and page["colours"][2] == mapping.COLOURS[2].tolist()
    assert zlib.decompress(base64.b64decode(page["cells"])) == classes.tobytes()
    counts = dict(zip(page["classes"], page["counts"], strict=True))
    assert counts["obstacle"] == 1 and counts["rover"] == 1 and counts["free"] >= 1
    assert sum(page["counts"]) == msg.width * msg.height
    json.dumps(page)
    torn = msgspec.structs.replace(msg, cells=zlib.compress(b"\x01" * 10))  # not width x height cells
    assert live.stream_message("map", codec.encode(torn)) is None


def test_a_map_past_the_viewers_bound_reaches_the_page_coarsened():
    page = live.stream_message("map", huge_lander_map(4096, 2048))
    assert (page["width"], page["height"], page["cell_m"]) == (2048, 1024, 2.0)
    assert page["counts"][2] == 1 and sum(page["counts"]) == 2048 * 1024
    assert zlib.decompress(base64.b64decode(page["cells"]))[:2] == b"\x02\x01"


def test_the_photos_kept_for_the_page_stay_within_their_bytes_the_first_to_arrive_let_go_first(monkeypatch):
    monkeypatch.setattr(live, "PHOTO_BYTES_KEPT", 1000)
    latest, seen = live.Latest(), {}
    assert not latest.put_photo(1, bytes(1001)) and latest.photos_dropped == 1  # alone over the bound: not kept
    for rover in range(1, 6):
        assert latest.put_photo(rover, bytes(300))
    assert set(latest.newer_photos(seen)) == {3, 4, 5} and latest.photo_bytes == 900
    latest.put_photo(3, bytes(250))  # rover 3's newer photo: now the last to have arrived
    latest.put_photo(1, bytes(300))  # back, and rover 4 let go for it
    assert set(latest.photos) == {5, 3, 1} and latest.photo_bytes == 850
    assert set(latest.newer_photos(seen)) == {1, 3}  # rover 1 came back: the page gets it again


def test_power_fields_reach_the_page_only_when_the_scenario_has_a_sun():
    common = dict(id=1, x=0.0, z=0.0, heading_deg=90.0, action="move", state="migration", goal_index=0,
                  distance_to_goal_m=10.0, distance_covered_m=1.0, alive=True)
    powered = m.RoverTruth(**common, battery_wh=0.0125, temperature_c=-12.345, sunlit=False, energy_used_wh=0.002,
                           powered=True)
    state = live.state_json(m.WorldState(stamp=1.0, rovers=[powered, m.RoverTruth(**{**common, "id": 2})]))
    with_sun, without = state["rovers"]
    assert with_sun["battery_wh"] == 0.0125 and with_sun["temperature_c"] == -12.35
    assert with_sun["sunlit"] is False and with_sun["powered"] is True and with_sun["energy_used_wh"] == 0.002
    assert "battery_wh" not in without and "sunlit" not in without
    report = m.MissionReport(scenario="s", seed=0, relative_path_length_m=1.0, average_distance_covered_m=1.0,
                             average_path_efficiency=1.0, total_distance_covered_m=1.0, rovers_reached_final_goal=0,
                             rovers_total=1, rover_collisions=0, obstacle_collisions=0, rovers_stuck=0,
                             mission_duration_s=1.0, power_budget_efficiency=0.5, power_shutdowns=1, cold_shutdowns=0)
    stats = codec.decode(m.WorldStats, codec.encode(m.WorldStats(stamp=1.0, report=report)))
    assert live.stats_json(stats)["report"]["power_budget_efficiency"] == 0.5
    assert live.stats_json(stats)["report"]["power_shutdowns"] == 1


def test_the_scene_carries_the_sun_and_battery_capacity_of_a_sunlit_scenario():
    polar = scenario_scene(load_scenario(SCENARIOS / "polar_night_edge.yaml"), cells=24)
    assert polar["power"] == {"capacity_wh": 0.05}
    assert 0 < polar["sun"]["elevation_deg"] < 5  # the low polar sun of the scenario's comment
    plain = scenario_scene(load_scenario(SCENARIO), cells=24)
    assert plain["sun"] is None and plain["power"] is None


def test_a_post_that_is_not_json_is_refused_before_it_does_anything(tmp_path: Path):
    """A cross-site form can send text/plain without the browser asking the server first: it must do nothing."""
    viewer = _viewer(tmp_path)

    async def go() -> list[tuple[int, dict]]:
        async with TestClient(TestServer(build_app(viewer))) as client:
            out = []
            for path in ("/api/command", "/api/scenario/launch", "/api/scenario/save", "/api/launch/stop"):
                res = await client.post(path, data=json.dumps({"command": "stop", "rover_id": 1}),
                                        headers={"Content-Type": "text/plain"})
                out.append((res.status, await res.json()))
            return out

    for status, body in asyncio.run(go()):
        assert status == 415 and "application/json" in body["error"]
    assert not (tmp_path / "ws").exists() or not any((tmp_path / "ws").iterdir())
    assert not (tmp_path / "runs").exists()


def _get(viewer: Viewer, paths: list[str]) -> list[tuple[int, str, str]]:
    """GET each path from a served viewer: (status, content type, body text)."""
    async def go() -> list[tuple[int, str, str]]:
        async with TestClient(TestServer(build_app(viewer))) as client:
            out = []
            for path in paths:
                res = await client.get(path)
                out.append((res.status, res.content_type, await res.text()))
            return out

    return asyncio.run(go())


@pytest.mark.skipif(not BUNDLE.is_file(), reason="the front end is not built (npm run build in web/frontend)")
def test_each_tab_has_its_own_url_and_the_favicon_is_served(tmp_path: Path):
    """/live and /editor serve the page (it opens the tab its path names), so a tab survives a reload."""
    (root, live_tab, editor_tab, icon, missing) = _get(_viewer(tmp_path), ["/", "/live", "/editor", "/favicon.ico",
                                                                          "/editors"])
    for status, kind, body in (root, live_tab, editor_tab):
        assert status == 200 and kind == "text/html" and "/static/bundle.js" in body
        assert 'rel="icon"' in body
    assert icon[0] == 200 and icon[1] == "image/svg+xml" and icon[2].startswith("<svg")
    assert missing[0] == 404


def test_the_editor_is_given_the_scenario_the_view_shows(tmp_path: Path):
    """``lunarsim view --scenario FILE``: the editor opens FILE's scenario; without one, nothing (a blank)."""
    scenario = load_scenario(SCENARIO)
    ((status, _, body),) = _get(_viewer(tmp_path, scenario), ["/api/scenario/current"])
    given = json.loads(body)["scenario"]
    assert status == 200 and given["name"] == "crater_observation" and len(given["rovers"]) == 5
    assert given["mission"][0]["x"] == scenario.mission[0].x
    ((_, _, body),) = _get(_viewer(tmp_path), ["/api/scenario/current"])
    assert json.loads(body) == {"ok": True, "scenario": None}


def test_the_scene_names_the_spawns_the_camera_frames_at_the_start():
    scene = scenario_scene(load_scenario(SCENARIO), cells=24)
    assert scene["spawns"][0] == {"x": -510.0, "z": 100.0} and len(scene["spawns"]) == 5


def test_hello_says_how_old_the_last_world_state_is(tmp_path: Path):
    """A page that joins after the world stopped learns it from the state's age, without waiting for a silence."""
    viewer = _viewer(tmp_path)

    async def hello() -> dict:
        async with TestClient(TestServer(build_app(viewer))) as client, client.ws_connect("/ws") as ws:
            return json.loads((await ws.receive()).data)

    assert asyncio.run(hello())["state_age_s"] is None
    state = m.WorldState(stamp=1.0, rovers=[])
    viewer.latest.put("state", codec.encode(state))
    viewer.latest.arrived["state"] -= 30.0  # as if the world went quiet half a minute ago
    age = asyncio.run(hello())["state_age_s"]
    assert 30.0 <= age < 40.0
    viewer.latest.forget()  # a new run: the old state's age no longer says anything
    assert asyncio.run(hello())["state_age_s"] is None


def _rocky(rocks: int, scattered: int) -> dict:
    """The crater scenario with ``rocks`` more rocks placed in rows beside its lander and a rock field of
    ``scattered``."""
    sc = _page_scenario()
    x, z = sc["lander"]["x"], sc["lander"]["z"]
    sc["obstacles"]["rocks"] = [{"x": x + 5 + i % 200 * 0.5, "z": z + i // 200 * 0.5, "radius_m": 0.2}
                                for i in range(rocks)]
    sc["obstacles"]["rock_fields"] = [{"x": x - 60, "z": z, "radius_m": 50, "count": scattered}]
    return sc


def test_a_large_upload_is_validated_in_the_worker_while_the_view_answers_others(tmp_path: Path):
    """Nearly the largest scenario file, its rock field filling the rock bound: parsed, validated and drawn in the
    worker process while /api/info answers, saying so by counting the job it is running."""
    listed = int(MAX_SCENARIO_BYTES * 0.9 / 45)  # a placed rock takes about 45 bytes
    text = json.dumps(_rocky(listed, MAX_ROCKS - listed))  # JSON is YAML: the page's YAML-text path
    assert MAX_SCENARIO_BYTES * 0.8 < len(text) < MAX_SCENARIO_BYTES

    async def go() -> tuple[list[dict], int, dict]:
        async with TestClient(TestServer(build_app(_viewer(tmp_path)))) as client:
            warm = await client.post("/api/scenario/validate", json={"scenario": _page_scenario()})
            assert warm.status == 200  # the worker process has started
            upload = asyncio.create_task(client.post("/api/scenario/validate", json={"scenario": text,
                                                                                   "scene": True}))
            meanwhile: list[dict] = []
            deadline = asyncio.get_running_loop().time() + 120
            while not upload.done() and asyncio.get_running_loop().time() < deadline:
                res = await client.get("/api/info")
                info = await res.json()
                if res.status == 200 and info["validating"] and not upload.done():
                    meanwhile.append(info)
                await asyncio.sleep(0.01)
            res = await upload
            return meanwhile, res.status, await res.json()

    meanwhile, status, body = asyncio.run(go())
    assert meanwhile, "/api/info never answered while the upload was in the worker"
    assert all(info["validating"] == 1 for info in meanwhile)
    assert status == 200 and body["ok"] and f"{listed} rocks" in body["summary"]
    assert len(body["scenario"]["obstacles"]["rocks"]) == listed and len(body["scene"]["rocks"]) == MAX_ROCKS


def test_uploads_beyond_the_scenario_limits_are_refused_with_a_short_error(tmp_path: Path):
    aliases = "a: &a [x, x, x, x, x, x, x, x, x, x]\n" + "".join(
        f"{b}: &{b} [{', '.join([f'*{a}'] * 10)}]\n" for a, b in zip("abcdefg", "bcdefgh", strict=True))
    fields = _page_scenario()  # 1,000 rock fields of 100,000 rocks each: a few kB of JSON, 10**8 rocks to draw
    fields["obstacles"]["rock_fields"] = [{"x": fields["lander"]["x"], "z": fields["lander"]["z"], "radius_m": 80,
                                           "count": MAX_ROCKS}] * MAX_ROCK_FIELDS

    async def go() -> list[tuple[int, dict]]:
        async with TestClient(TestServer(build_app(_viewer(tmp_path)))) as client:
            out = []
            for body in ({"scenario": "x" * MAX_REQUEST_BYTES}, {"scenario": "name: x\n#" + "x" * MAX_SCENARIO_BYTES},
                         {"scenario": aliases}, {"scenario": fields, "scene": True}):
                res = await client.post("/api/scenario/validate", json=body)
                out.append((res.status, await res.json()))
            res = await client.post("/api/scenario/validate", data=b"{not json",
                                    headers={"Content-Type": "application/json"})
            out.append((res.status, await res.json()))
            return out

    (big, big_err), (text, text_err), (bomb, bomb_err), (many, many_err), (broken, broken_err) = asyncio.run(go())
    assert big == 413 and f"larger than the {MAX_REQUEST_BYTES / 1024**2:g} MiB" in big_err["error"]
    assert text == 400 and f"larger than the {MAX_SCENARIO_BYTES / 1024**2:g} MiB a scenario file" in text_err["error"]
    assert bomb == 400 and "aliases expand it to more than" in bomb_err["error"]
    assert len(bomb_err["error"]) < 200 and len(big_err["error"]) < 200
    assert many == 400 and f"at most {MAX_ROCKS:,}" in many_err["error"] and "scene" not in many_err
    assert broken == 400 and broken_err["error"] == "request body is not JSON"


def test_two_launches_within_a_second_get_two_run_folders(tmp_path):
    """``lunarsim run`` refuses a folder that holds a run: a relaunch within the same second needs its own."""
    import datetime as dt

    now = dt.datetime(2026, 11, 29, 20, 4, 12)
    folders = []
    for _ in range(3):
        folders.append(editor.run_folder(tmp_path, "crater", now))
        folders[-1].mkdir()
    assert [f.name for f in folders] == ["crater-web-20261129-200412", "crater-web-20261129-200412-2",
                                         "crater-web-20261129-200412-3"]
