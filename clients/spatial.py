"""The spatial queries of the client library: Client.sight / ray / ground / place and their batched forms
(docs/protocol.md, "Spatial queries"). Each is sent to the landblock of its starting position; the typed
answers are the engine's own result classes (engine.queries)."""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any

from engine.geometry import Position
from engine.queries.results import Ground, PlacementResult, RayHit, SightResult
from engine.world.types import MoverSpec
from service.codec import encode_mover_spec, encode_position
from service.queries import BATCH_FIELDS, decode_ground, decode_placement, decode_ray_hit, decode_sight

from .errors import ServiceError
from .query_columns import QueryColumnResults, query_columns

__all__ = ["SpatialQueries", "SightQuery"]


@dataclass(frozen=True, slots=True)
class SightQuery:
    """One pair of a `Client.sights` batch with what the map form lets each pair name: eye `a`, eye `b`,
    its own sight radius (None: the batch's), the mover looked at (`target`) and the mover looking
    (`viewer`), by id."""

    a: Position
    b: Position
    radius: float | None = None
    target: int | None = None
    viewer: int | None = None


def _lb(p: Position) -> int:
    return (p.cell_id >> 16) & 0xFFFF


def _sight_item(a: Position, b: Position, radius: float | None, target: int | None, viewer: int | None) -> dict[str, Any]:
    item: dict[str, Any] = {"from": encode_position(a), "to": encode_position(b)}
    if radius is not None:
        item["radius"] = radius
    if target is not None:
        item["target"] = target
    if viewer is not None:
        item["viewer"] = viewer
    return item


def _ray_item(a: Position, b: Position, radius: float, target: int | None) -> dict[str, Any]:
    item: dict[str, Any] = {"from": encode_position(a), "to": encode_position(b), "radius": radius}
    if target is not None:
        item["target"] = target
    return item


def _ground_item(p: Position, max_drop: float | None) -> dict[str, Any]:
    item: dict[str, Any] = {"position": encode_position(p)}
    if max_drop is not None:
        item["max_drop"] = max_drop
    return item


def _place_item(spec: MoverSpec, p: Position, mode: str, slide: bool) -> dict[str, Any]:
    return {"mover": encode_mover_spec(spec), "position": encode_position(p), "mode": mode, "slide": slide}


class SpatialQueries:
    """Mixed into Client: needs its `_lb_request(lb, op, content, timeout=...)`."""

    _lb_request: Callable[..., dict[str, Any]]

    def _one(self, op: str, lb: int, item: dict[str, Any], timeout: float | None) -> Any:
        return self._lb_request(lb, op, {"v": 1, op: item}, timeout=timeout)[op]

    def _many(self, op: str, lbs: list[int], items: list[dict[str, Any]], decode: Callable[[Any], Any],
              timeout: float | None) -> list[Any]:
        """One batch request per landblock; answers in the order asked, a ServiceError for a refused item."""
        out: list[Any] = [None] * len(items)
        by_lb: dict[int, list[int]] = {}
        for i, lb in enumerate(lbs):
            by_lb.setdefault(lb, []).append(i)
        many = BATCH_FIELDS[op]
        for lb, idx in by_lb.items():
            answers = self._lb_request(lb, op, {"v": 1, many: [items[i] for i in idx]}, timeout=timeout)[many]
            for i, a in zip(idx, answers, strict=True):
                out[i] = ServiceError.from_wire(a["error"]) if isinstance(a, dict) and "error" in a else decode(a)
        return out

    def sight(self, a: Position, b: Position, radius: float | None = None, *, target: int | None = None,
              viewer: int | None = None, timeout: float | None = None) -> SightResult:
        """Is the line from eye `a` to eye `b` clear (World.sight, on the service)?"""
        return decode_sight(self._one("sight", _lb(a), _sight_item(a, b, radius, target, viewer), timeout))

    def sights(self, pairs: Sequence[tuple[Position, Position] | SightQuery], radius: float | None = None,
               timeout: float | None = None) -> list[SightResult | ServiceError]:
        """`sight` for each pair, in order: a pair is (a, b), or a SightQuery naming its own radius,
        target and viewer (as the map form's items can)."""
        queries = [p if isinstance(p, SightQuery) else SightQuery(p[0], p[1]) for p in pairs]
        items = [_sight_item(q.a, q.b, radius if q.radius is None else q.radius, q.target, q.viewer) for q in queries]
        return self._many("sight", [_lb(q.a) for q in queries], items, decode_sight, timeout)

    def ray(self, start: Position, end: Position, radius: float, *, target: int | None = None,
            timeout: float | None = None) -> RayHit:
        """The first contact of a sphere swept from `start` to `end` (World.ray, on the service)."""
        return decode_ray_hit(self._one("ray", _lb(start), _ray_item(start, end, radius, target), timeout))

    def rays(self, segments: Sequence[tuple[Position, Position]], radius: float,
             timeout: float | None = None) -> list[RayHit | ServiceError]:
        items = [_ray_item(a, b, radius, None) for a, b in segments]
        return self._many("ray", [_lb(a) for a, _ in segments], items, decode_ray_hit, timeout)

    def ground(self, position: Position, max_drop: float | None = None, timeout: float | None = None) -> Ground | None:
        """The surface under `position`, or None (World.ground, on the service)."""
        return decode_ground(self._one("ground", _lb(position), _ground_item(position, max_drop), timeout))

    def grounds(self, positions: Sequence[Position], max_drop: float | None = None,
                timeout: float | None = None) -> list[Ground | None | ServiceError]:
        items = [_ground_item(p, max_drop) for p in positions]
        return self._many("ground", [_lb(p) for p in positions], items, decode_ground, timeout)

    def place(self, spec: MoverSpec, position: Position, mode: str = "enter_world", slide: bool = True,
              timeout: float | None = None) -> PlacementResult:
        """Where the service would place an object of shape `spec` at `position` (World.place); places nothing."""
        return decode_placement(self._one("place", _lb(position), _place_item(spec, position, mode, slide), timeout))

    def places(self, queries: Sequence[tuple[MoverSpec, Position]], mode: str = "enter_world", slide: bool = True,
               timeout: float | None = None) -> list[PlacementResult | ServiceError]:
        items = [_place_item(s, p, mode, slide) for s, p in queries]
        return self._many("place", [_lb(p) for _, p in queries], items, decode_placement, timeout)

    # -- the column form (docs/protocol.md, "Query columns") ------------------------------------------
    def _columns(self, op: str, named: dict[str, Any], options: dict[str, Any] | None,
                 timeout: float | None) -> QueryColumnResults:
        def request(lb: int, body: dict[str, Any]) -> dict[str, Any]:
            return self._lb_request(lb, op, {"v": 1, **body}, timeout=timeout)

        return query_columns(request, op, named, options)

    def sight_columns(self, from_cells: Any, from_origins: Any, to_cells: Any, to_origins: Any, radius: Any = None,
                      *, targets: Any = None, viewers: Any = None, timeout: float | None = None) -> QueryColumnResults:
        """`sight` for N pairs as numpy columns: cell ids (N,) and origins (N, 3) of both eyes; `radius`,
        `targets`, `viewers` a scalar or (N,) (0: the default radius, no target, no viewer). The answers'
        columns: flags (`clear`), cell, stop, normal, blocker, blocker_id."""
        return self._columns("sight", {"from_cell": from_cells, "from_origin": from_origins, "to_cell": to_cells,
                                       "to_origin": to_origins, "radius": radius, "target": targets,
                                       "viewer": viewers}, None, timeout)

    def ray_columns(self, from_cells: Any, from_origins: Any, to_cells: Any, to_origins: Any, radius: Any, *,
                    targets: Any = None, timeout: float | None = None) -> QueryColumnResults:
        """`ray` for N segments as numpy columns (as `sight_columns`; `radius` required, > 0). The answers'
        columns: flags (`hit`), cell, position, normal, distance, blocker, blocker_id."""
        return self._columns("ray", {"from_cell": from_cells, "from_origin": from_origins, "to_cell": to_cells,
                                     "to_origin": to_origins, "radius": radius, "target": targets}, None, timeout)

    def ground_columns(self, cells: Any, origins: Any, max_drop: Any = None,
                       timeout: float | None = None) -> QueryColumnResults:
        """`ground` for N points as numpy columns: cell ids (N,), origins (N, 3). The answers' columns: flags
        (`found`, `walkable`), z, plane, cell, water_depth."""
        return self._columns("ground", {"cell": cells, "origin": origins, "max_drop": max_drop}, None, timeout)

    def place_columns(self, spec: MoverSpec, cells: Any, origins: Any, orientations: Any = None,
                      mode: str = "enter_world", slide: bool = True, timeout: float | None = None) -> QueryColumnResults:
        """`place` of one shape at N positions as numpy columns: cell ids (N,), origins (N, 3), orientations
        (N, 4) w x y z or None. The answers' columns: flags (`ok`, `contact`, ...), placement_result, cell,
        origin, orientation, contact_plane, contact_plane_cell."""
        options = {"mover": encode_mover_spec(spec), "mode": mode, "slide": slide}
        return self._columns("place", {"cell": cells, "origin": origins, "orientation": orientations}, options,
                             timeout)
