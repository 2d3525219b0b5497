"""`acphys view` without a browser: its HTTP API and its board of movers.

The browser test (test_view_browser.py) needs chromium; these run anywhere.
"""

from __future__ import annotations

import json
import subprocess
import sys
import time
import urllib.error
import urllib.request
from collections.abc import Iterator
from typing import Any

import pytest

from service_support import ROOT, ServiceProcess, child_env, free_port

pytest.importorskip("starlette")
pytest.importorskip("uvicorn")
pytest.importorskip("sse_starlette")

PREFIX = "acphys-view-api-test"


def _get(url: str) -> tuple[int, Any]:
    try:
        with urllib.request.urlopen(url, timeout=5.0) as r:  # loopback only
            return r.status, json.loads(r.read())
    except urllib.error.HTTPError as e:
        return e.code, json.loads(e.read())


@pytest.fixture(scope="module")
def view_url() -> Iterator[tuple[str, ServiceProcess]]:
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
                    assert proc.poll() is None and time.monotonic() < deadline, "acphys view did not come up"
                    time.sleep(0.1)
            yield url, svc
        finally:
            proc.terminate()
            try:
                proc.wait(15)
            except subprocess.TimeoutExpired:
                proc.kill()
                proc.wait(10)


def test_the_view_serves_its_page_and_says_what_it_watches(view_url: tuple[str, ServiceProcess]) -> None:
    url, svc = view_url
    with urllib.request.urlopen(url, timeout=5.0) as r:
        page = r.read().decode()
    assert '<canvas id="map"' in page and "/static/view.js" in page
    with urllib.request.urlopen(url + "static/view.js", timeout=5.0) as r:
        assert b"EventSource" in r.read()
    status, info = _get(url + "api/info")
    assert status == 200 and info["prefix"] == PREFIX and info["connect"] == [svc.endpoint]
    assert len(info["instances"]) == 1
    assert _get(url + "api/landblocks") == (200, ["A9B4", "A9B5", "AAB4", "AAB5"])


def test_terrain_grids_are_the_worlds_heights(view_url: tuple[str, ServiceProcess]) -> None:
    from clients.demo_world import demo_scene_path
    from engine import load_scene

    url, _ = view_url
    status, grid = _get(url + "api/terrain/AAB5")
    assert status == 200 and grid["id"] == "AAB5" and grid["size"] * grid["step"] == 192.0
    assert (grid["x0"], grid["y0"]) == (0xAA * 192.0, 0xB5 * 192.0)
    world = load_scene(str(demo_scene_path()))
    n, step = grid["size"], grid["step"]
    for i, j in ((0, 0), (n - 1, 0), (0, n - 1), (n // 2, n // 3), (n - 1, n - 1)):
        x, y = (i + 0.5) * step, (j + 0.5) * step
        cell = (0xAAB5 << 16) | (int(x // 24) * 8 + int(y // 24) + 1)
        assert grid["heights"][j * n + i] == pytest.approx(world.terrain_height(cell, x, y), abs=0.01)
    assert grid["max"] == pytest.approx(90.0)  # the mesa's top is in AAB5


def test_bad_terrain_requests_get_clear_errors(view_url: tuple[str, ServiceProcess]) -> None:
    url, _ = view_url
    status, body = _get(url + "api/terrain/zz")
    assert status == 400 and "not a landblock id" in body["error"]
    status, body = _get(url + "api/terrain/1234")
    assert status == 404 and "no landblock 1234" in body["error"]
    assert _get(url + "api/info")[0] == 200  # and it keeps serving


def test_the_board_keeps_the_newest_state_of_each_mover() -> None:
    from clients.view_board import MoverBoard

    board = MoverBoard(session=None, prefix="p")
    big = 0x52BCE000000001  # beyond JavaScript's exact integers: the page gets it in hex
    state = {"id": big, "seq": 5, "landblock": 0xA9B4, "position": {"cell": 0xA9B40001, "origin": [1.0, 2.0, 3.0]},
             "collide_objects": [big + 1]}
    assert board.offer(state)
    assert not board.offer({**state, "seq": 4})  # an older one arriving late changes nothing
    assert board.offer({**state, "seq": 6, "position": {"cell": 0xA9B40001, "origin": [4.0, 2.0, 3.0]}})
    (page,) = board.snapshot()
    assert page["id"] == "52BCE000000001" and page["seq"] == 6 and page["position"]["origin"][0] == 4.0
    assert page["cell_hex"] == "A9B40001" and page["collide_objects"] == ["52BCE000000002"]
