"""Placing map labels so that none covers another, a drawn object or a marker.

Pure geometry, no drawing library: boxes in any one unit whose y grows
upwards (the demo picture uses display pixels). Each label is tried in
rings around its anchor point, nearest ring first, in its preferred
directions (a place that would stick out of the bounds is slid back inside
them). The first place clear of every obstacle and every label already
placed wins, and one that also keeps off the soft points (the path, say)
beats one that does not in the same ring. A label that moved past the
first ring should get a leader line back to its anchor
(`Placement.leader`). When nothing is clear the place with the least
overlap is taken, so that a label is never dropped.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

__all__ = ["Box", "Label", "Placement", "DIRECTIONS", "UP_FIRST", "place_labels"]


@dataclass(frozen=True, slots=True)
class Box:
    """An axis-aligned box, x0 <= x1 and y0 <= y1."""

    x0: float
    y0: float
    x1: float
    y1: float

    @staticmethod
    def around(x: float, y: float, half_w: float, half_h: float | None = None) -> Box:
        h = half_w if half_h is None else half_h
        return Box(x - half_w, y - h, x + half_w, y + h)

    def overlap(self, other: Box) -> float:
        """The area the two boxes share (0 when they only touch or are apart)."""
        w = min(self.x1, other.x1) - max(self.x0, other.x0)
        h = min(self.y1, other.y1) - max(self.y0, other.y0)
        return w * h if w > 0 and h > 0 else 0.0

    def inside(self, outer: Box) -> bool:
        return outer.x0 <= self.x0 and self.x1 <= outer.x1 and outer.y0 <= self.y0 and self.y1 <= outer.y1

    def contains(self, x: float, y: float) -> bool:
        return self.x0 <= x <= self.x1 and self.y0 <= y <= self.y1

    @property
    def centre(self) -> tuple[float, float]:
        return (self.x0 + self.x1) / 2.0, (self.y0 + self.y1) / 2.0


#: (dx, dy) signs: where the box goes relative to its anchor, in order of preference
DIRECTIONS: tuple[tuple[int, int], ...] = ((1, 1), (1, 0), (-1, 1), (0, 1), (1, -1), (-1, 0), (0, -1), (-1, -1))
UP_FIRST: tuple[tuple[int, int], ...] = ((0, 1), (1, 1), (-1, 1), (1, 0), (-1, 0), (0, -1), (1, -1), (-1, -1))


@dataclass(frozen=True, slots=True)
class Label:
    """A label of size `width` x `height` that belongs next to `anchor`."""

    anchor: tuple[float, float]
    width: float
    height: float
    directions: tuple[tuple[int, int], ...] = DIRECTIONS


@dataclass(frozen=True, slots=True)
class Placement:
    box: Box
    ring: int  # 0: next to the anchor
    leader: bool  # moved away from its anchor: draw a line back to it
    clear: bool  # False when no clear place was found and the least-overlapping one was taken


def _box_at(label: Label, direction: tuple[int, int], d: float) -> Box:
    """The label's box `d` away from its anchor (outside the square of half-size `d`) in `direction`."""
    ax, ay = label.anchor
    sx, sy = direction
    w, h = label.width, label.height
    x0 = ax + d if sx > 0 else ax - d - w if sx < 0 else ax - w / 2.0
    y0 = ay + d if sy > 0 else ay - d - h if sy < 0 else ay - h / 2.0
    return Box(x0, y0, x0 + w, y0 + h)


def _within(box: Box, bounds: Box) -> Box | None:
    """`box` slid inside `bounds` (None when it is larger than they are)."""
    w, h = box.x1 - box.x0, box.y1 - box.y0
    if w > bounds.x1 - bounds.x0 or h > bounds.y1 - bounds.y0:
        return None
    x0 = min(max(box.x0, bounds.x0), bounds.x1 - w)
    y0 = min(max(box.y0, bounds.y0), bounds.y1 - h)
    return Box(x0, y0, x0 + w, y0 + h)


def place_labels(labels: Sequence[Label], obstacles: Sequence[Box], bounds: Box, gap: float, step: float,
                 rings: int = 12, soft: Sequence[tuple[float, float]] = ()) -> list[Placement]:
    """One placement per label, in order (earlier labels get the better places).

    `gap` is the first ring's distance from the anchor (keep it above a marker's half size), `step`
    the distance between rings; labels beyond ring 0 are marked for a leader line."""
    placed: list[Box] = []
    out: list[Placement] = []
    for label in labels:
        ax, ay = label.anchor
        reach = gap + rings * step + label.width + label.height
        near = [(x, y) for x, y in soft if abs(x - ax) <= reach and abs(y - ay) <= reach]
        best: tuple[float, int, Box] | None = None
        fallback: tuple[float, int, Box] | None = None
        for ring in range(rings + 1):
            if best is not None and best[0] <= ring:
                break  # nothing further out can beat it
            d = gap + ring * step
            for direction in label.directions:
                box = _within(_box_at(label, direction, d), bounds)
                if box is None:
                    continue
                hit = sum(box.overlap(o) for o in obstacles) + sum(box.overlap(p) for p in placed)
                if hit > 0.0:
                    if fallback is None or hit < fallback[0]:
                        fallback = (hit, ring, box)
                    continue
                cost = ring + (0.6 if any(box.contains(x, y) for x, y in near) else 0.0)
                if best is None or cost < best[0]:
                    best = (cost, ring, box)
        if best is not None:
            _, ring, box = best
            clear = True
        elif fallback is not None:
            _, ring, box = fallback
            clear = False
        else:  # larger than the bounds: beside the anchor, as it would have been
            ring, box, clear = 0, _box_at(label, label.directions[0], gap), False
        placed.append(box)
        out.append(Placement(box, ring, ring > 0, clear))
    return out
