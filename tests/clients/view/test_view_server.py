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

from support.service_harness import ROOT, ServiceProcess, child_env, free_port

pytest.importorskip("starlette")
pytest.importorskip("uvicorn")
pytest.importorskip("sse_starlette")

PREFIX = "acphys-view-api-test"
#: the path `acphys view --path` asks for: from the north hills (global 150, 372: landblock A9B5, its outdoor
#: cell 6 * 8 + 7 + 1 = 0x38) to the middle of the house's room (EnvCell A9B50100, on its floor at 40 m)
PATH_WORDS = ["A9B50038", "150", "180", "41.5", "A9B50100", "108", "108", "40"]


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
        proc = subprocess.Popen([sys.executable, "-m", "clients", "view", "--connect", svc.endpoint,
                                 "--prefix", PREFIX, "--port", str(port), "--path", *PATH_WORDS],
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
    from clients.demo.world import demo_scene_path
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
    from clients.view.board import MoverBoard

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


# -- buildings and objects ----------------------------------------------------------------------------
def _bbox(points: list[list[float]]) -> tuple[float, float, float, float]:
    xs, ys = [p[0] for p in points], [p[1] for p in points]
    return min(xs), min(ys), max(xs), max(ys)


def test_the_view_draws_the_worlds_buildings_and_objects(view_url: tuple[str, ServiceProcess]) -> None:
    from clients.demo.world import ORIGIN_LANDBLOCK, demo_footprints

    url, _ = view_url
    # the demo world's own account of its village (global demo metres from A9B4's corner), in the view's
    # global metres (landblock column and row times 192)
    ox, oy = (ORIGIN_LANDBLOCK >> 8) * 192.0, (ORIGIN_LANDBLOCK & 0xFF) * 192.0
    want = {f.name: f for f in demo_footprints()}
    status, body = _get(url + "api/objects/A9B5")
    assert status == 200 and body["id"] == "A9B5"
    (house,) = body["buildings"]
    x0, y0, x1, y1 = want["house"].a
    assert _bbox(house["polygon"]) == pytest.approx((ox + x0, oy + y0, ox + x1, oy + y1), abs=1e-3)
    assert len(house["polygon"]) == 4 and house["circles"] == [] and house["model"] == "01000001"
    circles = sorted(tuple(c) for o in body["objects"] for c in o["circles"])
    expected = sorted((ox + f.a[0], oy + f.a[1], f.a[2]) for f in demo_footprints() if f.shape == "circle")
    assert len(circles) == len(expected) == 3  # the pillar and the boulder's two spheres
    for got, exp in zip(circles, expected):
        assert got == pytest.approx(exp, abs=1e-3)
    (platform,) = [o for o in body["objects"] if o["polygon"]]
    x0, y0, x1, y1 = want["platform"].a
    assert _bbox(platform["polygon"]) == pytest.approx((ox + x0, oy + y0, ox + x1, oy + y1), abs=1e-3)
    # the hills have none; ids are checked as for the terrain
    assert _get(url + "api/objects/A9B4") == (200, {"id": "A9B4", "buildings": [], "objects": []})
    assert _get(url + "api/objects/zz")[0] == 400
    status, body = _get(url + "api/objects/1234")
    assert status == 404 and "no landblock 1234" in body["error"]


def test_a_convex_hull_keeps_the_corners_only() -> None:
    from clients.view.objects import convex_hull

    square_with_inside = [(0.0, 0.0), (2.0, 0.0), (2.0, 2.0), (0.0, 2.0), (1.0, 1.0), (1.0, 0.0), (0.5, 1.5)]
    assert convex_hull(square_with_inside) == [(0.0, 0.0), (2.0, 0.0), (2.0, 2.0), (0.0, 2.0)]  # counter-clockwise
    assert convex_hull([(1.0, 1.0), (1.0, 1.0)]) == [(1.0, 1.0)]


# -- removed movers leave ------------------------------------------------------------------------------
def _state(mid: int, seq: int) -> dict[str, Any]:
    return {"id": mid, "seq": seq, "landblock": 0xA9B4, "position": {"cell": 0xA9B40001, "origin": [1.0, 2.0, 3.0]}}


def test_a_quiet_mover_the_service_no_longer_holds_is_forgotten_after_two_answers() -> None:
    from clients.view.board import MoverBoard
    from clients.view.removals import QUIET_S, RECHECK_S, RETRY_S, RemovalWatch

    board = MoverBoard(session=None, prefix="p")
    held = {0xA1: True, 0xB2: False, 0xC3: None}  # held; gone; the service does not answer
    asked: list[int] = []

    def ask(mid: int) -> bool | None:
        asked.append(mid)
        return held[mid]

    for mid in held:
        board.offer(_state(mid, 3))
    t0 = max(s["received"] for s in board.snapshot())
    watch = RemovalWatch(board, ask)
    assert watch.run_once(t0 + QUIET_S - 0.5) == [] and asked == []  # none quiet yet
    assert watch.run_once(t0 + QUIET_S + 0.1) == [] and sorted(asked) == [0xA1, 0xB2, 0xC3]  # one "gone" is not enough
    asked.clear()
    assert watch.run_once(t0 + QUIET_S + 0.1 + RETRY_S / 2) == [] and asked == []  # not due again yet
    assert watch.run_once(t0 + QUIET_S + 0.1 + RETRY_S) == ["B2"] and sorted(asked) == [0xB2, 0xC3]
    assert sorted(s["id"] for s in board.snapshot()) == ["A1", "C3"]  # no answer drops nothing
    asked.clear()
    assert watch.run_once(t0 + QUIET_S + 0.1 + RECHECK_S) == [] and 0xA1 in asked  # the held one, asked again later
    # the forgotten mover stays out for its old State arriving late, and is back for a newer one
    assert not board.offer(_state(0xB2, 3))
    assert board.offer(_state(0xB2, 4)) and "B2" in {s["id"] for s in board.snapshot()}


def test_a_mover_that_spoke_again_is_not_forgotten() -> None:
    from clients.view.board import MoverBoard
    from clients.view.removals import QUIET_S, RETRY_S, RemovalWatch

    board = MoverBoard(session=None, prefix="p")
    board.offer(_state(0xB2, 1))
    t0 = board.snapshot()[0]["received"]
    watch = RemovalWatch(board, lambda mid: False)
    watch.run_once(t0 + QUIET_S)
    board.offer(_state(0xB2, 2))  # a new State between the two answers: the first miss no longer counts
    assert watch.run_once(t0 + QUIET_S + RETRY_S) == []
    assert [s["seq"] for s in board.snapshot()] == [2]


def _the_asked_paths(url: str) -> list[dict[str, Any]]:
    """The view's paths once its `--path` is answered. The service builds the graph of the cells the search
    reaches first, a share per ask, on its engine thread: until then every request to it waits behind
    those shares (seconds each on the interpreted engine under coverage)."""
    deadline = time.monotonic() + 120.0
    while True:
        status, paths = _get(url + "api/paths")
        assert status == 200 and len(paths) == 1
        if not paths[0]["pending"] or time.monotonic() > deadline:
            return list(paths)
        time.sleep(0.2)


def test_the_view_drops_a_mover_the_service_removed(view_url: tuple[str, ServiceProcess]) -> None:
    from clients import Client
    from clients.cli.player import player_mover
    from clients.demo.world import global_to_cell
    from engine.geometry import Position, Vec3

    url, svc = view_url
    _the_asked_paths(url)  # so that the register below does not wait behind the graph building
    with Client([svc.endpoint], prefix=PREFIX, timeout=10.0) as c:
        cell, x, y = global_to_cell(50.0, 50.0)
        st = c.register(player_mover(), Position.at(cell, Vec3(x, y, 60.0)))
        key = f"{st.id:X}"
        deadline = time.monotonic() + 30.0
        while key not in {m["id"] for m in _get(url + "api/movers")[1]}:  # re-sent until the view has one
            assert time.monotonic() < deadline, "the view never got the mover's State"
            c.step(st.id, (0.0, 0.0, 0.0), 0.2)
            time.sleep(0.2)
        c.remove(st.id)
        deadline = time.monotonic() + 30.0
        while key in {m["id"] for m in _get(url + "api/movers")[1]}:
            assert time.monotonic() < deadline, "the view still lists the removed mover"
            time.sleep(0.2)


def _post(url: str, body: Any) -> tuple[int, Any]:
    req = urllib.request.Request(url, data=json.dumps(body).encode(), headers={"Content-Type": "application/json"},
                                 method="POST")
    try:
        with urllib.request.urlopen(req, timeout=120.0) as r:  # loopback only; a path may build graphs first
            return r.status, json.loads(r.read())
    except urllib.error.HTTPError as e:
        return e.code, json.loads(e.read())


def _same_waypoints(served: list[dict[str, Any]], local: Any) -> None:
    assert [w["cell"] for w in served] == [f"{p.cell_id:08X}" for p in local.waypoints]
    assert [w["landblock"] for w in served] == [p.cell_id >> 16 for p in local.waypoints]
    for w, p in zip(served, local.waypoints):
        assert w["origin"] == pytest.approx([p.origin.x, p.origin.y, p.origin.z], abs=1e-4)


def test_the_view_serves_the_paths_asked_as_the_world_finds_them(view_url: tuple[str, ServiceProcess]) -> None:
    from clients.cli.player import player_mover
    from clients.demo.world import demo_scene_path
    from clients.view.paths import parse_path_words
    from engine import load_scene
    from engine.geometry import Position, Vec3

    url, _ = view_url
    (p,) = _the_asked_paths(url)
    assert p["number"] == 1 and not p["pending"] and not p["error"]
    assert p["from"]["cell"] == "A9B50038" and p["to"] == {"cell": "A9B50100", "landblock": 0xA9B5,
                                                           "origin": [108.0, 108.0, 40.0]}
    # the same path as the world loaded here finds for the same walker, asked in the same order
    world = load_scene(str(demo_scene_path()))
    walker = player_mover()
    local = world.path(walker, *parse_path_words(PATH_WORDS))
    assert local.found and p["found"] and p["length"] == pytest.approx(local.length, abs=1e-3)
    _same_waypoints(p["waypoints"], local)
    # into the room: outdoors first, then in its EnvCell to the end (in once, not out again)
    indoors = [int(w["cell"][4:], 16) >= 0x100 for w in p["waypoints"]]
    assert not indoors[0] and indoors[-1] and indoors == sorted(indoors)
    assert p["waypoints"][-1]["cell"] == "A9B50100"

    # two points posted, as two shift-clicks on the page send them (global metres: landblock column * 192 + x)
    a9b5 = (0xA9 * 192.0, 0xB5 * 192.0)
    start_xy, goal_xy = (a9b5[0] + 130.0, a9b5[1] + 98.0), (a9b5[0] + 60.0, a9b5[1] + 58.0)  # the pad; the hills west
    status, q = _post(url + "api/path", {"from": list(start_xy), "to": list(goal_xy)})
    assert status == 200 and q["number"] == 2 and q["found"], q
    # on the terrain there, in the outdoor cells of landblock A9B5's (130, 98) and (60, 58):
    # 5 * 8 + 4 + 1 = 0x2D and 2 * 8 + 2 + 1 = 0x13
    assert q["from"]["cell"] == "A9B5002D" and q["from"]["origin"][:2] == [130.0, 98.0]
    assert q["to"]["cell"] == "A9B50013" and q["to"]["origin"][:2] == [60.0, 58.0]
    start = Position.at(0xA9B5002D, Vec3(130.0, 98.0, world.terrain_height(0xA9B5002D, 130.0, 98.0)))
    goal = Position.at(0xA9B50013, Vec3(60.0, 58.0, world.terrain_height(0xA9B50013, 60.0, 58.0)))
    assert q["from"]["origin"][2] == pytest.approx(start.origin.z) and q["to"]["origin"][2] == pytest.approx(goal.origin.z)
    _same_waypoints(q["waypoints"], world.path(walker, start, goal))
    assert [e["number"] for e in _get(url + "api/paths")[1]] == [1, 2]
    # what is not two points is refused with a reason, and so is a point where the world has no land
    for bad in ({"from": list(start_xy)}, {"from": [1.0, 2.0], "to": ["x", 1.0]}):
        status, err = _post(url + "api/path", bad)
        assert status == 400 and "not two points" in err["error"], bad
    status, err = _post(url + "api/path", {"from": list(start_xy), "to": [10.0, 10.0]})  # landblock 0000
    assert status == 404 and "no terrain there" in err["error"]
