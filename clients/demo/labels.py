"""The demo picture's labels on a map panel, placed clear of each other and of what is drawn.

Labels (leg numbers, event letters, START/END, object names) are first made
at their anchors; once the figure has been laid out and drawn once, their
sizes and the panel's drawn things are known in display pixels and
`clients.demo.label_layout` moves every label to a free place, with a thin
leader line back to its anchor when it had to go further than next to it.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

from clients.demo.label_layout import DIRECTIONS, Box, Label, Placement, place_labels

__all__ = ["PanelLabels"]

GAP_PX = 7.0  # the first ring: just clear of a marker of 8 points (5.6 px at 100 dpi)
STEP_PX = 6.0  # between rings


@dataclass(slots=True)
class _Pending:
    text: Any  # a matplotlib Annotation
    anchor: tuple[float, float]  # data coordinates
    directions: tuple[tuple[int, int], ...]
    priority: int


@dataclass(slots=True)
class PanelLabels:
    """The labels of one axes, and what they must keep off."""

    ax: Any
    pending: list[_Pending] = field(default_factory=list)
    markers: list[tuple[float, float, float]] = field(default_factory=list)  # data x, y, size in points
    artists: list[Any] = field(default_factory=list)  # drawn things (patches, fixed texts, the scale bar)
    soft: list[tuple[float, float]] = field(default_factory=list)  # data points better not covered (the path)
    placements: list[tuple[Any, Placement]] = field(default_factory=list)  # after place(): each label's box

    def add(self, text: str, xy: tuple[float, float], priority: int,
            directions: tuple[tuple[int, int], ...] = DIRECTIONS, leader_colour: str = "#333333",
            **style: Any) -> Any:
        """A label for `xy` (data), drawn at `xy` until `place` moves it; earlier priorities place first."""
        t = self.ax.annotate(text, xy, xytext=xy, textcoords="data", ha="center", va="center",
                             arrowprops={"arrowstyle": "-", "color": leader_colour, "lw": 0.6,
                                         "shrinkA": 0.0, "shrinkB": 0.0}, **style)
        t.set_in_layout(False)  # inside the axes: it must not move the panels
        t.arrow_patch.set_visible(False)
        self.pending.append(_Pending(t, xy, directions, priority))
        return t

    def marker(self, x: float, y: float, size_pt: float) -> None:
        self.markers.append((x, y, size_pt))

    def place(self, renderer: Any, dpi: float) -> list[tuple[Any, Placement]]:
        """Move every label to its place (the figure must have been drawn once)."""
        ax = self.ax
        to_px = ax.transData.transform
        order = sorted(self.pending, key=lambda p: p.priority)
        labels = []
        for p in order:
            p.text.update_bbox_position_size(renderer)
            patch = p.text.get_bbox_patch()
            ext = (patch if patch is not None else p.text).get_window_extent(renderer)
            (ax_px, ay_px), = to_px([p.anchor])
            labels.append(Label((float(ax_px), float(ay_px)), float(ext.width), float(ext.height), p.directions))
        obstacles = [_box(a.get_window_extent(renderer)) for a in self.artists]
        for x, y, size in self.markers:
            (px, py), = to_px([(x, y)])
            half = size / 2.0 * dpi / 72.0 + 1.0
            obstacles.append(Box.around(float(px), float(py), half))
        frame = _box(ax.get_window_extent(renderer))
        bounds = Box(frame.x0 + 2, frame.y0 + 2, frame.x1 - 2, frame.y1 - 2)
        soft = [(float(x), float(y)) for x, y in to_px(self.soft)] if self.soft else []
        soft = [s for s in soft if bounds.contains(*s)]
        to_data = ax.transData.inverted().transform
        self.placements = []
        for p, placed in zip(order, place_labels(labels, obstacles, bounds, GAP_PX, STEP_PX, soft=soft)):
            (x, y), = to_data([placed.box.centre])
            p.text.set_position((float(x), float(y)))
            p.text.arrow_patch.set_visible(placed.leader)
            self.placements.append((p.text, placed))
        return self.placements


def _box(bbox: Any) -> Box:
    return Box(float(bbox.x0), float(bbox.y0), float(bbox.x1), float(bbox.y1))

