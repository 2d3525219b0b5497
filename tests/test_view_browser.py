"""`acphys view` in a real browser: Debian's chromium, driven by selenium through chromedriver.

A service on its own loopback port, `acphys view` (a subprocess) connected to
it, and a headless chromium on the page. A demo walk runs against the
service: its mover must appear on the page and move, a mover standing still
must appear too, a click on a mover must show its State, and the browser's
console must hold no errors. Without /usr/bin/chromium and
/usr/bin/chromedriver the test is skipped (CI installs both).
"""

from __future__ import annotations

import json
import os
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

from service_support import ROOT, ServiceProcess, child_env, free_port

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


@pytest.fixture()
def view() -> Iterator[tuple[ServiceProcess, str]]:
    with ServiceProcess(extra=["--prefix", PREFIX]) as svc:
        port = free_port()
        proc = subprocess.Popen([sys.executable, "-m", "clients.cli", "view", "--connect", svc.endpoint,
                                 "--prefix", PREFIX, "--port", str(port)],
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
    from clients.demo_walk import demo_mover, walk_demo
    from clients.demo_world import global_to_cell
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
        still = c.register(demo_mover(), Position.at(cell, Vec3(x, y, 60.0)))
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
            assert shown["id"] == still_hex and shown["landblock"] == 0xA9B4 and "contact" in shown
            assert browser.find_element(By.ID, "selected").text == still_hex
            browser.save_screenshot(str(tmp_path / "live-map.png"))
        finally:
            stop.set()
            thread.join(30)
            c.remove(still.id)
    assert not thread.is_alive()
    severe = [e for e in browser.get_log("browser") if e.get("level") == "SEVERE"]
    assert severe == [], severe
