"""The spatial queries of the client library: Client.sight / ray / ground / place and their batched forms
(docs/protocol.md, "Spatial queries"). Each is sent to the landblock of its starting position; the typed
answers are the engine's own result classes (engine.queries).

Every query is read-only: it runs the engine's own sweeps against the service's world with its movers in
it and changes none of them. Positions are `engine.Position`s (a hex cell id 0xXXYYIIII and an origin in
landblock-local metres: x east, y north, z absolute height); distances and radii are metres. The sweeps
cross landblock borders as far as the instance has land loaded. Errors, as `ServiceError` kinds
(docs/protocol.md, "Errors"): `landblock_not_loaded` (the query reaches land the instance does not
hold), `unknown_cell`, `unknown_mover` (a `target` or `viewer` no mover has), `bad_value` (a radius
outside 0.001 .. 10 m, a negative `max_drop`, an unknown `mode`, a non-unit orientation),
`non_finite`; and `NoServiceError` when no instance owns the starting landblock, `RequestTimeout`.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass
from functools import partial
from typing import Any

from engine.geometry import Position
from engine import Ground, MoverSpec, PlacementResult, RayHit, SightResult
from service.protocol.codec import encode_mover_spec
from service.protocol import BATCH_FIELDS, read_answer, write_query

from clients.errors import ServiceError
from clients.query_columns import QueryColumnResults, query_columns

__all__ = ["SpatialQueries", "SightQuery"]


@dataclass(frozen=True, slots=True)
class SightQuery:
    """One pair of a `Client.sights` batch with what the map form lets each pair name: eye `a`, eye `b`,
    its own sight radius in metres (None: the batch's), the mover looked at (`target`) and the mover
    looking (`viewer`), by id."""

    a: Position
    b: Position
    radius: float | None = None
    target: int | None = None
    viewer: int | None = None


def _lb(p: Position) -> int:
    return (p.cell_id >> 16) & 0xFFFF


def _sight_item(a: Position, b: Position, radius: float | None, target: int | None, viewer: int | None) -> dict[str, Any]:
    return write_query("sight", from_=a, to=b, radius=radius, target=target, viewer=viewer)


def _ray_item(a: Position, b: Position, radius: float, target: int | None) -> dict[str, Any]:
    return write_query("ray", from_=a, to=b, radius=radius, target=target)


def _ground_item(p: Position, max_drop: float | None) -> dict[str, Any]:
    return write_query("ground", position=p, max_drop=max_drop)


def _place_item(spec: MoverSpec, p: Position, mode: str, slide: bool) -> dict[str, Any]:
    return write_query("place", mover=spec, position=p, mode=mode, slide=slide)


class SpatialQueries:
    """The spatial queries, mixed into `Client` (which gives them its `_lb_request(lb, op, content,
    timeout=...)`): call them on a Client."""

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
        """Is the line from eye `a` to eye `b` clear (World.sight, on the service)?

        A sight object (a sphere of `radius` metres, 0.001 .. 10; None: the client's 0.1 m) is swept
        from `a` to `b` as a missile is: terrain, cell walls, buildings, static objects, creatures and
        players stop it, ethereal objects do not. `target`: the id of the mover looked at (touching it
        counts as arriving; other creatures are passed); `viewer`: the id of the mover whose eye `a` is
        (its own body does not block). Returns a `SightResult`: `clear`, or where the sphere's centre
        stopped (`stop`), the surface `normal` there, the `cell` id and the `blocker` (its `kind`:
        terrain, cell, building or object; its `object_id`). Raises ServiceError (the kinds in this
        module's docstring), NoServiceError, RequestTimeout."""
        return read_answer("sight", self._one("sight", _lb(a), _sight_item(a, b, radius, target, viewer), timeout))

    def sights(self, pairs: Sequence[tuple[Position, Position] | SightQuery], radius: float | None = None,
               timeout: float | None = None) -> list[SightResult | ServiceError]:
        """`sight` for each pair, in order: a pair is (a, b), or a SightQuery naming its own radius,
        target and viewer (as the map form's items can). `radius`: metres, for the pairs that name none.

        One request per landblock of the pairs' `a`. Returns one entry per pair: its SightResult, or a
        ServiceError for a pair the engine refused (`landblock_not_loaded`, `unknown_mover`, ...).
        Raises ServiceError when a landblock's request is refused whole (a field error such as a NaN,
        whose path indexes that landblock's share of the pairs; more than 4096 pairs: `too_large`),
        NoServiceError, RequestTimeout."""
        queries = [p if isinstance(p, SightQuery) else SightQuery(p[0], p[1]) for p in pairs]
        items = [_sight_item(q.a, q.b, radius if q.radius is None else q.radius, q.target, q.viewer) for q in queries]
        return self._many("sight", [_lb(q.a) for q in queries], items, partial(read_answer, "sight"), timeout)

    def ray(self, start: Position, end: Position, radius: float, *, target: int | None = None,
            timeout: float | None = None) -> RayHit:
        """The first contact of a sphere of `radius` metres (0.001 .. 10) swept from `start` to `end`
        (World.ray, on the service), as a missile is swept; `target`: the id of a mover aimed at.

        Returns a `RayHit`: `hit`; `position`, where the sphere's centre stopped (touching what it hit,
        one radius before a wall; `end` when nothing was hit), its `cell` id, the hit surface's `normal`,
        the `distance` in metres the centre travelled, and the `blocker`. Raises ServiceError (the kinds
        in this module's docstring), NoServiceError, RequestTimeout."""
        return read_answer("ray", self._one("ray", _lb(start), _ray_item(start, end, radius, target), timeout))

    def rays(self, segments: Sequence[tuple[Position, Position]], radius: float,
             timeout: float | None = None) -> list[RayHit | ServiceError]:
        """`ray` for each (start, end) segment, in order, with one `radius` in metres: one entry per
        segment, its RayHit or a ServiceError for a segment the engine refused. Raises as `sights`
        does for a request refused whole."""
        items = [_ray_item(a, b, radius, None) for a, b in segments]
        return self._many("ray", [_lb(a) for a, _ in segments], items, partial(read_answer, "ray"), timeout)

    def ground(self, position: Position, max_drop: float | None = None, timeout: float | None = None) -> Ground | None:
        """The surface under `position`, or None (World.ground, on the service).

        What an object falling from `position` would rest on: outdoors the terrain or the top of what
        stands on it (a roof, a static object, a mover that is not a creature), indoors the floor or
        what stands on it, at most `max_drop` metres down (None: the engine's default). Creatures are
        never ground. Returns a `Ground`: `z` (its height straight below, metres), its `plane` (in the
        frame of `cell`'s landblock), the `cell` id, `walkable` and `water_depth` (metres, 0 on dry
        land); None when there is no surface within reach. Raises ServiceError (the kinds in this
        module's docstring), NoServiceError, RequestTimeout."""
        return read_answer("ground", self._one("ground", _lb(position), _ground_item(position, max_drop), timeout))

    def grounds(self, positions: Sequence[Position], max_drop: float | None = None,
                timeout: float | None = None) -> list[Ground | None | ServiceError]:
        """`ground` for each position, in order: one entry per position, its Ground, None (no surface
        within reach) or a ServiceError for a position the engine refused. Raises as `sights` does for a
        request refused whole."""
        items = [_ground_item(p, max_drop) for p in positions]
        return self._many("ground", [_lb(p) for p in positions], items, partial(read_answer, "ground"), timeout)

    def place(self, spec: MoverSpec, position: Position, mode: str = "enter_world", slide: bool = True,
              timeout: float | None = None) -> PlacementResult:
        """Where the service would place an object of shape `spec` at `position` (World.place); places nothing.

        The client's placement of an object entering the world (`mode` "enter_world") or teleporting
        ("teleport") at `position`: pushed out of what it overlaps (movers included) and, with `slide`,
        moved to a free spot nearby. Returns a `PlacementResult`: `ok`, `placement_result` ("OK",
        "NoValidPosition" or "NoCell(lost)"), the `position` it would stand at (None when not placed)
        and the contact state there (`contact`, `on_walkable`, `contact_plane`, `contact_plane_cell`,
        `water_contact`): what `Client.register` takes to start a mover standing. Raises ServiceError
        (`bad_value` for a bad `spec` or `mode`, and the kinds in this module's docstring),
        NoServiceError, RequestTimeout."""
        return read_answer("place", self._one("place", _lb(position), _place_item(spec, position, mode, slide), timeout))

    def places(self, queries: Sequence[tuple[MoverSpec, Position]], mode: str = "enter_world", slide: bool = True,
               timeout: float | None = None) -> list[PlacementResult | ServiceError]:
        """`place` for each (spec, position), in order, with one `mode` and `slide`: one entry per query,
        its PlacementResult or a ServiceError for a query the engine refused. Raises as `sights` does for
        a request refused whole."""
        items = [_place_item(s, p, mode, slide) for s, p in queries]
        return self._many("place", [_lb(p) for _, p in queries], items, partial(read_answer, "place"), timeout)

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
        columns: flags (`clear`), cell, stop, normal, blocker, blocker_id.

        Origins are landblock-local metres, radii metres (0.001 .. 10). One request per landblock of
        the `from_cells`. Returns a `QueryColumnResults`, one row per pair in order; a failed pair's row
        holds the missing values and its error is in `errors` by index (so is every pair of a landblock
        whose request went unanswered): no AcphysError is raised. ValueError for arrays of the wrong
        shape or a required one missing (docs/protocol.md, "Query columns")."""
        return self._columns("sight", {"from_cell": from_cells, "from_origin": from_origins, "to_cell": to_cells,
                                       "to_origin": to_origins, "radius": radius, "target": targets,
                                       "viewer": viewers}, None, timeout)

    def ray_columns(self, from_cells: Any, from_origins: Any, to_cells: Any, to_origins: Any, radius: Any, *,
                    targets: Any = None, timeout: float | None = None) -> QueryColumnResults:
        """`ray` for N segments as numpy columns (as `sight_columns`; `radius` required, 0.001 .. 10 m, a
        scalar or (N,)). The answers' columns: flags (`hit`), cell, position, normal, distance (metres),
        blocker, blocker_id. Errors as `sight_columns`: per row in `errors`; ValueError for bad shapes."""
        return self._columns("ray", {"from_cell": from_cells, "from_origin": from_origins, "to_cell": to_cells,
                                     "to_origin": to_origins, "radius": radius, "target": targets}, None, timeout)

    def ground_columns(self, cells: Any, origins: Any, max_drop: Any = None,
                       timeout: float | None = None) -> QueryColumnResults:
        """`ground` for N points as numpy columns: cell ids (N,), origins (N, 3) in landblock-local metres,
        `max_drop` metres, a scalar or (N,) (0: the default). The answers' columns: flags (`found`,
        `walkable`), z, plane, cell, water_depth. Errors as `sight_columns`: per row in `errors`;
        ValueError for bad shapes."""
        return self._columns("ground", {"cell": cells, "origin": origins, "max_drop": max_drop}, None, timeout)

    def place_columns(self, spec: MoverSpec, cells: Any, origins: Any, orientations: Any = None,
                      mode: str = "enter_world", slide: bool = True, timeout: float | None = None) -> QueryColumnResults:
        """`place` of one shape at N positions as numpy columns: cell ids (N,), origins (N, 3), orientations
        (N, 4) w x y z or None. The answers' columns: flags (`ok`, `contact`, ...), placement_result, cell,
        origin, orientation, contact_plane, contact_plane_cell. `mode` and `slide` as `place`, for every
        row. Errors as `sight_columns`: per row in `errors`; ValueError for bad shapes."""
        options = {"mover": encode_mover_spec(spec), "mode": mode, "slide": slide}
        return self._columns("place", {"cell": cells, "origin": origins, "orientation": orientations}, options,
                             timeout)
