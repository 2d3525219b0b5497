"""The live map's paths: asked of the service (`Client.path`, docs/protocol.md "Paths") and drawn by the page.

A path comes from `acphys view --path FROM_CELL X Y Z TO_CELL X Y Z` (asked
once the view runs) or from two shift-clicks on the map (the page posts the
two points, in global map metres; each becomes a point on the terrain there,
in its outdoor cell). The walker is player-sized (the demo's player, as
`acphys path` has it). `PathBook` keeps every path asked, in order, with the
service's answer once it came: the page reads them from `/api/paths` and
draws each one's waypoints as a polyline.
"""

from __future__ import annotations

import logging
import math
import threading
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

from engine.geometry import Position, Vec3
from engine import PathResult

__all__ = ["PathBook", "PathEntry", "outdoor_position", "parse_path_words"]

log = logging.getLogger("acphys.view")

LANDBLOCK_M = 192.0
_CELL_M = 24.0
#: the most paths the book keeps (the oldest go first): a page clicked all day stays small
MAX_PATHS = 32
#: seconds a path may take: the first to reach a landblock builds its graph (about a second of the
#: service's time per landblock, several on a slow machine)
PATH_TIMEOUT_S = 60.0


def parse_path_words(words: list[str]) -> tuple[Position, Position]:
    """FROM_CELL X Y Z TO_CELL X Y Z (hex cell ids, landblock metres) as (start, goal)."""
    from clients.cli.values import parse_position

    return parse_position(words[:4]), parse_position(words[4:])


def outdoor_position(gx: float, gy: float, height_at: Callable[[int, float, float], float]) -> Position:
    """The point on the terrain at global map metres (gx, gy) (landblock column * 192 + local x, as the
    page counts them), in its outdoor cell; `height_at(cell, x, y)` is the terrain's height there.
    ValueError outside the map's 256 x 256 landblocks."""
    if not (math.isfinite(gx) and math.isfinite(gy)):
        raise ValueError("a point's coordinates are finite numbers")
    bx, by = math.floor(gx / LANDBLOCK_M), math.floor(gy / LANDBLOCK_M)
    if not (0 <= bx <= 0xFF and 0 <= by <= 0xFF):
        raise ValueError(f"({gx}, {gy}) is outside the map")
    x, y = gx - bx * LANDBLOCK_M, gy - by * LANDBLOCK_M
    cell = (bx << 24) | (by << 16) | (min(int(x // _CELL_M), 7) * 8 + min(int(y // _CELL_M), 7) + 1)
    return Position.at(cell, Vec3(x, y, height_at(cell, x, y)))


def _point(p: Position) -> dict[str, Any]:
    """A Position for the page: its cell and landblock in hex, the landblock as a number (as a State
    carries it), its landblock-local origin."""
    o = p.origin
    return {"cell": f"{p.cell_id:08X}", "landblock": p.landblock, "origin": [o.x, o.y, o.z]}


@dataclass(slots=True)
class PathEntry:
    """One path asked: where from and to, and the service's answer (None until it came, or `error`)."""

    number: int
    start: Position
    goal: Position
    answer: PathResult | None = None
    error: str = ""

    def to_json(self) -> dict[str, Any]:
        out: dict[str, Any] = {"number": self.number, "from": _point(self.start), "to": _point(self.goal),
                               "pending": self.answer is None and not self.error, "error": self.error}
        a = self.answer
        if a is not None:
            out.update({"found": a.found, "length": a.length, "expanded": a.expanded, "reason": a.reason,
                        "detail": a.detail, "waypoints": [_point(p) for p in a.waypoints]})
        else:
            out.update({"found": False, "waypoints": []})
        return out


@dataclass(slots=True)
class PathBook:
    """The paths asked, in order, answered by `ask(start, goal)` (the service's Client.path)."""

    ask: Callable[[Position, Position], PathResult]
    entries: list[PathEntry] = field(default_factory=list)
    _lock: threading.Lock = field(default_factory=threading.Lock)
    _count: int = 0

    def add(self, start: Position, goal: Position) -> PathEntry:
        """A new entry, not yet answered (`answer` answers it)."""
        with self._lock:
            self._count += 1
            entry = PathEntry(self._count, start, goal)
            self.entries.append(entry)
            del self.entries[:-MAX_PATHS]
        return entry

    def answer(self, entry: PathEntry) -> PathEntry:
        """Ask the service for `entry`'s path (blocking: call it off the server's event loop)."""
        try:
            result = self.ask(entry.start, entry.goal)
        except Exception as e:  # refused, no service, timeout: the page says why
            log.warning("path %d not answered: %s", entry.number, e)
            with self._lock:
                entry.error = f"{type(e).__name__}: {e}"
            return entry
        with self._lock:
            entry.answer = result
        return entry

    def answer_in_background(self, entries: list[PathEntry]) -> threading.Thread:
        """Answer `entries` one after the other on a thread of their own (the view serves meanwhile)."""
        def run() -> None:
            for e in entries:
                self.answer(e)

        t = threading.Thread(target=run, name="acphys-view-paths", daemon=True)
        t.start()
        return t

    def to_json(self) -> list[dict[str, Any]]:
        with self._lock:
            return [e.to_json() for e in self.entries]
