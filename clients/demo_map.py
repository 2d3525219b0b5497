"""The demo's picture: a top-down map of terrain heights with the walk on it.

Terrain is coloured by height and shaded from the north-west; slopes too
steep to walk (normal z below FloorZ) are tinted red. The path is black
where the mover stood on walkable ground, orange where it touched
unwalkable ground and blue in the air; red crosses mark collisions, a white
square the start and a black square the end. Buildings are drawn as brown
roofs outlined in black with their doorways left light, objects as grey
shapes outlined in black (`clients.demo_world.demo_footprints`).
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np

from .demo_world import Footprint, demo_footprints

__all__ = ["FLOOR_Z", "PathPoint", "draw_footprints", "height_grid", "render_map"]

FLOOR_Z = 0.66417414618662751  # the client's walkable limit (engine.constants.FLOOR_Z)

WALK = (15, 15, 15)
TOUCH = (255, 140, 0)
AIR = (30, 90, 255)
HIT = (220, 0, 0)
ROOF = (150, 75, 45)
DOORWAY = (235, 215, 170)
OBJECT = (125, 125, 125)
OUTLINE = (0, 0, 0)


@dataclass(slots=True)
class PathPoint:
    """One resolved position of the walk, in global map metres."""

    x: float
    y: float
    contact: bool
    on_walkable: bool
    collided: bool
    z: float = 0.0


def height_grid(height_at: Callable[[float, float], float], size_m: int, step_m: float = 1.0) -> np.ndarray:
    """Heights sampled at cell centres; row 0 is the south edge."""
    n = int(size_m / step_m)
    grid = np.empty((n, n), dtype=np.float64)
    for j in range(n):
        y = (j + 0.5) * step_m
        for i in range(n):
            grid[j, i] = height_at((i + 0.5) * step_m, y)
    return grid


_STOPS = np.array([0.0, 0.3, 0.55, 0.8, 1.0])
_COLOURS = np.array([(52, 120, 60), (118, 160, 74), (168, 140, 88), (150, 120, 100), (245, 245, 240)], dtype=np.float64)


def _terrain_rgb(heights: np.ndarray, step_m: float) -> np.ndarray:
    lo, hi = float(heights.min()), float(heights.max())
    t = (heights - lo) / max(hi - lo, 1e-9)
    rgb = np.stack([np.interp(t, _STOPS, _COLOURS[:, c]) for c in range(3)], axis=-1)
    dzdy, dzdx = np.gradient(heights, step_m)
    nz = 1.0 / np.sqrt(1.0 + dzdx**2 + dzdy**2)
    light = np.array([-1.0, 1.0, 1.5]) / np.linalg.norm([-1.0, 1.0, 1.5])  # from the north-west, above
    shade = np.clip((-dzdx * light[0] - dzdy * light[1] + light[2]) * nz, 0.0, 1.0)
    rgb *= (0.45 + 0.55 * shade)[..., None]
    steep = nz < FLOOR_Z
    rgb[steep] = rgb[steep] * 0.55 + np.array([200.0, 40.0, 40.0]) * 0.45
    return rgb


def _dot(img: np.ndarray, px: float, py: float, colour: tuple[int, int, int], r: int) -> None:
    h, w, _ = img.shape
    x0, y0 = int(px), int(py)
    img[max(0, y0 - r):min(h, y0 + r + 1), max(0, x0 - r):min(w, x0 + r + 1)] = colour


def _cross(img: np.ndarray, px: float, py: float, colour: tuple[int, int, int], r: int) -> None:
    h, w, _ = img.shape
    for d in range(-r, r + 1):
        for x, y in ((px + d, py + d), (px + d, py - d)):
            xi, yi = int(x), int(y)
            if 0 <= xi < w and 0 <= yi < h:
                img[yi, xi] = colour


def _fill(img: np.ndarray, x0: float, y0: float, x1: float, y1: float, colour: tuple[int, int, int],
          outline: bool) -> None:
    """Fill the pixel box [x0, x1] x [y0, y1] (at least 3 px wide), with a one-pixel outline."""
    h, w, _ = img.shape
    cx, cy = (x0 + x1) / 2.0, (y0 + y1) / 2.0
    hx, hy = max(abs(x1 - x0) / 2.0, 1.5), max(abs(y1 - y0) / 2.0, 1.5)
    i0, i1 = max(0, round(cx - hx)), min(w - 1, round(cx + hx))
    j0, j1 = max(0, round(cy - hy)), min(h - 1, round(cy + hy))
    if i0 > i1 or j0 > j1:
        return
    img[j0:j1 + 1, i0:i1 + 1] = OUTLINE if outline else colour
    if outline and i1 - i0 >= 2 and j1 - j0 >= 2:
        img[j0 + 1:j1, i0 + 1:i1] = colour


def _disc(img: np.ndarray, cx: float, cy: float, r: float, colour: tuple[int, int, int]) -> None:
    """A filled disc of radius `r` px (at least 2)."""
    h, w, _ = img.shape
    r = max(r, 2.0)
    j0, j1 = max(0, int(cy - r) - 1), min(h, int(cy + r) + 2)
    i0, i1 = max(0, int(cx - r) - 1), min(w, int(cx + r) + 2)
    j, i = np.ogrid[j0:j1, i0:i1]
    inside = (i + 0.5 - cx) ** 2 + (j + 0.5 - cy) ** 2 <= r**2
    img[j0:j1, i0:i1][inside] = colour


def draw_footprints(img: np.ndarray, footprints: Sequence[Footprint],
                    to_px: Callable[[float, float], tuple[float, float]], px_per_m: float) -> None:
    """Buildings, their doorways and objects, seen from above."""
    circles = [(to_px(f.a[0], f.a[1]), max(f.a[2] * px_per_m, 2.0)) for f in footprints if f.shape == "circle"]
    for c, r in circles:  # outlines first, so that a cluster of spheres reads as one shape
        _disc(img, *c, r + 1.0, OUTLINE)
    for c, r in circles:
        _disc(img, *c, r, OBJECT)
    for f in footprints:
        if f.shape == "rect":
            (x0, y0), (x1, y1) = to_px(f.a[0], f.a[1]), to_px(f.a[2], f.a[3])
            if f.kind == "door":
                _fill(img, x0, y0, x1, y1, DOORWAY, outline=False)
            else:
                _fill(img, x0, y0, x1, y1, ROOF if f.kind == "building" else OBJECT, outline=True)


def render_map(heights: np.ndarray, step_m: float, path: Sequence[PathPoint], scale: int = 2,
               footprints: Sequence[Footprint] | None = None) -> np.ndarray:
    """An RGB image (north up) of `heights` (row 0 south) with `path` drawn on it.

    `footprints` (buildings and objects, drawn under the path) default to the
    demo world's; pass an empty list for bare terrain."""
    rgb = _terrain_rgb(heights, step_m)
    img = np.repeat(np.repeat(rgb[::-1], scale, axis=0), scale, axis=1).astype(np.uint8)
    size_px = img.shape[0]
    px_per_m = scale / step_m

    def to_px(x: float, y: float) -> tuple[float, float]:
        return x * px_per_m, size_px - 1 - y * px_per_m

    draw_footprints(img, demo_footprints() if footprints is None else footprints, to_px, px_per_m)

    for a, b in zip(path, path[1:]):
        colour = WALK if b.on_walkable else TOUCH if b.contact else AIR
        (x0, y0), (x1, y1) = to_px(a.x, a.y), to_px(b.x, b.y)
        n = int(max(abs(x1 - x0), abs(y1 - y0)) * 2) + 1
        for k in range(n + 1):
            f = k / n
            _dot(img, x0 + (x1 - x0) * f, y0 + (y1 - y0) * f, colour, 1)
    for p in path:
        if p.collided:
            _cross(img, *to_px(p.x, p.y), HIT, 4)
    if path:
        _dot(img, *to_px(path[0].x, path[0].y), (0, 0, 0), 5)
        _dot(img, *to_px(path[0].x, path[0].y), (255, 255, 255), 3)
        _dot(img, *to_px(path[-1].x, path[-1].y), (0, 0, 0), 5)
    return img
