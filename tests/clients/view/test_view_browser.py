"""`acphys view` in a real browser: Debian's chromium, driven by selenium through chromedriver.

A service on its own loopback port, `acphys view` (a subprocess) connected to
it, and a headless chromium on the page. A demo walk runs against the
service: its mover must appear on the page and move, a mover standing still
must appear too, a click on a mover must show its State, and the browser's
console must hold no errors. A second test checks the page's layout against
what it should be, from the page's own record of where it drew things and
the DOM's boxes (not pixels): labels clear of each other, of the movers, the
scale bar, north and the hint; the house and the objects where the world has
them; the height key's range; the list and the State in hex with a clock
time; removed movers gone. Without /usr/bin/chromium and
/usr/bin/chromedriver the tests are skipped (CI installs both).
"""

from __future__ import annotations

import json
import math
import os
import re
import shutil
import subprocess
import sys
import tempfile
import threading
import time
import urllib.request
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest

from support.service_harness import ROOT, ServiceProcess, child_env, free_port

CHROMIUM = "/usr/bin/chromium"
CHROMEDRIVER = "/usr/bin/chromedriver"
pytestmark = pytest.mark.skipif(not (os.path.exists(CHROMIUM) and os.path.exists(CHROMEDRIVER)),
                                reason="Debian's chromium and chromium-driver are not installed (CI installs them)")
PREFIX = "acphys-view-test"
DEADLINE_S = 60.0


class _StopWalk(Exception):
    pass


def _get(url: str, timeout: float = 2.0) -> Any:
    with urllib.request.urlopen(url, timeout=timeout) as r:  # loopback only
        return json.loads(r.read())


def _view_process(extra: list[str]) -> Iterator[tuple[ServiceProcess, str]]:
    """A service, and `acphys view` connected to it (with `extra` options), until the test is done."""
    with ServiceProcess(extra=["--prefix", PREFIX]) as svc:
        port = free_port()
        proc = subprocess.Popen([sys.executable, "-m", "clients", "view", "--connect", svc.endpoint,
                                 "--prefix", PREFIX, "--port", str(port), *extra],
                                cwd=ROOT, env=child_env(), stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
        url = f"http://127.0.0.1:{port}/"
        try:
            deadline = time.monotonic() + 30.0
            while True:
                try:
                    _get(url + "api/info")
                    break
                except OSError:
                    if proc.poll() is not None or time.monotonic() > deadline:
                        out = proc.stdout.read() if proc.stdout else ""
                        pytest.fail(f"acphys view did not come up: {out}")
                    time.sleep(0.1)
            yield svc, url
        finally:
            proc.terminate()
            try:
                proc.wait(15)
            except subprocess.TimeoutExpired:
                proc.kill()
                proc.wait(10)


@pytest.fixture()
def view() -> Iterator[tuple[ServiceProcess, str]]:
    yield from _view_process([])


#: `acphys view --path`: from the north hills (landblock A9B5's outdoor cell 0x38) into the house's room
PATH_WORDS = ["A9B50038", "150", "180", "41.5", "A9B50100", "108", "108", "40"]


@pytest.fixture()
def path_view() -> Iterator[tuple[ServiceProcess, str]]:
    yield from _view_process(["--path", *PATH_WORDS])


@pytest.fixture()
def browser() -> Iterator[Any]:
    from selenium import webdriver
    from selenium.webdriver.chrome.service import Service

    profile = tempfile.mkdtemp(prefix="acphys-chromium-")
    opts = webdriver.ChromeOptions()
    opts.binary_location = CHROMIUM
    for flag in ("--headless=new", "--no-sandbox", "--disable-gpu", "--disable-dev-shm-usage",
                 "--disable-background-networking", "--disable-component-update", "--disable-sync",
                 "--no-first-run", "--disable-default-apps", "--window-size=1400,900", f"--user-data-dir={profile}"):
        opts.add_argument(flag)
    opts.set_capability("goog:loggingPrefs", {"browser": "ALL"})
    driver = webdriver.Chrome(service=Service(executable_path=CHROMEDRIVER), options=opts)
    driver.set_page_load_timeout(30)
    driver.set_script_timeout(10)
    try:
        yield driver
    finally:
        driver.quit()
        shutil.rmtree(profile, ignore_errors=True)


def _wait(predicate: Any, what: str, timeout: float = DEADLINE_S) -> Any:
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        value = predicate()
        if value:
            return value
        time.sleep(0.1)
    pytest.fail(f"timed out waiting for {what}")


def test_the_live_map_shows_the_movers_of_a_demo_walk_moving(view: tuple[ServiceProcess, str], browser: Any,
                                                            tmp_path: Path) -> None:
    from selenium.webdriver.common.action_chains import ActionChains
    from selenium.webdriver.common.by import By

    from clients import Client
    from clients.cli.player import player_mover
    from clients.demo.walk import walk_demo
    from clients.demo.world import global_to_cell
    from engine.geometry import Position, Vec3

    svc, url = view
    browser.get(url)
    js = browser.execute_script
    # the page has the service's four landblocks, their terrain drawn
    _wait(lambda: js("return window.acphysView && window.acphysView.terrainReady()") == 4, "the terrain")
    assert sorted(js("return window.acphysView.landblocks()")) == ["A9B4", "A9B5", "AAB4", "AAB5"]
    _wait(lambda: js("return document.getElementById('status').dataset.live") == "1", "the event stream")

    stop = threading.Event()
    walked: dict[str, Any] = {}

    def walk() -> None:
        def on_step(n: int) -> None:
            walked["steps"] = n
            if stop.is_set() or n >= 1500:
                raise _StopWalk()
            time.sleep(0.01)  # about as fast as a person can watch

        with Client([svc.endpoint], prefix=PREFIX, timeout=10.0) as c:
            try:
                walk_demo(c, on_step=on_step)
            except _StopWalk:
                pass
            except Exception as e:  # reported by the test below
                walked["error"] = e

    with Client([svc.endpoint], prefix=PREFIX, timeout=10.0) as c:
        # a mover that stands still: it appears once the page's view has its state (re-sent until it has)
        cell, x, y = global_to_cell(100.0, 100.0)
        still = c.register(player_mover(), Position.at(cell, Vec3(x, y, 60.0)))
        still_hex = f"{still.id:X}"
        thread = threading.Thread(target=walk, daemon=True)
        thread.start()
        try:
            def still_seen() -> bool:
                if still_hex in js("return window.acphysView.moverIds()"):
                    return True
                c.step(still.id, (0.0, 0.0, 0.0), 0.2)  # one more publication (it falls onto the hills)
                return False

            _wait(still_seen, "the standing mover on the page")
            ids = _wait(lambda: [i for i in js("return window.acphysView.moverIds()") if i != still_hex],
                        "the demo walker on the page")
            walker = ids[0]
            first = js("return window.acphysView.position(arguments[0])", walker)
            _wait(lambda: (lambda p: abs(p[0] - first[0]) + abs(p[1] - first[1]) > 5.0)(
                js("return window.acphysView.position(arguments[0])", walker)), "the walker to move 5 m on the page")
            assert "error" not in walked, walked.get("error")
            # the walker is where the service says (global metres: landblock column * 192 + local x)
            st = c.find(int(walker, 16))
            lb = st.landblock
            gx, gy = (lb >> 8) * 192 + st.position.origin.x, (lb & 0xFF) * 192 + st.position.origin.y
            _wait(lambda: (lambda p: abs(p[0] - gx) < 10.0 and abs(p[1] - gy) < 10.0)(
                js("return window.acphysView.position(arguments[0])", walker)), "the page to agree with the service")

            # a click on the standing mover shows its State
            canvas = browser.find_element(By.ID, "map")
            sx, sy = js("return window.acphysView.screenOf(arguments[0])", still_hex)
            w, h = canvas.size["width"], canvas.size["height"]
            ActionChains(browser).move_to_element_with_offset(canvas, int(sx - w / 2), int(sy - h / 2)).click().perform()
            _wait(lambda: js("return window.acphysView.selected()") == still_hex, "the click to select the mover")
            shown = json.loads(browser.find_element(By.ID, "state").text)
            assert shown["id"] == still_hex and shown["landblock"] == "A9B4" and "contact" in shown
            assert browser.find_element(By.ID, "selected").text == still_hex
            browser.save_screenshot(str(tmp_path / "live-map.png"))
        finally:
            stop.set()
            thread.join(30)
            c.remove(still.id)
    assert not thread.is_alive()
    severe = [e for e in browser.get_log("browser") if e.get("level") == "SEVERE"]
    assert severe == [], severe


def _overlap(a: dict[str, float], b: dict[str, float]) -> bool:
    return min(a["x1"], b["x1"]) > max(a["x0"], b["x0"]) and min(a["y1"], b["y1"]) > max(a["y0"], b["y0"])


def _check_labels(lay: dict[str, Any]) -> list[dict[str, Any]]:
    """The shown labels: inside the map, clear of each other, of every mover and of the fixed marks."""
    w, h = lay["canvas"]["w"], lay["canvas"]["h"]
    fixed = lay["fixed"]
    marks = [fixed["scale"], fixed["north"], fixed["hint"]]
    for a, b in ((0, 1), (0, 2), (1, 2)):
        assert not _overlap(marks[a], marks[b]), (marks[a], marks[b])  # the scale bar sits above the hint
    dots = [{"x0": d["x"] - d["r"], "y0": d["y"] - d["r"], "x1": d["x"] + d["r"], "y1": d["y"] + d["r"]}
            for d in lay["dots"]]
    shown = [lb for lb in lay["labels"] if lb["shown"]]
    for lb in shown:
        b = lb["box"]
        assert 0 <= b["x0"] and b["x1"] <= w and 0 <= b["y0"] and b["y1"] <= h, lb
        assert not any(_overlap(b, m) for m in marks), lb
        assert not any(_overlap(b, d) for d in dots), lb
    for i, a in enumerate(shown):
        for b in shown[i + 1:]:
            assert not _overlap(a["box"], b["box"]), (a, b)
    # a mover's label beside its dot, or further out with a leader line back to it
    where = {d["id"]: d for d in lay["dots"]}
    for lb in shown:
        if lb["kind"] == "mover":
            d, b = where[lb["id"]], lb["box"]
            gap = math.hypot(max(b["x0"] - d["x"], 0.0, d["x"] - b["x1"]), max(b["y0"] - d["y"], 0.0, d["y"] - b["y1"]))
            assert (gap > d["r"] + 8.0) == lb["leader"], lb
    return shown


def _ints(value: Any) -> list[int]:
    if isinstance(value, bool):
        return []
    if isinstance(value, int):
        return [value]
    if isinstance(value, dict):
        return [i for v in value.values() for i in _ints(v)]
    if isinstance(value, list):
        return [i for v in value for i in _ints(v)]
    return []


def test_the_live_map_lays_out_its_labels_key_buildings_and_list(view: tuple[ServiceProcess, str], browser: Any,
                                                                 tmp_path: Path) -> None:
    from selenium.webdriver.common.by import By

    from clients import Client
    from clients.cli.player import player_mover
    from clients.demo.world import ORIGIN_LANDBLOCK, demo_footprints, global_to_cell
    from engine.geometry import Position, Vec3

    svc, url = view
    browser.get(url)
    js = browser.execute_script
    _wait(lambda: js("return window.acphysView && window.acphysView.terrainReady()") == 4, "the terrain")
    _wait(lambda: len(js("return window.acphysView.outlines()")) == 4, "the buildings and objects")
    _wait(lambda: js("return document.getElementById('status').dataset.live") == "1", "the event stream")
    ox, oy = (ORIGIN_LANDBLOCK >> 8) * 192.0, (ORIGIN_LANDBLOCK & 0xFF) * 192.0  # demo metres -> the map's
    centre, scale = (108.0, 300.0), 8.0  # the village, 8 px a metre
    canvas = browser.find_element(By.ID, "map").rect
    cw, ch = round(canvas["width"]), round(canvas["height"])

    def screen(x: float, y: float) -> tuple[float, float]:  # demo metres -> canvas pixels at that view
        return cw / 2 + (x - centre[0]) * scale, ch / 2 - (y - centre[1]) * scale

    def demo_xy(px: float, py: float) -> tuple[float, float]:
        return centre[0] + (px - cw / 2) / scale, centre[1] - (py - ch / 2) / scale

    # a crowd by the door, one alone, one under the scale bar's place and one under north's
    spots = [(106.0, 292.0), (107.2, 292.0), (108.4, 292.0), (106.6, 293.2), (107.8, 293.2), (125.0, 315.0),
             demo_xy(40.0, ch - 60.0), demo_xy(cw - 28.0, 40.0)]
    with Client([svc.endpoint], prefix=PREFIX, timeout=10.0) as c:
        ids = []
        for gx, gy in spots:
            cell, x, y = global_to_cell(gx, gy)
            ids.append(c.register(player_mover(), Position.at(cell, Vec3(x, y, 60.0))).id)
        keys = [f"{i:X}" for i in ids]
        states: dict[int, Any] = {}

        def settled_and_shown() -> bool:  # they fall onto the ground, a State each step, until the page has all
            for i in ids:
                states[i] = c.step(i, (0.0, 0.0, 0.0), 0.2)
            on_page = set(js("return window.acphysView.moverIds()"))
            return all(st.on_walkable for st in states.values()) and set(keys) <= on_page

        _wait(settled_and_shown, "the movers to settle on the page")
        for i in ids:  # the last States, as the page got them
            states[i] = c.find(i)
        time.sleep(0.3)

        # -- at the page's own zoom (the whole world): the fixed marks and labels apart
        _check_labels(js("return window.acphysView.layout()"))

        # -- over the village
        js("window.acphysView.setView(arguments[0], arguments[1], arguments[2])", ox + centre[0], oy + centre[1], scale)
        crowd = keys[2]
        browser.find_element(By.CSS_SELECTOR, f'#movers li[data-id="{crowd}"]').click()  # select from the list

        def laid_out() -> Any:
            lay = js("return window.acphysView.layout()")
            ok = lay["canvas"] == {"w": cw, "h": ch} and len(lay["dots"]) == len(ids) and \
                any(s["kind"] == "building" for s in lay.get("shapes", [])) and \
                any(lb["kind"] == "mover" and lb["id"] == crowd and lb["shown"] for lb in lay["labels"])
            return lay if ok else None

        lay = _wait(laid_out, "the page drawn over the village")
        browser.save_screenshot(str(tmp_path / "live-map-village.png"))
        shown = _check_labels(lay)
        by_id = {lb["id"]: lb for lb in lay["labels"]}
        assert set(keys) <= set(by_id)  # every mover has its label, shown or (crowded) hidden
        assert by_id[crowd]["shown"] and by_id[keys[5]]["shown"]  # the selected one, and the one alone
        assert by_id[keys[6]]["shown"] and by_id[keys[7]]["shown"]  # moved off the scale bar and north
        assert {lb["text"] for lb in shown if lb["kind"] == "landblock"} == {"landblock A9B5"}
        # the dots are where the service says the movers are
        for i, key in zip(ids, keys):
            st = states[i]
            lb = st.position.cell_id >> 16
            gx = (lb >> 8) * 192.0 + st.position.origin.x - ox
            gy = (lb & 0xFF) * 192.0 + st.position.origin.y - oy
            (dot,) = [d for d in lay["dots"] if d["id"] == key]
            assert (dot["x"], dot["y"]) == pytest.approx(screen(gx, gy), abs=0.5)
        # the house drawn where the world has it, and the three objects near it
        want = {f.name: f.a for f in demo_footprints()}
        x0, y0, x1, y1 = want["house"]
        (house,) = [s["box"] for s in lay["shapes"] if s["kind"] == "building"]
        (sx0, sy1), (sx1, sy0) = screen(x0, y0), screen(x1, y1)
        assert (house["x0"], house["y0"], house["x1"], house["y1"]) == pytest.approx((sx0, sy0, sx1, sy1), abs=0.5)
        assert sum(s["kind"] == "object" for s in lay["shapes"]) == 3  # pillar, boulder, platform

        # -- the height key: the colours of the lowest to the highest ground drawn, its marks apart
        grids = [_get(url + f"api/terrain/{lb}") for lb in ("A9B4", "A9B5", "AAB4", "AAB5")]
        lo, hi = min(g["min"] for g in grids), max(g["max"] for g in grids)
        ticks = browser.find_elements(By.CSS_SELECTOR, "#height-key-ticks span")
        texts = [t.text for t in ticks]
        assert texts[0] == f"{lo:.1f} m" and texts[1] == f"{hi:.1f} m", texts
        assert len(texts) >= 3 and all(re.fullmatch(r"\d+ m", t) for t in texts[2:]), texts
        key = browser.find_element(By.ID, "height-key").rect
        rects = [t.rect for t in ticks]
        for r in rects:
            assert key["x"] - 0.5 <= r["x"] and r["x"] + r["width"] <= key["x"] + key["width"] + 0.5, r
        boxes = [{"x0": r["x"], "y0": r["y"], "x1": r["x"] + r["width"], "y1": r["y"] + r["height"]} for r in rects]
        assert not any(_overlap(a, b) for k, a in enumerate(boxes) for b in boxes[k + 1:]), texts

        # -- the list: each mover with its landblock and its place there
        _wait(lambda: len(browser.find_elements(By.CSS_SELECTOR, "#movers li")) == len(ids), "the list")
        rows = {li.get_attribute("data-id"): li.text for li in browser.find_elements(By.CSS_SELECTOR, "#movers li")}
        for i, key in zip(ids, keys):
            o = states[i].position.origin
            assert rows[key].startswith(key + " ")
            assert rows[key].endswith(f"{states[i].landblock:04X} {o.x:.1f}, {o.y:.1f}, {o.z:.1f}"), rows[key]

        # -- the State panel: ids in hex throughout, the time as a clock
        _wait(lambda: browser.find_element(By.ID, "selected").text == crowd, "the selection")
        shown_state = json.loads(browser.find_element(By.ID, "state").text)
        st = states[ids[2]]
        assert shown_state["id"] == crowd and shown_state["landblock"] == f"{st.landblock:04X}" == "A9B5"
        assert shown_state["position"]["cell"] == f"{st.position.cell_id:08X}"
        assert shown_state["contact_plane_cell"] == f"{st.result.contact_plane_cell:08X}"
        assert re.fullmatch(r"\d\d:\d\d:\d\d \(\d+ s ago\)", shown_state["received"]), shown_state["received"]
        assert all(i < 0x10000 for i in _ints(shown_state)), shown_state  # no id in decimal

        # -- removed movers leave the map and the list
        c.remove(ids[2])
        c.remove(ids[5])
        gone = {keys[2], keys[5]}
        _wait(lambda: not gone & set(js("return window.acphysView.moverIds()")), "the removed movers to leave")
        _wait(lambda: len(browser.find_elements(By.CSS_SELECTOR, "#movers li")) == len(ids) - 2, "the list to shrink")
        assert not gone & {li.get_attribute("data-id") for li in browser.find_elements(By.CSS_SELECTOR, "#movers li")}
        assert browser.find_element(By.ID, "mover-count").text == str(len(ids) - 2)
        assert browser.find_element(By.ID, "selected").text == f"{crowd} (removed)"
        for i in ids:
            if f"{i:X}" not in gone:
                c.remove(i)
    severe = [e for e in browser.get_log("browser") if e.get("level") == "SEVERE"]
    assert severe == [], severe


def test_the_live_map_draws_the_paths_asked(path_view: tuple[ServiceProcess, str], browser: Any) -> None:
    from selenium.webdriver.common.action_chains import ActionChains
    from selenium.webdriver.common.by import By
    from selenium.webdriver.common.keys import Keys

    from clients.cli.player import player_mover
    from clients.demo.world import demo_scene_path
    from clients.view.paths import parse_path_words
    from engine import load_scene

    _, url = path_view
    browser.get(url)
    js = browser.execute_script
    _wait(lambda: js("return window.acphysView && window.acphysView.terrainReady()") == 4, "the terrain")
    # the --path, answered and drawn: one polyline through as many points as the world's own path has waypoints
    local = load_scene(str(demo_scene_path())).path(player_mover(), *parse_path_words(PATH_WORDS))
    assert local.found

    def drawn(n: int) -> Any:
        def ready() -> Any:
            paths = js("return window.acphysView.paths()")
            lay = js("return window.acphysView.layout()")
            done = len(paths) == n and not any(p["pending"] for p in paths) and len(lay.get("paths", [])) == n
            return (paths, lay) if done else None
        return ready

    paths, lay = _wait(drawn(1), "the --path drawn", timeout=120.0)
    (p,), (line,) = paths, lay["paths"]
    assert p["found"] and line["found"] and len(line["points"]) == len(local.waypoints) == len(p["waypoints"])
    for (px, py), w in zip(line["points"], local.waypoints):  # where the page put each waypoint, in pixels
        gx, gy = (w.cell_id >> 24) * 192.0 + w.origin.x, ((w.cell_id >> 16) & 0xFF) * 192.0 + w.origin.y
        sx, sy = js("return window.acphysView.toScreen(arguments[0], arguments[1])", gx, gy)
        assert (px, py) == pytest.approx((sx, sy), abs=0.01)
    listed = browser.find_elements(By.CSS_SELECTOR, "#paths li")
    assert len(listed) == 1 and f"{len(local.waypoints)} waypoints" in listed[0].text

    # two shift-clicks: a path between those points, asked by the page and drawn
    canvas = browser.find_element(By.ID, "map")
    rect = canvas.rect
    cw, ch = rect["width"], rect["height"]
    start, goal = js("return window.acphysView.toScreen(arguments[0], arguments[1])", 0xA9 * 192.0 + 130.0,
                     0xB5 * 192.0 + 98.0), js("return window.acphysView.toScreen(arguments[0], arguments[1])",
                                               0xA9 * 192.0 + 60.0, 0xB5 * 192.0 + 58.0)
    for px, py in (start, goal):
        ActionChains(browser).key_down(Keys.SHIFT).move_to_element_with_offset(canvas, px - cw / 2, py - ch / 2) \
            .click().key_up(Keys.SHIFT).perform()
    paths, lay = _wait(drawn(2), "the shift-clicked path drawn", timeout=120.0)
    q, line = paths[1], lay["paths"][1]
    assert q["found"] and q["from"]["cell"] == "A9B5002D" and q["to"]["cell"] == "A9B50013"
    assert len(line["points"]) == len(q["waypoints"]) >= 2
    # its ends where the clicks were (within a pixel's worth of metres, plus placement's 0.25 m)
    scale = js("return window.acphysView.view().scale")
    for (px, py), (cx, cy) in ((line["points"][0], start), (line["points"][-1], goal)):
        assert math.hypot(px - cx, py - cy) <= 1.5 + 0.25 * scale
    errors = [e for e in browser.get_log("browser") if e["level"] == "SEVERE"]
    assert not errors, errors
