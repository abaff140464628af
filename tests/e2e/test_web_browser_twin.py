"""The web twin's first-hour rough edges, each checked in a real headless Chromium.

The editor opens the scenario ``lunarsim view --scenario`` was given; each tab has its own URL and survives a
reload; the 3D view starts framed on the mission with a scale bar and the report's axes; the editor's labels do
not overlap; the header says when the run ended or the world went silent; no request 404s (the favicon);
statistics carry the decimals a reader needs; goals are numbered from 1 wherever a person reads them.
"""

from __future__ import annotations

import json
import math
import re

import msgspec
import pytest
import zenoh
from procs import SCENARIOS, lunarsim, stop, wait_for
from test_web_browser import page_value, shot, start_view

from bus.zenoh_config import build_config
from schemas import codec
from schemas import messages as m
from schemas.keyspace import Keyspace
from schemas.scenario import load_scenario

pytestmark = pytest.mark.e2e

CRATER = SCENARIOS / "crater_observation.yaml"


def watched_page(context):
    """A page that records script errors and every answer of 400 or more (a favicon 404 among them)."""
    page = context.new_page()
    page.errors, page.failed = [], []
    page.on("pageerror", lambda e: page.errors.append(str(e)))
    page.on("response", lambda r: page.failed.append(f"{r.status} {r.url}") if r.status >= 400 else None)
    return page


def overlapping(boxes: list[dict]) -> list[tuple[str, str]]:
    return [(a["text"], b["text"]) for i, a in enumerate(boxes) for b in boxes[i + 1:]
            if a["x"] < b["x"] + b["w"] and b["x"] < a["x"] + a["w"] and a["y"] < b["y"] + b["h"]
            and b["y"] < a["y"] + a["h"]]


def assert_nice_scale(scale: dict, max_px: float) -> None:
    """A scale bar of 1, 2 or 5 times a power of ten metres, between 40% and 100% of its longest."""
    mantissa = scale["metres"] / 10 ** math.floor(math.log10(scale["metres"]))
    assert round(mantissa, 6) in (1, 2, 5), scale
    assert 0.39 * max_px <= scale["px"] <= max_px + 1, scale


def test_editor_opens_the_given_scenario_on_its_own_url_with_labels_apart(router, tmp_path, browser):
    view, url = start_view(router, "webtabs", tmp_path, "--scenario", str(CRATER))
    try:
        page = watched_page(browser)
        page.goto(url + "editor")
        wait_for(lambda: page_value(page, "lunarsim.editor.scenario.name") == "crater_observation", 15,
                 "the editor to open the --scenario given to the view")
        assert page_value(page, "lunarsim.editor.scenario.rovers.length") == 5
        assert page_value(page, "lunarsim.tab") == "editor" and page.is_visible("#map")
        assert "crater_observation" in page.inner_text("#ed-status")
        assert page.input_value("#ed-name") == "crater_observation"
        labels = page_value(page, "lunarsim.editor.labels")
        texts = " | ".join(label["text"] for label in labels)
        assert "crater 1" in texts and "goal 1" in texts and "lander" in texts, texts
        assert "crater 0" not in texts and "goal 0" not in texts, texts
        assert not overlapping(labels), overlapping(labels)
        assert page.inner_text("#ed-goals .item").startswith("goal 1")
        assert_nice_scale(page_value(page, "lunarsim.editor.scaleBar"), 140)
        shot(page, "editor_given_scenario")

        # A second crater put right on the goal: three labels at one place, still apart (merged into one).
        box = page.locator("#map").bounding_box()
        goal = load_scenario(CRATER).mission[0]
        sx, sy = page.evaluate(f"lunarsim.editor.toScreen({goal.x}, {goal.z})")
        page.check("input[name=tool][value=crater]")
        page.mouse.click(box["x"] + sx, box["y"] + sy)
        wait_for(lambda: page_value(page, "lunarsim.editor.scenario.craters.length") == 2, 5, "the second crater")
        labels = page_value(page, "lunarsim.editor.labels")
        texts = " | ".join(label["text"] for label in labels)
        assert "crater 2" in texts and "goal 1" in texts and not overlapping(labels), (texts, overlapping(labels))
        shot(page, "editor_labels_apart")

        page.reload()
        wait_for(lambda: page_value(page, "lunarsim.tab") == "editor", 10, "the editor tab after a reload")
        assert page.url.endswith("/editor") and page.is_visible("#map") and not page.is_visible("#view3d")
        page.click("#tab-live")
        assert page.url.endswith("/live") and page.is_visible("#view3d")
        assert page.title() == "LunarSim: live view"
        page.go_back()
        wait_for(lambda: page_value(page, "lunarsim.tab") == "editor", 5, "back to the editor")
        assert page.url.endswith("/editor")
        icon = page.request.get(url + "favicon.ico")
        assert icon.status == 200 and icon.headers["content-type"] == "image/svg+xml"
        assert not page.failed, page.failed
        assert not page.errors, page.errors
    finally:
        stop(view)


def test_live_view_starts_framed_on_the_mission_with_a_scale_bar_and_axes(router, tmp_path, browser):
    view, url = start_view(router, "webframe", tmp_path, "--scenario", str(CRATER))
    try:
        page = watched_page(browser)
        page.goto(url)
        wait_for(lambda: page_value(page, "lunarsim.view.framed"), 15, "the view framed on the mission")
        wait_for(lambda: page_value(page, "lunarsim.view.overlay.scale"), 10, "the scale bar")
        size = page.locator("#view3d").bounding_box()
        scenario = load_scenario(CRATER)
        points = [(scenario.lander.x, scenario.lander.z), *((r.x, r.z) for r in scenario.rovers),
                  *((g.x, g.z) for g in scenario.mission)]
        screen = [page.evaluate(f"lunarsim.view.screenOf({x}, {z})") for x, z in points]
        for (x, z), (sx, sy) in zip(points, screen, strict=True):
            assert 0 <= sx <= size["width"] and 0 <= sy <= size["height"], (x, z, sx, sy, size)
        spread = (max(s[0] for s in screen) - min(s[0] for s in screen),
                  max(s[1] for s in screen) - min(s[1] for s in screen))
        assert spread[0] > 0.3 * size["width"] or spread[1] > 0.3 * size["height"], (spread, size)
        rover = scenario.rovers[0]
        ends = [page.evaluate(f"lunarsim.view.screenOf({x}, {rover.z})") for x in (rover.x, rover.x + 2.8)]
        length = math.dist(*ends)
        assert length >= 8, f"a rover (2.8 m drawn) is {length:.1f} px long: a speck"

        scale = page_value(page, "lunarsim.view.overlay.scale")
        assert_nice_scale(scale, 150)
        assert page.inner_text("#scalebar") == (f"{scale['metres']:g} m" if scale["metres"] < 1000
                                                else f"{scale['metres'] / 1000:g} km")
        target = page_value(page, "[lunarsim.view.controls.target.x, -lunarsim.view.controls.target.z]")
        ends = [page.evaluate(f"lunarsim.view.screenOf({target[0] + d * scale['metres'] / 2}, {target[1]})")
                for d in (-1, 1)]
        assert abs(math.dist(*ends) - scale["px"]) < 0.15 * scale["px"], (ends, scale)
        compass = page_value(page, "lunarsim.view.overlay.compass")
        assert compass["x"][0] > 0.9 and abs(compass["x"][1]) < 0.2, compass  # +x to the right
        assert compass["z"][1] < -0.5 and abs(compass["z"][0]) < 0.3, compass  # +z forward: up the screen
        assert page.is_visible("#compass") and page.is_visible("#frame-view")
        shot(page, "live_view_framed")

        page.mouse.move(size["x"] + size["width"] / 2, size["y"] + size["height"] / 2)
        page.mouse.wheel(0, 1500)  # zoom out: the bar follows
        wait_for(lambda: page_value(page, "lunarsim.view.overlay.scale.metres") > scale["metres"], 5,
                 "a longer scale bar after zooming out")
        page.click("#frame-view")
        wait_for(lambda: page_value(page, "lunarsim.view.overlay.scale") == scale, 5, "the framing again")
        assert not page.failed, page.failed
        assert not page.errors, page.errors
    finally:
        stop(view)


def _publish(session: zenoh.Session, key: str, message) -> None:
    session.put(key, codec.encode(message))


def _rover(stamp: float) -> m.RoverTruth:
    return m.RoverTruth(id=1, x=stamp, z=2.0, heading_deg=0.0, action="move", state="migration", goal_index=0,
                        distance_to_goal_m=10.0, distance_covered_m=stamp, alive=True)


def test_the_header_says_when_the_world_goes_silent_or_the_run_ends(router, tmp_path, browser):
    """The viewer stays connected after the world stops: the header must not go on saying so in green."""
    world = "websilent"
    keys = Keyspace(world)
    view, url = start_view(router, world, tmp_path)
    try:
        page = watched_page(browser)
        page.goto(url)
        wait_for(lambda: page_value(page, "lunarsim.run.status") == "waiting", 10, "waiting for a world")
        with zenoh.open(build_config(connect=[router])) as session:
            for i in range(40):  # a world publishing its state, until the page shows it live
                _publish(session, keys.state, m.WorldState(stamp=0.1 * i, rovers=[_rover(0.1 * i)]))
                if page_value(page, "lunarsim.run.status") == "live":
                    break
                page.wait_for_timeout(100)
            assert page_value(page, "lunarsim.run.status") == "live"
            assert page.inner_text("#conn") == "live" and page.get_attribute("#conn", "class") == "ok"
            assert page.inner_text("#rovers td[data-field=goal]") == "1"  # goal_index 0 is the first goal
            last = msgspec.structs.replace(_rover(4.0), goal_index=1)  # inside the table's redraw period, then quiet
            _publish(session, keys.state, m.WorldState(stamp=4.0, rovers=[last]))
            wait_for(lambda: page.inner_text("#rovers td[data-field=goal]") == "2", 5, "the last state in the table")
            wait_for(lambda: page_value(page, "lunarsim.run.status") == "silent", 10, "the silence noticed")
            assert page.inner_text("#conn") == "world silent" and "no world state for" in page.inner_text("#runinfo")
            shot(page, "header_world_silent")

            late = watched_page(browser)  # a page opened after the world went quiet knows at once
            late.goto(url)
            wait_for(lambda: page_value(late, "lunarsim.run.status") == "silent", 3, "the late page to see silence")

            report = m.MissionReport(
                scenario="s", seed=0, relative_path_length_m=123.456, average_distance_covered_m=98.7654,
                average_path_efficiency=0.87654, total_distance_covered_m=493.827, rovers_reached_final_goal=1,
                rovers_total=1, rover_collisions=0, obstacle_collisions=0, rovers_stuck=0, mission_duration_s=64.321,
                worst_rover_connected_fraction=0.97345, complete=True)
            _publish(session, keys.stats, m.WorldStats(stamp=64.321, report=report, final=True))
            wait_for(lambda: page_value(page, "lunarsim.run.status") == "ended", 10, "the run's end on the page")
            assert page.inner_text("#conn") == "run ended" and "connected" not in page.inner_text("header")
            assert "1/1 rovers reached their final goal; mission complete" in page.inner_text("#runinfo")
            assert "final, at t = 64.3 s" in page.inner_text("#stats-when")
            cell = lambda field: page.inner_text(f"#simstats td[data-field={field}]")  # noqa: E731
            assert (cell("relative_path_length_m"), cell("average_distance_covered_m")) == ("123.5", "98.8")
            assert (cell("average_path_efficiency"), cell("worst_rover_connected_fraction")) == ("0.88", "97.3%")
            assert (cell("rovers_reached_final_goal"), cell("rover_collisions"), cell("complete")) == ("1", "0", "yes")
            assert cell("mission_duration_s") == "64.3"
            short = msgspec.structs.replace(report, average_path_efficiency=1.5234, rovers_holding_relay_spots=2,
                        reached_path_efficiency=None, rovers_reached_final_goal=0)
            _publish(session, keys.stats, m.WorldStats(stamp=65.0, report=short, final=True))
            wait_for(lambda: "above 1" in cell("average_path_efficiency"), 10, "the note on an efficiency above 1")
            assert cell("average_path_efficiency") == "1.52 (above 1: rovers stopped short)"
            assert (cell("reached_path_efficiency"), cell("rovers_holding_relay_spots")) == ("–", "2")
        shot(page, "header_run_ended")
        assert not page.failed and not late.failed, (page.failed, late.failed)
        assert not page.errors, page.errors
    finally:
        stop(view)


def test_a_real_run_ends_on_the_page_with_photos_and_goals_numbered_from_one(router, tmp_path, browser):
    """crater_observation to its end: photos named goal1_*, the end and its statistics on the page."""
    world, out = "webend", tmp_path / "run"
    view, url = start_view(router, world, tmp_path, "--scenario", str(CRATER))
    page = watched_page(browser)
    page.goto(url)
    run = lunarsim("run", str(CRATER), "--connect", router, "--world", world, "--time-scale", "5",
                   "--max-sim-time", "300", "--quiet", "--no-record", "--out", str(out))
    try:
        wait_for(lambda: page_value(page, "lunarsim.run.status") == "live", 60, "the run live on the page")
        goals = page.locator("#rovers td[data-field=goal]")
        wait_for(lambda: goals.all_inner_texts() == ["1"] * 5, 30, "every rover on goal 1 (goal_index 0)")
        wait_for(lambda: page.locator("#photos figcaption").count() > 0, 150, "a crater photo on the page")
        assert re.search(r"goal1_\d{3}\.\ddeg", page.inner_text("#photos")), page.inner_text("#photos")
        wait_for(lambda: page_value(page, "lunarsim.run.status") == "ended", 150, "the run's end on the page")
        run.communicate(timeout=60)
        assert page.inner_text("#conn") == "run ended"
        assert "5/5 rovers reached their final goal; mission complete" in page.inner_text("#runinfo")
        for field in ("relative_path_length_m", "average_distance_covered_m", "mission_duration_s"):
            assert re.fullmatch(r"\d+\.\d", page.inner_text(f"#simstats td[data-field={field}]")), field
        for field in ("rovers_reached_final_goal", "rover_collisions", "radio_lost"):
            assert re.fullmatch(r"\d+", page.inner_text(f"#simstats td[data-field={field}]")), field
        shot(page, "live_view_run_ended")
        index = [json.loads(line) for line in (out / "lander_archive" / "index.jsonl").read_text().splitlines()]
        rover1 = [entry for entry in index if entry["rover"] == 1]
        assert rover1 and all(entry["label"].startswith("goal1_") for entry in rover1), rover1
        assert all((out / "lander_archive" / entry["file"]).is_file() for entry in rover1)
        assert not page.failed, page.failed
        assert not page.errors, page.errors
    finally:
        stop(run, view)


def _frames_once_quiet(page, quiet_ms: int = 500, timeout: float = 10) -> int:
    """The page's count of drawn frames once it has drawn none for ``quiet_ms``."""
    seen = {}

    def quiet() -> bool:
        before = page_value(page, "lunarsim.frames")
        page.wait_for_timeout(quiet_ms)
        seen["frames"] = page_value(page, "lunarsim.frames")
        return seen["frames"] == before

    wait_for(quiet, timeout, f"the page to draw nothing for {quiet_ms} ms")
    return seen["frames"]


def test_the_view_draws_while_rovers_move_and_nothing_while_the_world_is_quiet(router, tmp_path, browser):
    """Software WebGL takes a core's worth of milliseconds a frame: a page on a quiet world must not keep drawing
    the same picture, and must draw again for a new state or a camera move."""
    world = "webidle"
    keys = Keyspace(world)
    view, url = start_view(router, world, tmp_path, "--scenario", str(CRATER))
    try:
        page = watched_page(browser)
        page.goto(url)
        wait_for(lambda: page_value(page, "lunarsim.view.framed"), 15, "the view framed on the mission")
        idle = _frames_once_quiet(page)
        assert idle >= 1, "the scene was never drawn"
        wait_for(lambda: page.inner_text("#fps") == "idle: nothing moved", 5, "the header to say the view is idle")

        with zenoh.open(build_config(connect=[router])) as session:
            for i in range(10):  # a second of a rover driving, at the view's stream rate
                _publish(session, keys.state, m.WorldState(stamp=0.1 * i, rovers=[_rover(0.1 * i)]))
                page.wait_for_timeout(100)
            wait_for(lambda: page_value(page, "lunarsim.states") >= 5, 5, "the states on the page")
            moving = _frames_once_quiet(page)
        # How many frames a second of states gets is the machine's frame rate (software WebGL on a loaded core
        # drew 4): more than one says the drawing followed the states, not one last frame after them.
        assert moving >= idle + 2, (idle, moving)
        assert page_value(page, "lunarsim.view.drawnEase") == 1, "the last frame left the rover short of its state"

        size = page.locator("#view3d").bounding_box()
        page.mouse.move(size["x"] + size["width"] / 2, size["y"] + size["height"] / 2)
        page.mouse.wheel(0, 600)
        wait_for(lambda: page_value(page, "lunarsim.frames") > moving, 5, "a frame for the camera's move")
        assert not page.failed, page.failed
        assert not page.errors, page.errors
    finally:
        stop(view)
