"""The demo's picture: the walk's story on one page (matplotlib).

Left, a top-down map of the four landblocks: terrain shaded from the
north-west and coloured by height, contour lines every 5 m (labelled every
10 m), slopes too steep to walk (normal z below FloorZ) hatched red, the
landblock ids, a scale bar and north. The path is black where the mover
walked, orange where it stood on unwalkable ground and blue (thick) in the
air; each leg is numbered where it starts and has an arrow in its direction
of travel; START and END are marked; events are lettered.

Middle, the village drawn to scale (house with its doorway, pillar, boulder,
platform), with the events that happened there, and the key to every mark.
Right, the story: each numbered leg with its outcome, each lettered event.
Below, the height profile along the path: the mover's height and the ground
under it, leg by leg.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from .demo_map import FLOOR_Z, PathPoint
from .demo_walk import DT, LANDING, WalkResult
from .demo_world import DEMO_LANDBLOCKS, ORIGIN_LANDBLOCK, Footprint, demo_footprints

__all__ = ["EVENT_STYLE", "VILLAGE_BOX", "event_letters", "path_distances", "render_walk"]

WALK_COLOUR = "#111111"
STEEP_COLOUR = "#ff8c00"
AIR_COLOUR = "#1e5aff"
ROOF_COLOUR = "#96502d"
DOOR_COLOUR = "#ebd7aa"
OBJECT_COLOUR = "#7d7d7d"

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


def _segments(path: Sequence[PathPoint]) -> tuple[list[Any], list[str], list[float]]:
    """Line segments of the path, each coloured by the state the mover ended it in."""
    segs, colours, widths = [], [], []
    for a, b in zip(path, path[1:]):
        st = _state(b)
        segs.append([(a.x, a.y), (b.x, b.y)])
        colours.append(_STATE_COLOUR[st])
        widths.append(4.0 if st == "air" else 2.2 if st == "steep" else 1.4)
    return segs, colours, widths


def _leg_starts(res: WalkResult) -> list[int]:
    """Index into the path where each leg starts (the landing is path[0 .. landing.steps])."""
    out, i = [], res.landing.steps
    for leg in res.legs:
        out.append(i)
        i += leg.steps
    return out


def _draw_footprints(ax: Any, footprints: Sequence[Footprint]) -> None:
    from matplotlib.patches import Circle, Rectangle

    for f in footprints:
        if f.shape == "circle":
            ax.add_patch(Circle((f.a[0], f.a[1]), f.a[2], facecolor=OBJECT_COLOUR, edgecolor="black", lw=0.8, zorder=4))
    for f in footprints:
        if f.shape == "rect":
            x0, y0, x1, y1 = f.a
            colour = DOOR_COLOUR if f.kind == "door" else ROOF_COLOUR if f.kind == "building" else OBJECT_COLOUR
            ax.add_patch(Rectangle((x0, y0), x1 - x0, y1 - y0, facecolor=colour,
                                   edgecolor="none" if f.kind == "door" else "black", lw=0.8, zorder=4))


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


def _north_and_scale(ax: Any, metres: float, label: str) -> None:
    from mpl_toolkits.axes_grid1.anchored_artists import AnchoredSizeBar

    ax.add_artist(AnchoredSizeBar(ax.transData, metres, label, "lower left", pad=0.5, sep=4, frameon=True,
                                  size_vertical=metres / 40, fontproperties={"size": 8}))
    ax.annotate("N", xy=(0.96, 0.97), xytext=(0.96, 0.87), xycoords="axes fraction", ha="center", va="center",
                fontsize=11, fontweight="bold", arrowprops={"arrowstyle": "-|>", "color": "black", "lw": 1.5},
                bbox={"boxstyle": "circle,pad=0.2", "fc": "white", "ec": "black", "alpha": 0.8}, zorder=10)


def _path_on(ax: Any, res: WalkResult, labels: list[str], in_box: Callable[[float, float], bool] | None,
             legs: bool, arrow_min_m: float, crowd_m: float) -> None:
    from matplotlib.collections import LineCollection

    path = res.path
    segs, colours, widths = _segments(path)
    ax.add_collection(LineCollection(segs, colors=colours, linewidths=widths, zorder=5, capstyle="round"))
    starts = _leg_starts(res)
    dist = path_distances(path)
    for n, (i0, leg) in enumerate(zip(starts, res.legs), start=1):
        i1 = i0 + leg.steps
        if leg.steps == 0:
            continue
        # direction of travel: an arrow halfway along the leg (when the leg is long enough to carry one)
        mid_d = (dist[i0] + dist[i1]) / 2.0
        k = int(np.searchsorted(dist, mid_d))
        k = min(max(k, i0 + 1), i1)
        a, b = path[k - 1], path[k]
        if dist[i1] - dist[i0] >= arrow_min_m and (in_box is None or in_box(b.x, b.y)):
            ux, uy = b.x - a.x, b.y - a.y
            norm = math.hypot(ux, uy) or 1.0
            ax.annotate("", xy=(b.x + ux / norm * 0.01, b.y + uy / norm * 0.01), xytext=(b.x - ux / norm * arrow_min_m / 4,
                        b.y - uy / norm * arrow_min_m / 4), arrowprops={"arrowstyle": "-|>,head_width=0.35,head_length=0.7",
                        "color": _STATE_COLOUR[_state(b)], "lw": 1.6}, zorder=6)
        if legs:
            p = path[i0]
            if in_box is None or in_box(p.x, p.y):
                ax.annotate(str(n), (p.x, p.y), xytext=(-9, 7), textcoords="offset points", fontsize=8,
                            fontweight="bold", ha="center", va="center", zorder=9,
                            bbox={"boxstyle": "circle,pad=0.18", "fc": "#fff8c0", "ec": "black", "lw": 0.7})
    s, e = path[0], path[-1]
    for (p, text, colour, marker) in ((s, "START", "#00a000", "o"), (e, "END", "#c00000", "s")):
        if in_box is None or in_box(p.x, p.y):
            ax.plot([p.x], [p.y], marker=marker, ms=10, mfc=colour, mec="black", zorder=8, ls="none")
            ax.annotate(text, (p.x, p.y), xytext=(8, -12), textcoords="offset points", fontsize=8,
                        fontweight="bold", color=colour, zorder=9,
                        bbox={"boxstyle": "round,pad=0.15", "fc": "white", "ec": colour, "alpha": 0.85})
    placed: list[tuple[float, float]] = []
    for ev, letter in zip(res.events, labels):
        style = EVENT_STYLE.get(ev.kind)
        if style is None or (in_box is not None and not in_box(ev.x, ev.y)):
            continue
        marker, colour, _ = style
        # letters of events close together are stacked upwards, so that each stays readable
        crowd = sum(1 for (px, py) in placed if math.hypot(px - ev.x, py - ev.y) < crowd_m)
        placed.append((ev.x, ev.y))
        ax.plot([ev.x], [ev.y], marker=marker, ms=8, mfc=colour, mec="white", mew=0.8, ls="none", zorder=7)
        ax.annotate(letter, (ev.x, ev.y), xytext=(7, 2 + 10 * crowd), textcoords="offset points", fontsize=7.5,
                    color=colour, fontweight="bold", zorder=9,
                    bbox={"boxstyle": "round,pad=0.1", "fc": "white", "ec": "none", "alpha": 0.75})


def _key(ax: Any) -> None:
    from matplotlib.lines import Line2D
    from matplotlib.patches import Patch

    handles: list[Any] = [
        Line2D([], [], color=WALK_COLOUR, lw=1.4, label="walking on walkable ground"),
        Line2D([], [], color=STEEP_COLOUR, lw=2.2, label="standing on unwalkable (steep) ground"),
        Line2D([], [], color=AIR_COLOUR, lw=4.0, label="in the air"),
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
    leg_no = {leg.name: n for n, leg in enumerate(res.legs, start=1)}
    lines = [f"The walk: {res.steps} physics steps of {DT:.1f} s.",
             "A player-sized mover (two spheres of 0.48 m) is dropped",
             "onto the hills, then heads for one waypoint after another",
             "(the legs). A leg ends when the mover arrives, or is",
             "blocked: it stops making progress against an obstacle.", "",
             f"0  {LANDING}: {res.landing.outcome}, {res.landing.steps} steps"]
    for n, leg in enumerate(res.legs, start=1):
        lines.append(f"{n:<2} {leg.name}: {leg.outcome}, {leg.steps} steps")
    lines += ["", "events (letters on the map, the village and the profile)"]
    for ev, letter in zip(res.events, labels):
        n = leg_no.get(ev.leg, 0)
        text = ev.text if len(ev.text) <= 72 else ev.text[:69] + "..."
        lines.append(f"{letter:>2} [{n}] {text}")
    ax.text(0.0, 1.0, "\n".join(lines), va="top", ha="left", family="monospace", fontsize=7.0, transform=ax.transAxes)
    ax.axis("off")


def _profile(ax: Any, res: WalkResult, ground_at: Callable[[float, float], float], labels: list[str]) -> None:
    from matplotlib.collections import LineCollection

    path = res.path
    dist = path_distances(path)
    z = np.array([p.z for p in path])
    ground = np.array([ground_at(p.x, p.y) for p in path])
    ax.fill_between(dist, ground, min(ground.min(), z.min()) - 5, color="#c8b48c", zorder=1, label="ground under the path")
    ax.plot(dist, ground, color="#6b5530", lw=0.8, zorder=2)
    segs = [[(dist[i], z[i]), (dist[i + 1], z[i + 1])] for i in range(len(path) - 1)]
    colours = [_STATE_COLOUR[_state(p)] for p in path[1:]]
    widths = [3.0 if _state(p) == "air" else 1.4 for p in path[1:]]
    ax.add_collection(LineCollection(segs, colors=colours, linewidths=widths, zorder=3))
    top = max(z.max(), ground.max()) + 6
    for n, i0 in enumerate(_leg_starts(res), start=1):
        ax.axvline(dist[i0], color="grey", lw=0.5, ls=":", zorder=0)
        ax.text(dist[i0], top, str(n), ha="center", va="bottom", fontsize=7.5, fontweight="bold",
                bbox={"boxstyle": "circle,pad=0.15", "fc": "#fff8c0", "ec": "black", "lw": 0.6})
    for ev, letter in zip(res.events, labels):
        if ev.kind not in EVENT_STYLE:
            continue
        marker, colour, _ = EVENT_STYLE[ev.kind]
        d = dist[min(ev.step, len(dist) - 1)]
        ax.plot([d], [ev.z], marker=marker, ms=6, mfc=colour, mec="white", ls="none", zorder=4)
        ax.annotate(letter, (d, ev.z), xytext=(3, 5), textcoords="offset points", fontsize=6.5, color=colour,
                    fontweight="bold", zorder=5)
    ax.set_xlim(0, dist[-1] if len(dist) else 1)
    ax.set_ylim(min(ground.min(), z.min()) - 5, top + 8)
    ax.set_xlabel("distance walked along the path (m)")
    ax.set_ylabel("height (m)")
    ax.set_title("height profile: the mover (line, coloured as on the map) and the ground under it (brown); "
                 "numbers: where each leg starts", fontsize=9, loc="left")
    ax.grid(True, lw=0.3, alpha=0.5)


def render_walk(res: WalkResult, heights: np.ndarray, step_m: float, ground_at: Callable[[float, float], float],
                out: str | Path | None = None, footprints: Sequence[Footprint] | None = None) -> Any:
    """The picture of the walk `res` over `heights` (row 0 south, `step_m` apart); saved to `out` when given.

    `ground_at(x, y)` is the terrain height at global metres (for the profile). Returns the Figure."""
    import matplotlib

    matplotlib.use("Agg")
    from matplotlib import colormaps
    from matplotlib.colors import Normalize
    from matplotlib.figure import Figure

    footprints = demo_footprints() if footprints is None else footprints
    size_m = heights.shape[0] * step_m
    labels = event_letters(len(res.events))
    fig = Figure(figsize=(20, 14), dpi=100, layout="constrained")
    gs = fig.add_gridspec(2, 3, width_ratios=[2.3, 1.25, 1.35], height_ratios=[3.0, 1.0])
    middle = gs[0, 1].subgridspec(2, 1, height_ratios=[1.15, 1.0])
    ax_map, ax_zoom = fig.add_subplot(gs[0, 0]), fig.add_subplot(middle[0])
    ax_story, ax_prof = fig.add_subplot(gs[0, 2]), fig.add_subplot(gs[1, :])
    ax_key = fig.add_subplot(middle[1])
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
        ax_map.text(bx * 192.0 + 4, by * 192.0 + 188, f"landblock {lb:04X}", fontsize=8, color="white", va="top",
                    fontweight="bold", zorder=3)
    _draw_footprints(ax_map, footprints)
    x0, y0, x1, y1 = VILLAGE_BOX
    from matplotlib.patches import Rectangle

    ax_map.add_patch(Rectangle((x0, y0), x1 - x0, y1 - y0, fill=False, ec="white", lw=1.2, ls="-", zorder=6))
    ax_map.text(x0, y1 + 2, "village (middle panel)", color="white", fontsize=8, fontweight="bold", zorder=6)

    def outside_village(x: float, y: float) -> bool:
        return not (x0 <= x <= x1 and y0 <= y <= y1)

    _path_on(ax_map, res, labels, outside_village, legs=True, arrow_min_m=12.0, crowd_m=8.0)
    ax_map.set_xlim(0, size_m)
    ax_map.set_ylim(0, size_m)
    ax_map.set_aspect("equal")
    ax_map.set_xlabel("x: east (m)")
    ax_map.set_ylabel("y: north (m)")
    ax_map.set_title("acphys demo walk: a player-sized mover driven by physics steps over the demo world",
                     fontsize=11, loc="left")
    _north_and_scale(ax_map, 50.0, "50 m")
    sm = matplotlib.cm.ScalarMappable(norm=norm, cmap=cmap)
    bar = fig.colorbar(sm, ax=ax_map, shrink=0.5, pad=0.01, label="terrain height (m)")
    bar.ax.set_ylim(math.floor(lo), math.ceil(hi))

    _terrain(ax_zoom, heights, step_m, size_m, cmap, norm)
    _draw_footprints(ax_zoom, footprints)
    _path_on(ax_zoom, res, labels, lambda x, y: x0 <= x <= x1 and y0 <= y <= y1, legs=True, arrow_min_m=4.0, crowd_m=2.5)
    for f in footprints:
        if f.kind in ("building", "object") and f.name != "boulder" or (f.name == "boulder" and f.a[2] > 1.0):
            cx = (f.a[0] + f.a[2]) / 2 if f.shape == "rect" else f.a[0]
            top = f.a[3] if f.shape == "rect" else f.a[1] + f.a[2]
            ax_zoom.text(cx, top + 1.0, f.name, ha="center", va="bottom", fontsize=8, zorder=9,
                         bbox={"boxstyle": "round,pad=0.15", "fc": "white", "ec": "none", "alpha": 0.8})
    ax_zoom.set_xlim(x0, x1)
    ax_zoom.set_ylim(y0, y1)
    ax_zoom.set_aspect("equal")
    ax_zoom.set_title("the village, to scale: house, pillar, boulder, platform", fontsize=10, loc="left")
    _north_and_scale(ax_zoom, 10.0, "10 m")

    _key(ax_key)
    _story(ax_story, res, labels)
    _profile(ax_prof, res, ground_at, labels)
    if out is not None:
        fig.savefig(str(out), dpi=100)
    return fig
