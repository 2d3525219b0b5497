"""The demo picture: what it tells, and where its labels go.

The label placer (`clients.demo.label_layout`) is checked on hand-made geometry;
the picture is checked through the figure's own layout data (each label's
drawn box, each object's extent, in display pixels), never its pixels.
"""

from __future__ import annotations

import json
import math
from itertools import combinations
from typing import Any

import pytest

from clients.demo.command import _table
from clients.demo.walk import WalkResult, walk_demo
from clients.demo.world import build_demo_scene, demo_footprints, global_to_cell
from clients.demo.label_layout import Box, Label, place_labels
from engine import world_from_scene_dict
from support.demo_engine_client import EngineClient


# -- the placer, on hand-made geometry -------------------------------------------------------------
BOUNDS = Box(-100.0, -100.0, 100.0, 100.0)


def test_a_free_label_goes_to_its_first_direction_next_to_its_anchor() -> None:
    (p,) = place_labels([Label((0.0, 0.0), 4.0, 2.0)], [], BOUNDS, gap=1.0, step=3.0)
    assert p.box == Box(1.0, 1.0, 5.0, 3.0)  # up and right of the anchor, one gap away
    assert p.ring == 0 and not p.leader and p.clear


def test_an_obstacle_sends_the_label_to_its_next_direction() -> None:
    rock = Box(2.0, 2.0, 3.0, 3.0)  # inside the up-right place (1, 1)-(5, 3)
    (p,) = place_labels([Label((0.0, 0.0), 4.0, 2.0)], [rock], BOUNDS, gap=1.0, step=3.0)
    assert p.box == Box(1.0, -1.0, 5.0, 1.0)  # right, centred on the anchor's height
    assert p.box.overlap(rock) == 0.0 and not p.leader


def test_labels_on_one_anchor_do_not_cover_each_other() -> None:
    labels = [Label((10.0, 10.0), 6.0, 3.0) for _ in range(9)]
    placed = place_labels(labels, [], BOUNDS, gap=1.0, step=2.0)
    for a, b in combinations(placed, 2):
        assert a.box.overlap(b.box) == 0.0
    assert all(p.clear and p.box.inside(BOUNDS) for p in placed)
    assert placed[0].box == Box(11.0, 11.0, 17.0, 14.0) and not placed[0].leader
    # ring 0 lies within 1 + 6 of the anchor across and 1 + 3 up and down: 14 x 8 = 112, room for six boxes
    # of 18 at most, so at least three of the nine went further out, each with a leader line
    assert sum(p.leader for p in placed) >= 3
    assert all(p.leader == (p.ring > 0) for p in placed)


def test_a_label_walled_in_moves_out_a_ring_and_gets_a_leader() -> None:
    wall = Box(-6.0, -6.0, 6.0, 6.0)  # every ring-0 place (within 1 + 2 of the anchor) is inside it
    (p,) = place_labels([Label((0.0, 0.0), 2.0, 1.0)], [wall], BOUNDS, gap=1.0, step=10.0)
    assert p.ring == 1 and p.leader and p.clear
    assert p.box == Box(11.0, 11.0, 13.0, 12.0)


def test_the_soft_points_are_kept_off_when_the_ring_allows() -> None:
    path_point = (3.0, 2.0)  # inside the up-right place
    (p,) = place_labels([Label((0.0, 0.0), 4.0, 2.0)], [], BOUNDS, gap=1.0, step=3.0, soft=[path_point])
    assert p.box == Box(1.0, -1.0, 5.0, 1.0) and not p.box.contains(*path_point)


def test_a_label_at_the_edge_is_slid_inside_the_bounds() -> None:
    bounds = Box(0.0, 0.0, 20.0, 20.0)
    (p,) = place_labels([Label((18.0, 10.0), 4.0, 2.0)], [], bounds, gap=1.0, step=3.0)
    assert p.box.inside(bounds)
    assert p.box == Box(16.0, 11.0, 20.0, 13.0)  # up-right, slid 3 left to end at the edge


def test_with_no_clear_place_the_least_covered_one_is_taken() -> None:
    bounds = Box(0.0, 0.0, 10.0, 10.0)
    fog = Box(0.0, 0.0, 10.0, 10.0)  # covers every place: each 2 x 2 box overlaps it by 4
    thick = Box(5.0, 5.0, 10.0, 10.0)  # and the up-right quarter twice
    (p,) = place_labels([Label((5.0, 5.0), 2.0, 2.0)], [fog, thick], bounds, gap=1.0, step=1.0, rings=2)
    assert not p.clear
    # up-right (6, 6)-(8, 8) overlaps 4 + 4, right (6, 4)-(8, 6) 4 + 2, up-left (2, 6)-(4, 8) only the 4 of the fog
    assert p.box == Box(2.0, 6.0, 4.0, 8.0)


# -- the picture --------------------------------------------------------------------------------------
@pytest.fixture(scope="module")
def walk() -> WalkResult:
    scene = build_demo_scene()
    return walk_demo(EngineClient(world_from_scene_dict(json.loads(json.dumps(scene)))))  # type: ignore[arg-type]


@pytest.fixture(scope="module")
def picture(walk: WalkResult, tmp_path_factory: pytest.TempPathFactory) -> Any:
    pytest.importorskip("matplotlib")
    from clients.demo.map import height_grid
    from clients.demo.picture import render_walk

    world = world_from_scene_dict(build_demo_scene())

    def ground(x: float, y: float) -> float:
        c, lx, ly = global_to_cell(x, y)
        return world.terrain_height(c, lx, ly)

    out = tmp_path_factory.mktemp("picture") / "walk.png"
    pic = render_walk(walk, height_grid(ground, 384, 4.0), 4.0, ground, out)
    assert out.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    return pic


def _drawn_box(artist: Any, renderer: Any) -> Box:
    e = artist.get_window_extent(renderer)
    return Box(e.x0, e.y0, e.x1, e.y1)


def _labels(panel: Any, renderer: Any) -> list[tuple[str, Box]]:
    """Each placed label's text and its drawn box (the box round its text, as matplotlib laid it out)."""
    out = []
    for text, _ in panel.placements:
        patch = text.get_bbox_patch()
        out.append((text.get_text(), _drawn_box(patch if patch is not None else text, renderer)))
    return out


def _data_box(ax: Any, x0: float, y0: float, x1: float, y1: float) -> Box:
    (a, b), (c, d) = ax.transData.transform([(x0, y0), (x1, y1)])
    return Box(min(a, c), min(b, d), max(a, c), max(b, d))


def test_no_label_in_the_village_covers_another_an_object_or_a_mark(picture: Any, walk: WalkResult) -> None:
    from clients.demo.picture import VILLAGE_BOX

    renderer = picture.figure.canvas.get_renderer()
    ax = picture.village_labels.ax
    labels = _labels(picture.village_labels, renderer)
    texts = [t for t, _ in labels]
    assert {"m", "n", "o", "p", "q", "11", "12", "END", "boulder"} <= set(texts)  # the crowded ones are there
    for (ta, a), (tb, b) in combinations(labels, 2):
        assert a.overlap(b) == 0.0, (ta, tb)
    # the objects as the scene has them (circles as their squares), the boulder's two spheres among them
    objects = []
    for f in demo_footprints():
        x0, y0, x1, y1 = (f.a[0] - f.a[2], f.a[1] - f.a[2], f.a[0] + f.a[2], f.a[1] + f.a[2]) \
            if f.shape == "circle" else f.a
        objects.append((f.name, _data_box(ax, x0, y0, x1, y1)))
    assert sum(name == "boulder" for name, _ in objects) == 2
    for t, box in labels:
        for name, obj in objects:
            assert box.overlap(obj) == 0.0, (t, name)
    # and no label sits on an event's mark (its point), its own or another's
    vx0, vy0, vx1, vy1 = VILLAGE_BOX
    for e in walk.events:
        if vx0 <= e.x <= vx1 and vy0 <= e.y <= vy1:
            (px, py), = ax.transData.transform([(e.x, e.y)])
            assert not any(box.contains(px, py) for _, box in labels), e


def test_labels_stay_in_their_panels_and_clear_of_each_other(picture: Any) -> None:
    renderer = picture.figure.canvas.get_renderer()
    for panel in (picture.map_labels, picture.village_labels, picture.profile_labels):
        frame = _drawn_box(panel.ax, renderer)
        labels = _labels(panel, renderer)
        assert labels
        for t, box in labels:
            assert box.inside(frame), t
        for (ta, a), (tb, b) in combinations(labels, 2):
            assert a.overlap(b) == 0.0, (ta, tb)
    # the main map's labels keep off its scale bar and north arrow, and the village's off theirs
    for panel in (picture.map_labels, picture.village_labels):
        fixed = [a for a in panel.ax.artists] + [t for t in panel.ax.texts if t.get_text() == "N"]
        assert len(fixed) == 2
        for t, box in _labels(panel, renderer):
            assert all(box.overlap(_drawn_box(a, renderer)) == 0.0 for a in fixed), t


def test_a_label_moved_away_from_its_mark_has_a_leader_line(picture: Any) -> None:
    renderer = picture.figure.canvas.get_renderer()
    moved = 0
    for panel in (picture.map_labels, picture.village_labels, picture.profile_labels):
        for text, placement in panel.placements:
            (ax_px, ay_px), = panel.ax.transData.transform([text.xy])
            box = _drawn_box(text.get_bbox_patch(), renderer)
            # how far the box is from its anchor point
            gap = math.hypot(max(box.x0 - ax_px, 0.0, ax_px - box.x1), max(box.y0 - ay_px, 0.0, ay_px - box.y1))
            if gap > 10.0:  # more than the first ring's 7 px (plus a slide inside the panel)
                assert text.arrow_patch.get_visible(), text.get_text()
                moved += 1
            assert text.arrow_patch.get_visible() == placement.leader
    assert moved >= 1  # the village is crowded enough that some had to move


def test_start_and_end_are_on_the_main_map(picture: Any, walk: WalkResult) -> None:
    marks = {t.get_text(): t.xy for t, _ in picture.map_labels.placements}
    first, last = walk.path[0], walk.path[-1]
    assert marks["START"] == pytest.approx((first.x, first.y))
    assert marks["END"] == pytest.approx((last.x, last.y))
    village = {t.get_text() for t, _ in picture.village_labels.placements}
    assert "END" in village and "START" not in village  # the walk ends in the village and starts far from it


def test_the_table_and_the_pictures_number_the_legs_alike(picture: Any, walk: WalkResult) -> None:
    rows = _table(walk).splitlines()[2:-2]
    numbered = [r for r in rows if r[:2].strip().isdigit()]
    assert len(numbered) == len(walk.legs) and rows[0] not in numbered  # the landing has no number
    table_start: dict[int, tuple[float, float]] = {}
    for r in numbered:
        start = r[37:59].strip().strip("()").split(",")
        table_start[int(r[:2])] = (float(start[0]), float(start[1]))
    # every leg number on the map or in the village sits where the table says that leg starts
    on_maps = {}
    for panel in (picture.map_labels, picture.village_labels):
        for t, _ in panel.placements:
            if t.get_text().isdigit():
                on_maps[int(t.get_text())] = t.xy
    assert min(on_maps) == min(table_start)
    assert sorted(on_maps) == sorted(table_start)
    for n, xy in on_maps.items():
        assert xy == pytest.approx(table_start[n], abs=0.051), n
    profile = sorted(int(t.get_text()) for t, _ in picture.profile_labels.placements if t.get_text().isdigit())
    assert profile == sorted(table_start)
    story = "\n".join(t.get_text() for t in picture.figure.axes[2].texts).splitlines()
    story_numbers = [int(ln[:2]) for ln in story if ln[:2].strip().isdigit()]
    assert story_numbers == sorted(table_start)


def test_the_picture_tells_the_walk(picture: Any, walk: WalkResult) -> None:
    from clients.demo.picture import EVENT_STYLE, VILLAGE_BOX, event_letters

    res, fig = walk, picture.figure
    ax_map, ax_zoom, ax_story, ax_prof = fig.axes[:4]

    def texts(ax: Any) -> list[str]:
        return [t.get_text() for t in ax.texts]

    map_texts, zoom_texts = texts(ax_map), texts(ax_zoom)
    # every leg numbered where it starts (on the map, or in the village for legs starting there)
    x0, y0, x1, y1 = VILLAGE_BOX
    for n in range(1, len(res.legs) + 1):
        assert str(n) in map_texts + zoom_texts, n
    assert "START" in map_texts and "END" in map_texts and "END" in zoom_texts  # it ends in the village
    assert {"N", "50 m"} <= set(map_texts) | {t.get_text() for a in ax_map.artists for t in _all_texts(a)}
    # every labelled event has its letter on the map or the village, and in the profile
    letters = event_letters(len(res.events))
    for e, letter in zip(res.events, letters):
        if e.kind in EVENT_STYLE:
            inside = x0 <= e.x <= x1 and y0 <= e.y <= y1
            assert letter in (zoom_texts if inside else map_texts), (letter, e)
            assert letter in texts(ax_prof), (letter, e)
    # the story says every leg and every event in words
    story = "\n".join(texts(ax_story))
    assert all(leg.name in story for leg in res.legs)
    assert all(e.text[:40] in story for e in res.events)
    assert f"{res.steps - res.moves} physics steps" in story and f"{res.moves} moves" in story
    # the key names every kind of mark drawn
    legend = fig.axes[4].get_legend()
    labels = {t.get_text() for t in legend.get_texts()}
    assert {style[2] for style in EVENT_STYLE.values()} <= labels
    assert {"in the air", "start", "end"} <= labels
    # the profile spans the whole walk and reaches the mesa's top
    assert ax_prof.get_xlim()[1] == pytest.approx(sum(math.hypot(b.x - a.x, b.y - a.y)
                                                      for a, b in zip(res.path, res.path[1:])))
    assert ax_prof.get_ylim()[1] > 90.0


def _all_texts(artist: Any) -> list[Any]:
    from matplotlib.text import Text

    return [a for a in artist.findobj(Text)]


def test_the_path_and_the_track_along_it_are_drawn(picture: Any, walk: WalkResult) -> None:
    from matplotlib.collections import LineCollection
    from matplotlib.colors import to_hex

    from clients.demo.picture import PATH_COLOUR, PATH_WALK_COLOUR

    (leg,) = [leg for leg in walk.legs if leg.waypoints]
    fig = picture.figure
    ax_map, ax_zoom = fig.axes[:2]
    for ax in (ax_map, ax_zoom):  # the path's polyline, through its waypoints, on the map and in the village
        (line,) = [ln for ln in ax.get_lines() if ln.get_gid() == "found_path"]
        assert line.get_xydata().ravel().tolist() == pytest.approx([c for w in leg.waypoints for c in w[:2]])
        assert to_hex(line.get_color()) == PATH_COLOUR and line.get_linestyle() != "-"
    # the track walked along it: a segment per move, in its own colour, and none elsewhere on the walk
    (track,) = [c for c in ax_map.collections if isinstance(c, LineCollection) and len(c.get_segments()) == walk.steps]
    teal = [i for i, c in enumerate(track.get_colors()) if to_hex(c) == PATH_WALK_COLOUR]
    start = walk.landing.steps + sum(lg.steps for lg in walk.legs[:walk.legs.index(leg)])
    assert teal == list(range(start, start + leg.steps))
    # and the key tells both
    labels = {t.get_text() for t in fig.axes[4].get_legend().get_texts()}
    assert {"the path the service found (its waypoints)", "walked along the path, by moves of 3 m at most"} <= labels
