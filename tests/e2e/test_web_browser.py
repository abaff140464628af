"""The web view driven in a real headless Chromium (Debian's ``chromium``, through Playwright).

A real router, a real ``lunarsim run`` and a real ``lunarsim view``: the page shows the rovers moving, a
command sent from it reaches the lander (whose answer comes back to the page), and a scenario built in the
editor is saved, reloaded, exported and imported as a profile, and launched. Screenshots go to
``artifacts/screenshots/`` at the repository root.
"""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import pytest
import yaml
from procs import REPO, SCENARIOS, free_port, lunarsim, processes_mentioning, stop, wait_for, wait_for_output

pytestmark = pytest.mark.e2e

CHROMIUM = shutil.which("chromium") or "/usr/bin/chromium"
CHROMIUM_ARGS = ["--headless", "--no-sandbox", "--disable-gpu", "--disable-quic", "--no-first-run",
                 "--disable-background-networking", "--disable-component-update", "--disable-sync",
                 "--enable-unsafe-swiftshader", "--use-angle=swiftshader"]
"""The machine's closed network needs the first ones; the last two give WebGL in software without a GPU."""
SHOTS = REPO / "artifacts" / "screenshots"


def browser_context(playwright, user_data: Path):
    """Debian's chromium with a fresh profile; no browser is ever downloaded."""
    if not Path(CHROMIUM).is_file():
        pytest.skip("Debian's chromium is not installed (apt-get install -y chromium; .ci/run does it)")
    return playwright.chromium.launch_persistent_context(
        str(user_data), executable_path=CHROMIUM, args=CHROMIUM_ARGS, headless=True,
        viewport={"width": 1400, "height": 850}, accept_downloads=True)


def shot(page, name: str) -> Path:
    SHOTS.mkdir(parents=True, exist_ok=True)
    path = SHOTS / f"{name}.png"
    page.screenshot(path=str(path))
    print(f"screenshot: {path}")
    return path


def start_view(router: str, world: str, tmp: Path, *extra: str):
    port = free_port()
    proc = lunarsim("view", "--connect", router, "--world", world, "--port", str(port), "--workspace",
                    str(tmp / "ws"), "--runs", str(tmp / "runs"), *extra)
    wait_for_output(proc, "serving world", 30)
    return proc, f"http://127.0.0.1:{port}/"


def page_value(page, expression: str):
    return page.evaluate(f"() => {{ try {{ return {expression}; }} catch (e) {{ return null; }} }}")


def positions(page) -> dict:
    return {r["id"]: (r["x"], r["z"]) for r in page_value(page, "lunarsim.state.rovers") or []}


def test_live_view_shows_rovers_moving_and_commands_reach_the_lander(router, tmp_path, browser):
    world = "webview"
    run = lunarsim("run", str(SCENARIOS / "crater_observation.yaml"), "--connect", router, "--world", world,
                   "--time-scale", "4", "--quiet", "--no-record", "--out", str(tmp_path / "run"))
    view, url = start_view(router, world, tmp_path, "--scenario", str(SCENARIOS / "crater_observation.yaml"))
    try:
        page = browser.new_page()
        errors: list[str] = []
        page.on("pageerror", lambda e: errors.append(str(e)))
        page.goto(url)
        wait_for(lambda: page_value(page, "lunarsim.scene.name") == "crater_observation", 15, "the scene on the page")
        wait_for(lambda: len(positions(page)) == 5, 60, "five rovers on the page")
        first = positions(page)
        wait_for(lambda: sum(p != first[i] for i, p in positions(page).items()) >= 3, 30, "the rovers to move")
        wait_for(lambda: page_value(page, "lunarsim.stats.report.rovers_total") == 5, 15, "statistics on the page")
        assert page.locator("#simstats td[data-field=average_path_efficiency]").count() == 1
        assert page.locator("#rovers tbody tr").count() == 5
        shot(page, "live_view")

        page.select_option("#cmd-rover", "2")
        page.click("#cmd-stop")
        result = wait_for(lambda: page_value(page, "lunarsim.lastCommand"), 20, "the lander's answer on the page")
        assert result["name"] == "stop" and result["accepted"] is True, result
        assert "2" in result["detail"]
        assert "accepted" in page.inner_text("#cmd-result")
        stopped = "lunarsim.state.rovers.find(r => r.id === 2).state"
        wait_for(lambda: page_value(page, stopped) == "stopped", 20, "rover 2 stopped, as the page shows")
        page.select_option("#cmd-rover", "")
        page.fill("#cmd-x", "")
        page.click("#cmd-set-target")
        wait_for(lambda: page_value(page, "lunarsim.lastCommand.error"), 10, "the page's error for a target without x")
        assert "set-target needs x and z" in page.inner_text("#cmd-result")
        shot(page, "live_view_command")
        assert not errors, errors
    finally:
        stop(view, run)


def test_a_map_too_long_for_one_texture_reaches_the_page_coarsened_and_drawn(router, tmp_path, browser):
    """A lander map of 40,000 x 60 cells (a long traverse): within the viewers' cells, but wider than any browser's
    texture. The page gets it in blocks of 10 cells and drapes it."""
    import zenoh
    from hostile import huge_lander_map

    from bus.zenoh_config import build_config
    from schemas.keyspace import MAP, Keyspace

    world = "webbigmap"
    view, url = start_view(router, world, tmp_path)
    session = zenoh.open(build_config(connect=[router]))
    try:
        page = browser.new_page()
        errors: list[str] = []
        page.on("pageerror", lambda e: errors.append(str(e)))
        page.goto(url)
        payload = huge_lander_map(40_000, 60)

        def shown() -> bool:
            session.put(Keyspace(world).lander(MAP), payload)  # again until the page has it: no history on the key
            return page_value(page, "lunarsim.map.width") == 4000

        wait_for(shown, 30, "the coarsened map on the page")
        drawn = page_value(page, "lunarsim.map")
        assert (drawn["height"], drawn["cell_m"], drawn["bytes"]) == (6, 10.0, 4000 * 6)
        assert page_value(page, "lunarsim.view.mapOverlay.mesh.visible") is True
        assert not errors, errors
    finally:
        session.close()
        stop(view)


def test_polar_run_shows_battery_columns_power_statistics_and_the_lander_map(router, tmp_path, browser):
    """polar_night_edge has a sun: battery, temperature and light per rover, and the lander maps the traverse."""
    world, scenario = "webpolar", str(SCENARIOS / "polar_night_edge.yaml")
    run = lunarsim("run", scenario, "--connect", router, "--world", world, "--time-scale", "5", "--quiet",
                   "--no-record", "--out", str(tmp_path / "run"))
    view, url = start_view(router, world, tmp_path, "--scenario", scenario)
    try:
        page = browser.new_page()
        errors: list[str] = []
        page.on("pageerror", lambda e: errors.append(str(e)))
        page.goto(url)
        wait_for(lambda: page_value(page, "lunarsim.scene.power.capacity_wh") == 0.05, 15, "the scene's battery")
        wait_for(lambda: page.locator("#rovers td[data-field=battery_pct]").count() == 1, 60, "the battery column")
        assert "Wh" in page.inner_text("#rovers thead") and "°C" in page.inner_text("#rovers thead")
        percent = int(page.inner_text("#rovers td[data-field=battery_pct]"))
        battery = page_value(page, "lunarsim.state.rovers[0].battery_wh")
        assert 0 <= percent <= 100 and battery is not None
        wait_for(lambda: (page_value(page, "lunarsim.map.counts[1]") or 0) > 0, 40, "a map with explored cells")
        shown = page_value(page, "lunarsim.map")
        assert shown["bytes"] == shown["width"] * shown["height"] and shown["classes"][2] == "obstacle"
        assert page_value(page, "lunarsim.view.mapOverlay.mesh.visible") is True
        assert page.is_visible("#maplegend") and "free" in page.inner_text("#map-classes")
        wait_for(lambda: page_value(page, "lunarsim.stats.report.energy_used_wh") is not None, 20, "power stats")
        assert page.locator("#simstats td[data-field=power_budget_efficiency]").count() == 1
        shot(page, "live_view_polar_map")
        page.uncheck("#map-show")
        assert page_value(page, "lunarsim.view.mapOverlay.mesh.visible") is False
        assert not errors, errors
    finally:
        stop(view, run)


def test_editor_scenario_saved_reloaded_profiled_and_launched(router, tmp_path, browser):
    view, url = start_view(router, "webedit", tmp_path)
    try:
        page = browser.new_page()
        errors: list[str] = []
        page.on("pageerror", lambda e: errors.append(str(e)))
        page.goto(url)
        page.click("#tab-editor")
        wait_for(lambda: page_value(page, "lunarsim.editor.scenario.rovers.length") == 2, 10, "the new scenario")
        box = page.locator("#map").bounding_box()

        def at(x: float, z: float) -> tuple[float, float]:
            sx, sy = page.evaluate(f"lunarsim.editor.toScreen({x}, {z})")
            return box["x"] + sx, box["y"] + sy

        page.check("input[name=tool][value=rover]")
        page.mouse.click(*at(22, 10))  # a third rover beside the other two
        page.check("input[name=tool][value=select]")
        page.mouse.move(*at(0, 0))  # drag the lander a little
        page.mouse.down()
        page.mouse.move(*at(3, -4), steps=5)
        page.mouse.up()
        sc = page_value(page, "lunarsim.editor.scenario")
        assert len(sc["rovers"]) == 3 and abs(sc["rovers"][2]["x"] - 22) < 1.5
        assert abs(sc["lander"]["x"] - 3) < 1.5 and abs(sc["lander"]["z"] + 4) < 1.5
        draw_wall_and_rock_field(page, at)
        page.fill("#ed-name", "e2e_web")
        page.click("#ed-validate")
        wait_for(lambda: page_value(page, "lunarsim.editor.ok") is True, 15, "validation")
        page.click("#ed-save")
        wait_for(lambda: "saved" in (page_value(page, "lunarsim.editor.status") or ""), 10, "the save")
        saved = tmp_path / "ws" / "e2e_web.yaml"
        assert saved.is_file()
        check = lunarsim("scenario", "check", str(saved))
        out, err = check.communicate(timeout=60)
        assert check.returncode == 0 and "3 rovers" in out and "1 walls" in out, err
        obstacles = yaml.safe_load(saved.read_text())["obstacles"]
        (wall,) = obstacles["walls"]
        assert len(wall["points"]) == 3 and wall["thickness_m"] == 1.5
        assert abs(wall["points"][1][0] - 45) < 1.5 and abs(wall["points"][1][1] - 25) < 1.5  # the dragged point
        assert obstacles["rock_fields"] == [{"x": 60.0, "z": -20.0, "radius_m": 10.0, "count": 12}]
        shot(page, "editor_saved")

        page.click("#ed-new")
        wait_for(lambda: page_value(page, "lunarsim.editor.scenario.rovers.length") == 2, 10, "a new scenario")
        page.select_option("#ed-files", "e2e_web")
        page.click("#ed-load")
        wait_for(lambda: page_value(page, "lunarsim.editor.scenario.rovers.length") == 3, 10, "the reloaded scenario")
        assert page_value(page, "lunarsim.editor.scenario.obstacles.walls[0].points.length") == 3
        assert page.locator("#ed-walls .item").count() == 1 and page.locator("#ed-fields .item").count() == 1
        assert page.input_value("#ed-name") == "e2e_web"

        with page.expect_download() as download:
            page.click("#ed-export")
        profile = tmp_path / "e2e_web.json"
        download.value.save_as(str(profile))
        assert len(json.loads(profile.read_text())["roverDataObjects"]) == 3
        page.click("#ed-new")
        page.set_input_files("#ed-import", str(profile))
        wait_for(lambda: page_value(page, "lunarsim.editor.scenario.name") == "e2e_web"
                 and page_value(page, "lunarsim.editor.scenario.rovers.length") == 3, 10, "the imported profile")
        page.click("#ed-load")  # back to the saved file (the profile has no rover parameters)
        wait_for(lambda: "loaded" in (page_value(page, "lunarsim.editor.status") or ""), 10, "the reload")

        page.fill("#ed-scale", "6")
        page.click("#ed-launch")
        wait_for(lambda: page_value(page, "lunarsim.editor.launched.ok"), 15, "the launch")
        wait_for(lambda: page_value(page, "lunarsim.scene.name") == "e2e_web", 15, "the launched scenario's scene")
        wait_for(lambda: len(positions(page)) == 3, 60, "the launched rovers on the page")
        first = positions(page)
        wait_for(lambda: any(p != first[i] for i, p in positions(page).items()), 30, "the launched rovers to move")
        shot(page, "editor_launched_live")
        assert not errors, errors
        page.click("#tab-editor")
        page.click("#ed-stop")
        wait_for(lambda: "stopped" in (page_value(page, "lunarsim.editor.status") or ""), 60, "the run to stop")
    finally:
        stop(view)  # stops a launched mission still running too, before anything else
    runs = list((tmp_path / "runs").glob("e2e_web-web-*"))
    assert len(runs) == 1 and (runs[0] / "scenario.yaml").is_file()
    wait_for(lambda: processes_mentioning(str(runs[0])) == [], 30, "no agent, world or recorder of the run left")


def test_a_launched_mission_is_stopped_with_the_view_that_launched_it(router, tmp_path, browser):
    view, url = start_view(router, "webstop", tmp_path)
    try:
        page = browser.new_page()
        page.goto(url)
        page.click("#tab-editor")
        wait_for(lambda: page_value(page, "lunarsim.editor.scenario.rovers.length") == 2, 10, "the new scenario")
        page.fill("#ed-name", "e2e_stop")
        page.fill("#ed-scale", "1")
        page.click("#ed-launch")
        wait_for(lambda: page_value(page, "lunarsim.editor.launched.ok"), 15, "the launch")
        wait_for(lambda: len(positions(page)) == 2, 60, "the launched rovers on the page")
    finally:
        stop(view)  # SIGTERM with the page still open
    (run,) = (tmp_path / "runs").glob("e2e_stop-web-*")
    wait_for(lambda: processes_mentioning(str(run)) == [], 60, "the launched mission's processes to end")


def draw_wall_and_rock_field(page, at) -> None:
    """A wall of three points (double-click ends it), one point dragged, its thickness edited; a second wall
    drawn (Enter ends it), selected by its line and deleted with the Delete key; a rock field placed."""
    page.check("input[name=tool][value=wall]")
    page.mouse.click(*at(30, 30))
    page.mouse.click(*at(40, 30))
    page.mouse.dblclick(*at(40, 45))
    wait_for(lambda: page_value(page, "lunarsim.editor.scenario.obstacles.walls.length") == 1, 5, "the drawn wall")
    assert page_value(page, "lunarsim.editor.scenario.obstacles.walls[0].points.length") == 3
    page.mouse.click(*at(-30, 20))
    page.mouse.click(*at(-30, 40))
    page.keyboard.press("Enter")
    assert page_value(page, "lunarsim.editor.scenario.obstacles.walls.length") == 2
    page.check("input[name=tool][value=select]")
    page.mouse.click(*at(-30, 30))  # on the second wall's line, between its points
    assert page_value(page, "lunarsim.editor.selected") == {"kind": "wall", "index": 1}
    page.keyboard.press("Delete")
    assert page_value(page, "lunarsim.editor.scenario.obstacles.walls.length") == 1
    page.mouse.move(*at(40, 30))  # drag the first wall's middle point
    page.mouse.down()
    page.mouse.move(*at(45, 25), steps=5)
    page.mouse.up()
    thickness = page.locator("#ed-walls .item input[data-field=thickness_m]")
    thickness.fill("1.5")
    thickness.dispatch_event("change")
    page.check("input[name=tool][value=rockfield]")
    page.fill("#ed-field-r", "10")
    page.fill("#ed-field-n", "12")
    page.mouse.click(*at(60, -20))
    field = page_value(page, "lunarsim.editor.scenario.obstacles.rock_fields[0]")
    assert field["count"] == 12 and abs(field["x"] - 60) < 1.5, field
    page.fill("#ed-fields .item input[data-field=x]", "60")
    page.locator("#ed-fields .item input[data-field=x]").dispatch_event("change")
    page.fill("#ed-fields .item input[data-field=z]", "-20")
    page.locator("#ed-fields .item input[data-field=z]").dispatch_event("change")
    shot(page, "editor_wall_rock_field")


def test_a_replay_is_shown_and_paused_from_the_page(router, tmp_path, browser):
    """A replay republishes the recorded keys, so the same page shows it; the header says "replay" (the replay's
    token), "replay paused" once Pause on the page has stopped it, and no longer "replay" when it has gone."""
    out = tmp_path / "rec"
    run = lunarsim("run", str(SCENARIOS / "crater_observation.yaml"), "--connect", router, "--world", "recorded",
                   "--time-scale", "5", "--max-sim-time", "20", "--quiet", "--out", str(out))
    run.communicate(timeout=120)
    assert (out / "session.mcap").is_file(), run.returncode
    view, url = start_view(router, "replayed", tmp_path, "--scenario", str(out / "scenario.yaml"))
    replay = lunarsim("replay", str(out / "session.mcap"), "--connect", router, "--remap-world", "replayed",
                      "--loop", "--quiet")
    try:
        page = browser.new_page()
        page.goto(url)
        wait_for(lambda: len(positions(page)) == 5, 30, "the replayed rovers on the page")
        first = positions(page)
        wait_for(lambda: positions(page) != first, 20, "the replayed rovers to move")
        # read at once, and waited for: the recording is 4 s long, and each time the loop passes its final report
        # the header says "replay: run ended" until the replay starts over
        wait_for(lambda: page_value(page, "[lunarsim.run.status, document.getElementById('conn').textContent, "
                                          "document.getElementById('conn').className]") == ["replay", "replay", "ok"],
                 20, "the header to say replay")
        page.click("#cmd-pause")
        wait_for(lambda: page_value(page, "lunarsim.lastCommand.sent"), 10, "the pause to be sent")

        def settled() -> bool:  # no new world state reaches the page for a second
            before = page_value(page, "lunarsim.states")
            page.wait_for_timeout(1000)
            return page_value(page, "lunarsim.states") == before

        wait_for(settled, 15, "the replay to pause")
        wait_for(lambda: page_value(page, "lunarsim.run.status") == "paused", 10, "the header to say paused")
        assert page.inner_text("#conn") == "replay paused"
        shot(page, "replay_paused")
        page.click("#cmd-resume")
        before = page_value(page, "lunarsim.states")
        wait_for(lambda: page_value(page, "lunarsim.states") > before + 3, 15, "the replay to resume")
        wait_for(lambda: page_value(page, "lunarsim.run.status") == "replay", 10, "the header to say replay again")
        stop(replay)
        # Gone after its final report (the loop's end), the header says the run ended; gone before it, that the
        # world is silent: either way, no longer "replay".
        wait_for(lambda: page_value(page, "lunarsim.run.status") in ("silent", "ended"), 20,
                 "the replay gone from the header")
        assert page.inner_text("#conn") in ("world silent", "run ended")
    finally:
        stop(replay, view)
