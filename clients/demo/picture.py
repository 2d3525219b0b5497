"""The demo's picture: the walk's story on one page (matplotlib).

Left, a top-down map of the four landblocks: terrain shaded from the
north-west and coloured by height, contour lines every 5 m (labelled every
10 m), slopes too steep to walk (normal z below FloorZ) hatched red, the
landblock ids, a scale bar and north. The path is black where the mover
walked, orange where it stood on unwalkable ground and blue (thick) in the
air; each leg is numbered where it starts (from 1, as the printed table
numbers them) and has an arrow in its direction of travel; START and END are
marked; events are lettered. The leg walked along a path the service found
is teal, and the path itself (its waypoints' polyline) is dashed magenta
over it, a dot at each waypoint. Labels are placed clear of each other, of the
objects and of the marks (`clients.demo.labels`), with a leader line where
one had to move away from its mark.

Middle, the village drawn to scale (house with its doorway, pillar, boulder,
platform), with the events that happened there, and the key to every mark.
Right, the story: each numbered leg with its outcome, each lettered event.
Below, the height profile along the path: the mover's height and the ground
under it, leg by leg.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from clients.demo.labels import PanelLabels
from clients.demo.map import FLOOR_Z, PathPoint
from clients.demo.walk import DT, LANDING, WalkResult, numbered_legs
from clients.demo.world import DEMO_LANDBLOCKS, ORIGIN_LANDBLOCK, Footprint, demo_footprints
from clients.demo.label_layout import UP_FIRST

__all__ = ["EVENT_STYLE", "VILLAGE_BOX", "WalkPicture", "event_letters", "footprint_extent", "path_distances",
           "render_walk"]

WALK_COLOUR = "#111111"
STEEP_COLOUR = "#ff8c00"
AIR_COLOUR = "#1e5aff"
ROOF_COLOUR = "#96502d"
DOOR_COLOUR = "#ebd7aa"
OBJECT_COLOUR = "#7d7d7d"
PATH_COLOUR = "#d0009a"  # the path the service answered: its waypoints' polyline
PATH_WALK_COLOUR = "#00897b"  # the track walked along it, move by move

#: event kind -> (marker, colour, legend label); kinds not listed are told in the text only
EVENT_STYLE: dict[str, tuple[str, str, str]] = {
    "collision": ("X", "#dc0000", "collision (wall, object, steep face)"),
    "slide": (">", "#b000b0", "slide along an obstacle"),
    "held_back": ("s", "#dc0000", "held back by a slope too steep to walk"),
    "blocked": ("8", "#600000", "blocked: leg given up"),
    "left_ground": ("^", AIR_COLOUR, "left the ground"),
    "touched_down": ("v", AIR_COLOUR, "touched down"),
    "landed": ("v", AIR_COLOUR, "touched down"),
    "bounced": ("D", AIR_COLOUR, "bounced, came to rest"),
    "step_up": ("P", "#008000", "stepped up"),
    "step_down": ("d", "#008000", "stepped down"),
    "went_in": ("h", ROOF_COLOUR, "went indoors / came out"),
    "came_out": ("h", ROOF_COLOUR, "went indoors / came out"),
}

#: the village (global metres x0, y0, x1, y1): drawn to scale in the middle panel
VILLAGE_BOX = (72.0, 272.0, 144.0, 340.0)


def path_distances(path: Sequence[PathPoint]) -> np.ndarray:
    """Horizontal distance walked up to each point of the path (metres)."""
    xy = np.array([(p.x, p.y) for p in path], dtype=np.float64).reshape(-1, 2)
    if len(xy) < 2:
        return np.zeros(len(xy))
    return np.concatenate([[0.0], np.cumsum(np.hypot(*np.diff(xy, axis=0).T))])


def event_letters(n: int) -> list[str]:
    """a, b, ..., z, aa, ab, ...: one short label per event."""
    out = []
    for i in range(n):
        s = ""
        i += 1
        while i:
            i, r = divmod(i - 1, 26)
            s = chr(ord("a") + r) + s
        out.append(s)
    return out


def _state(p: PathPoint) -> str:
    return "walk" if p.on_walkable else "steep" if p.contact else "air"


_STATE_COLOUR = {"walk": WALK_COLOUR, "steep": STEEP_COLOUR, "air": AIR_COLOUR}


def _on_a_path(res: WalkResult) -> list[bool]:
    """For each segment of the track (path[i] to path[i + 1]): whether it is a move along a found path."""
    out = [False] * max(len(res.path) - 1, 0)
    for i0, leg in zip(_leg_starts(res), res.legs):
        if leg.waypoints:
            out[i0:i0 + leg.steps] = [True] * leg.steps
    return out


def _segment_colour(b: PathPoint, on_path: bool) -> str:
    """A segment's colour: teal along a path (where the mover walks the ground), else by the state it ended in."""
    st = _state(b)
    return PATH_WALK_COLOUR if on_path and st == "walk" else _STATE_COLOUR[st]


def _segments(res: WalkResult) -> tuple[list[Any], list[str], list[float]]:
    """Line segments of the track, each coloured by the state the mover ended it in (teal along a path)."""
    path = res.path
    segs, colours, widths = [], [], []
    for a, b, on_path in zip(path, path[1:], _on_a_path(res)):
        st = _state(b)
        segs.append([(a.x, a.y), (b.x, b.y)])
        colours.append(_segment_colour(b, on_path))
        widths.append(4.0 if st == "air" else 2.2 if st == "steep" or on_path else 1.4)
    return segs, colours, widths


def _leg_starts(res: WalkResult) -> list[int]:
    """Index into the path where each leg starts (the landing is path[0 .. landing.steps])."""
    out, i = [], res.landing.steps
    for leg in res.legs:
        out.append(i)
        i += leg.steps
    return out


def _draw_footprints(ax: Any, footprints: Sequence[Footprint]) -> list[Any]:
    """The buildings and objects seen from above; returns their patches."""
    from matplotlib.patches import Circle, Rectangle

    patches = []
    for f in footprints:
        if f.shape == "circle":
            patches.append(ax.add_patch(Circle((f.a[0], f.a[1]), f.a[2], facecolor=OBJECT_COLOUR, edgecolor="black",
                                               lw=0.8, zorder=4)))
    for f in footprints:
        if f.shape == "rect":
            x0, y0, x1, y1 = f.a
            colour = DOOR_COLOUR if f.kind == "door" else ROOF_COLOUR if f.kind == "building" else OBJECT_COLOUR
            patches.append(ax.add_patch(Rectangle((x0, y0), x1 - x0, y1 - y0, facecolor=colour,
                                                  edgecolor="none" if f.kind == "door" else "black", lw=0.8,
                                                  zorder=4)))
    return patches


def footprint_extent(footprints: Sequence[Footprint], name: str) -> tuple[float, float, float, float]:
    """x0, y0, x1, y1 (global metres) of everything drawn for the object `name`."""
    boxes = [(f.a[0] - f.a[2], f.a[1] - f.a[2], f.a[0] + f.a[2], f.a[1] + f.a[2]) if f.shape == "circle" else f.a
             for f in footprints if f.name == name]
    if not boxes:
        raise KeyError(name)
    return (min(b[0] for b in boxes), min(b[1] for b in boxes), max(b[2] for b in boxes), max(b[3] for b in boxes))


def _terrain(ax: Any, heights: np.ndarray, step_m: float, size_m: float, cmap: Any, norm: Any) -> None:
    from matplotlib.colors import LightSource

    shaded = LightSource(azdeg=315, altdeg=40).shade(heights, cmap=cmap, norm=norm, blend_mode="soft",
                                                     vert_exag=1.0, dx=step_m, dy=step_m)
    # the light source treats row 0 as the top: flip in, flip out, so that the shading is from the north-west
    ax.imshow(shaded, origin="lower", extent=(0, size_m, 0, size_m), interpolation="bilinear", zorder=0)
    xs = (np.arange(heights.shape[1]) + 0.5) * step_m
    ys = (np.arange(heights.shape[0]) + 0.5) * step_m
    lo, hi = math.floor(heights.min() / 5) * 5, math.ceil(heights.max() / 5) * 5
    cs = ax.contour(xs, ys, heights, levels=np.arange(lo, hi + 5, 5), colors="#3b2f20", linewidths=0.4,
                    alpha=0.6, zorder=1)
    major = [lv for lv in cs.levels if lv % 10 == 0]
    ax.clabel(cs, levels=major, fontsize=6, fmt="%d m", inline=True)
    dzdy, dzdx = np.gradient(heights, step_m)
    nz = 1.0 / np.sqrt(1.0 + dzdx**2 + dzdy**2)
    ax.contourf(xs, ys, (nz < FLOOR_Z).astype(float), levels=[0.5, 1.5], colors="none", hatches=["////"], zorder=1)
    ax.contour(xs, ys, (nz < FLOOR_Z).astype(float), levels=[0.5], colors="#c00000", linewidths=0.8, zorder=1)


def _north_and_scale(ax: Any, metres: float, label: str) -> list[Any]:
    """The scale bar (lower left) and the north arrow (upper right); returns both artists."""
    from mpl_toolkits.axes_grid1.anchored_artists import AnchoredSizeBar

    bar = ax.add_artist(AnchoredSizeBar(ax.transData, metres, label, "lower left", pad=0.5, sep=4, frameon=True,
                                        size_vertical=metres / 40, fontproperties={"size": 8}))
    north = ax.annotate("N", xy=(0.96, 0.97), xytext=(0.96, 0.87), xycoords="axes fraction", ha="center", va="center",
                fontsize=11, fontweight="bold", arrowprops={"arrowstyle": "-|>", "color": "black", "lw": 1.5},
                bbox={"boxstyle": "circle,pad=0.2", "fc": "white", "ec": "black", "alpha": 0.8}, zorder=10)
    return [bar, north]


def _path_on(labels: PanelLabels, res: WalkResult, letters: list[str], in_box: Callable[[float, float], bool],
             arrow_min_m: float, ends_anywhere: bool) -> None:
    """The path, its legs' arrows and numbers, START and END, and the events, on `labels.ax`.

    Only what lies inside `in_box` is marked; START and END also outside it when `ends_anywhere`
    (the whole map marks them wherever they are, the village only when they are in it)."""
    from matplotlib.collections import LineCollection

    ax = labels.ax
    path = res.path
    segs, colours, widths = _segments(res)
    ax.add_collection(LineCollection(segs, colors=colours, linewidths=widths, zorder=5, capstyle="round"))
    labels.soft.extend((p.x, p.y) for p in path)
    for leg in res.legs:  # the path asked for, over the track walked along it
        if leg.waypoints:
            xs, ys = [w[0] for w in leg.waypoints], [w[1] for w in leg.waypoints]
            ax.plot(xs, ys, color=PATH_COLOUR, lw=1.4, ls=(0, (4, 2)), marker="o", ms=3.5, mec="white", mew=0.5,
                    zorder=6, gid="found_path")
            labels.soft.extend(zip(xs, ys))
    dist = path_distances(path)
    for i0, (n, leg) in zip(_leg_starts(res), numbered_legs(res.legs)):
        i1 = i0 + leg.steps
        if leg.steps == 0:
            continue
        # direction of travel: an arrow halfway along the leg (when the leg is long enough to carry one)
        mid_d = (dist[i0] + dist[i1]) / 2.0
        k = int(np.searchsorted(dist, mid_d))
        k = min(max(k, i0 + 1), i1)
        a, b = path[k - 1], path[k]
        if dist[i1] - dist[i0] >= arrow_min_m and in_box(b.x, b.y):
            ux, uy = b.x - a.x, b.y - a.y
            norm = math.hypot(ux, uy) or 1.0
            ax.annotate("", xy=(b.x + ux / norm * 0.01, b.y + uy / norm * 0.01), xytext=(b.x - ux / norm * arrow_min_m / 4,
                        b.y - uy / norm * arrow_min_m / 4), arrowprops={"arrowstyle": "-|>,head_width=0.35,head_length=0.7",
                        "color": _STATE_COLOUR[_state(b)], "lw": 1.6}, zorder=6)
        p = path[i0]
        if in_box(p.x, p.y):
            labels.add(str(n), (p.x, p.y), priority=2, fontsize=8, fontweight="bold", zorder=9,
                       bbox={"boxstyle": "circle,pad=0.18", "fc": "#fff8c0", "ec": "black", "lw": 0.7})
    s, e = path[0], path[-1]
    for (p, text, colour, marker) in ((s, "START", "#00a000", "o"), (e, "END", "#c00000", "s")):
        if ends_anywhere or in_box(p.x, p.y):
            ax.plot([p.x], [p.y], marker=marker, ms=10, mfc=colour, mec="black", zorder=8, ls="none")
            labels.marker(p.x, p.y, 10.0)
            labels.add(text, (p.x, p.y), priority=1, leader_colour=colour, fontsize=8, fontweight="bold",
                       color=colour, zorder=9, bbox={"boxstyle": "round,pad=0.15", "fc": "white", "ec": colour,
                                                     "alpha": 0.85})
    for ev, letter in zip(res.events, letters):
        style = EVENT_STYLE.get(ev.kind)
        if style is None or not in_box(ev.x, ev.y):
            continue
        marker, colour, _ = style
        ax.plot([ev.x], [ev.y], marker=marker, ms=8, mfc=colour, mec="white", mew=0.8, ls="none", zorder=7)
        labels.marker(ev.x, ev.y, 8.0)
        labels.add(letter, (ev.x, ev.y), priority=3, leader_colour=colour, fontsize=7.5, color=colour,
                   fontweight="bold", zorder=9, bbox={"boxstyle": "round,pad=0.1", "fc": "white", "ec": "none",
                                                      "alpha": 0.75})


def _key(ax: Any) -> None:
    from matplotlib.lines import Line2D
    from matplotlib.patches import Patch

    handles: list[Any] = [
        Line2D([], [], color=WALK_COLOUR, lw=1.4, label="walking on walkable ground"),
        Line2D([], [], color=STEEP_COLOUR, lw=2.2, label="standing on unwalkable (steep) ground"),
        Line2D([], [], color=AIR_COLOUR, lw=4.0, label="in the air"),
        Line2D([], [], color=PATH_WALK_COLOUR, lw=2.2, label="walked along the path, by moves of 3 m at most"),
        Line2D([], [], color=PATH_COLOUR, lw=1.4, ls=(0, (4, 2)), marker="o", ms=3.5, mec="white",
               label="the path the service found (its waypoints)"),
        Line2D([], [], marker="o", ms=9, mfc="#00a000", mec="black", ls="none", label="start"),
        Line2D([], [], marker="s", ms=9, mfc="#c00000", mec="black", ls="none", label="end"),
        Line2D([], [], marker="$1$", ms=8, color="black", ls="none", label="leg number, where the leg starts"),
    ]
    seen = set()
    for marker, colour, label in EVENT_STYLE.values():
        if label not in seen:
            seen.add(label)
            handles.append(Line2D([], [], marker=marker, ms=8, mfc=colour, mec="white", color=colour, ls="none",
                                  label=label))
    handles += [
        Patch(facecolor="none", edgecolor="#c00000", hatch="////", label=f"slope too steep to walk (normal z < {FLOOR_Z:.2f})"),
        Patch(facecolor=ROOF_COLOUR, edgecolor="black", label="building (house), doorway light"),
        Patch(facecolor=OBJECT_COLOUR, edgecolor="black", label="object (pillar, boulder, platform)"),
        Line2D([], [], color="#3b2f20", lw=0.6, label="contour every 5 m"),
    ]
    ax.legend(handles=handles, loc="upper left", fontsize=7.5, frameon=True, title="key", title_fontsize=9,
              borderaxespad=0.0)
    ax.axis("off")


def _story(ax: Any, res: WalkResult, labels: list[str]) -> None:
    leg_no = {leg.name: str(n) for n, leg in numbered_legs(res.legs)}
    lines = [f"The walk: {res.steps - res.moves} physics steps of {DT:.1f} s and {res.moves} moves.",
             "A player-sized mover (two spheres of 0.48 m) is dropped",
             "onto the hills, then heads for one waypoint after another",
             "(the legs). A leg ends when the mover arrives, or is",
             "blocked: it stops making progress against an obstacle.",
             "One leg asks the service for a path (Client.path) and",
             "walks it by moves of 3 m at most toward each waypoint.", "",
             f"-  {LANDING}: {res.landing.outcome}, {res.landing.steps} steps"]
    for n, leg in numbered_legs(res.legs):
        lines.append(f"{n:<2} {leg.name}: {leg.outcome}, {leg.steps} {'moves' if leg.waypoints else 'steps'}")
    lines += ["", "events (letters on the map, the village and the profile)"]
    for ev, letter in zip(res.events, labels):
        on_leg = leg_no.get(ev.leg, "-")  # the landing's events: no leg number
        text = ev.text if len(ev.text) <= 72 else ev.text[:69] + "..."
        lines.append(f"{letter:>2} [{on_leg}] {text}")
    ax.text(0.0, 1.0, "\n".join(lines), va="top", ha="left", family="monospace", fontsize=7.0, transform=ax.transAxes)
    ax.axis("off")


#: where a leg's number goes on the profile: on its line's top end, else above or below it on the line
#: (moved sideways it would look like a neighbour's number)
_ON_THE_LINE = ((0, 0), (0, 1), (0, -1))


def _profile(labels: PanelLabels, res: WalkResult, ground_at: Callable[[float, float], float],
             letters: list[str]) -> None:
    from matplotlib.collections import LineCollection

    ax = labels.ax
    path = res.path
    dist = path_distances(path)
    z = np.array([p.z for p in path])
    ground = np.array([ground_at(p.x, p.y) for p in path])
    ax.fill_between(dist, ground, min(ground.min(), z.min()) - 5, color="#c8b48c", zorder=1, label="ground under the path")
    ax.plot(dist, ground, color="#6b5530", lw=0.8, zorder=2)
    segs = [[(dist[i], z[i]), (dist[i + 1], z[i + 1])] for i in range(len(path) - 1)]
    on_path = _on_a_path(res)
    colours = [_segment_colour(p, o) for p, o in zip(path[1:], on_path)]
    widths = [3.0 if _state(p) == "air" else 1.4 for p in path[1:]]
    ax.add_collection(LineCollection(segs, colors=colours, linewidths=widths, zorder=3))
    top = max(z.max(), ground.max()) + 6
    labels.soft.extend(zip(dist.tolist(), z.tolist()))
    for i0, (n, _leg) in zip(_leg_starts(res), numbered_legs(res.legs)):
        ax.axvline(dist[i0], color="grey", lw=0.5, ls=":", zorder=0)
        labels.add(str(n), (float(dist[i0]), float(top)), priority=1, directions=_ON_THE_LINE, fontsize=7.5,
                   fontweight="bold", zorder=6, bbox={"boxstyle": "circle,pad=0.15", "fc": "#fff8c0", "ec": "black",
                                                      "lw": 0.6})
    for ev, letter in zip(res.events, letters):
        if ev.kind not in EVENT_STYLE:
            continue
        marker, colour, _ = EVENT_STYLE[ev.kind]
        d = float(dist[min(ev.step, len(dist) - 1)])
        ax.plot([d], [ev.z], marker=marker, ms=6, mfc=colour, mec="white", ls="none", zorder=4)
        labels.marker(d, ev.z, 6.0)
        labels.add(letter, (d, ev.z), priority=2, leader_colour=colour, fontsize=6.5, color=colour,
                   fontweight="bold", zorder=5, bbox={"boxstyle": "round,pad=0.1", "fc": "white", "ec": "none",
                                                      "alpha": 0.75})
    ax.set_xlim(0, dist[-1] if len(dist) else 1)
    ax.set_ylim(min(ground.min(), z.min()) - 5, top + 10)
    ax.set_xlabel("distance walked along the path (m)")
    ax.set_ylabel("height (m)")
    ax.set_title("height profile: the mover (line, coloured as on the map) and the ground under it (brown); "
                 "numbers: where each leg starts", fontsize=9, loc="left")
    ax.grid(True, lw=0.3, alpha=0.5)


@dataclass(slots=True)
class WalkPicture:
    """The drawn picture and where its labels went on each panel (display pixels, `PanelLabels.placements`)."""

    figure: Any
    map_labels: PanelLabels
    village_labels: PanelLabels
    profile_labels: PanelLabels


def render_walk(res: WalkResult, heights: np.ndarray, step_m: float, ground_at: Callable[[float, float], float],
                out: str | Path | None = None, footprints: Sequence[Footprint] | None = None) -> WalkPicture:
    """The picture of the walk `res` over `heights` (row 0 south, `step_m` apart); saved to `out` when given.

    `ground_at(x, y)` is the terrain height at global metres (for the profile)."""
    import matplotlib

    matplotlib.use("Agg")
    from matplotlib import colormaps
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.colors import Normalize
    from matplotlib.figure import Figure
    from matplotlib.patches import Rectangle

    footprints = demo_footprints() if footprints is None else footprints
    size_m = heights.shape[0] * step_m
    letters = event_letters(len(res.events))
    fig = Figure(figsize=(20, 14), dpi=100, layout="constrained")
    canvas = FigureCanvasAgg(fig)
    gs = fig.add_gridspec(2, 3, width_ratios=[2.3, 1.25, 1.35], height_ratios=[3.0, 1.0])
    middle = gs[0, 1].subgridspec(2, 1, height_ratios=[1.15, 1.0])
    ax_map, ax_zoom = fig.add_subplot(gs[0, 0]), fig.add_subplot(middle[0])
    ax_story, ax_prof = fig.add_subplot(gs[0, 2]), fig.add_subplot(gs[1, :])
    ax_key = fig.add_subplot(middle[1])
    on_map, on_village, on_profile = PanelLabels(ax_map), PanelLabels(ax_zoom), PanelLabels(ax_prof)
    cmap = colormaps["gist_earth"]
    # the colour scale starts well below the lowest ground, so that low hills read green, not sea blue
    lo, hi = float(heights.min()), float(heights.max())
    norm = Normalize(vmin=lo - 45.0, vmax=hi + 5.0)

    _terrain(ax_map, heights, step_m, size_m, cmap, norm)
    for v in np.arange(192.0, size_m, 192.0):
        ax_map.axvline(v, color="white", lw=1.0, ls="--", alpha=0.8, zorder=2)
        ax_map.axhline(v, color="white", lw=1.0, ls="--", alpha=0.8, zorder=2)
    ox, oy = ORIGIN_LANDBLOCK >> 8, ORIGIN_LANDBLOCK & 0xFF
    for lb in DEMO_LANDBLOCKS:
        bx, by = (lb >> 8) - ox, (lb & 0xFF) - oy
        on_map.artists.append(ax_map.text(bx * 192.0 + 4, by * 192.0 + 188, f"landblock {lb:04X}", fontsize=8,
                                          color="white", va="top", fontweight="bold", zorder=3))
    on_map.artists += _draw_footprints(ax_map, footprints)
    x0, y0, x1, y1 = VILLAGE_BOX
    ax_map.add_patch(Rectangle((x0, y0), x1 - x0, y1 - y0, fill=False, ec="white", lw=1.2, ls="-", zorder=6))
    on_map.artists.append(ax_map.text(x0, y1 + 2, "village (middle panel)", color="white", fontsize=8,
                                      fontweight="bold", zorder=6))

    def in_village(x: float, y: float) -> bool:
        return x0 <= x <= x1 and y0 <= y <= y1

    _path_on(on_map, res, letters, lambda x, y: not in_village(x, y), arrow_min_m=12.0, ends_anywhere=True)
    ax_map.set_xlim(0, size_m)
    ax_map.set_ylim(0, size_m)
    ax_map.set_aspect("equal")
    ax_map.set_xlabel("x: east (m)")
    ax_map.set_ylabel("y: north (m)")
    ax_map.set_title("acphys demo walk: a player-sized mover driven by physics steps over the demo world",
                     fontsize=11, loc="left")
    on_map.artists += _north_and_scale(ax_map, 50.0, "50 m")
    sm = matplotlib.cm.ScalarMappable(norm=norm, cmap=cmap)
    bar = fig.colorbar(sm, ax=ax_map, shrink=0.5, pad=0.01, label="terrain height (m)")
    bar.ax.set_ylim(math.floor(lo), math.ceil(hi))

    _terrain(ax_zoom, heights, step_m, size_m, cmap, norm)
    on_village.artists += _draw_footprints(ax_zoom, footprints)
    for name in dict.fromkeys(f.name for f in footprints if f.kind in ("building", "object")):
        fx0, _, fx1, fy1 = footprint_extent(footprints, name)
        on_village.add(name, ((fx0 + fx1) / 2.0, fy1), priority=0, directions=UP_FIRST, fontsize=8, zorder=9,
                       bbox={"boxstyle": "round,pad=0.15", "fc": "white", "ec": "none", "alpha": 0.8})
    _path_on(on_village, res, letters, in_village, arrow_min_m=4.0, ends_anywhere=False)
    ax_zoom.set_xlim(x0, x1)
    ax_zoom.set_ylim(y0, y1)
    ax_zoom.set_aspect("equal")
    ax_zoom.set_title("the village, to scale: house, pillar, boulder, platform", fontsize=10, loc="left")
    on_village.artists += _north_and_scale(ax_zoom, 10.0, "10 m")

    _key(ax_key)
    _story(ax_story, res, letters)
    _profile(on_profile, res, ground_at, letters)
    # lay the panels out and draw once, so that every size is known; then place the labels and keep the layout
    canvas.draw()
    fig.set_layout_engine("none")
    renderer = canvas.get_renderer()
    for panel in (on_map, on_village, on_profile):
        panel.place(renderer, fig.dpi)
    if out is not None:
        fig.savefig(str(out), dpi=100)
    return WalkPicture(fig, on_map, on_village, on_profile)
