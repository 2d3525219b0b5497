"""Batched queries: many sights, rays or ground lookups in one call.

Every query of a batch is checked before any runs (a bad one is refused with
its index and nothing runs); the cells the queries start in are looked up
once per batch (a cache keyed by cell id shared by the whole batch). The
array form takes numpy arrays: cell ids (n,) and xyz (n, 3) for starts and
ends, as the service's columnar batches carry them.
"""

from __future__ import annotations

from typing import TYPE_CHECKING
from collections.abc import Sequence

import numpy as np
from numpy.typing import ArrayLike

from .. import limits
from ..errors import EngineError, OutOfRangeError
from ..geometry import Position, Vec3
from .ground import MAX_GROUND_DROP, _ground_checked
from .results import Ground, RayHit, SightResult
from .sweep import SIGHT_RADIUS, _ray_checked, _sight_checked, check_point, check_radius, check_segment, start_outside_viewer

if TYPE_CHECKING:
    from ..cells.obj_cell import ObjCell
    from ..world.world import World

__all__ = ["rays", "rays_array", "sights", "sights_array", "grounds", "grounds_array", "positions_from_arrays"]


def _refuse(index: int, error: EngineError) -> EngineError:
    """The same kind of error, saying which query of the batch it was."""
    return type(error)(f"query {index}: {error}")


def _check_pairs(world: World, starts: Sequence[Position], ends: Sequence[Position], radius: float) -> float:
    if len(starts) != len(ends):
        raise ValueError(f"a batch needs as many ends as starts ({len(starts)} starts, {len(ends)} ends)")
    r = check_radius(radius)
    for i, (s, e) in enumerate(zip(starts, ends)):
        try:
            check_point(world, s, "start")
            check_point(world, e, "end")
            check_segment(world, s, e, r)
        except EngineError as error:
            raise _refuse(i, error) from None
    return r


def rays(world: World, starts: Sequence[Position], ends: Sequence[Position], radius: float, *, target_id: int = 0) -> list[RayHit]:
    """`ray` for each (start, end) pair, in order."""
    r = _check_pairs(world, starts, ends, radius)
    cache: dict[int, ObjCell | None] = {}
    return [_ray_checked(world, s, e, r, target_id, cache) for s, e in zip(starts, ends)]


def sights(
    world: World,
    eyes: Sequence[Position],
    targets: Sequence[Position],
    radius: float = SIGHT_RADIUS,
    *,
    target_ids: Sequence[int] | None = None,
    viewer_ids: Sequence[int] | None = None,
) -> list[SightResult]:
    """`sight` for each (eye, target) pair, in order; `target_ids` and
    `viewer_ids` (0 for none) per pair when given."""
    r = _check_pairs(world, eyes, targets, radius)
    n = len(eyes)
    for name, ids in (("target_ids", target_ids), ("viewer_ids", viewer_ids)):
        if ids is not None and len(ids) != n:
            raise ValueError(f"{name} needs one id per pair ({n} pairs, {len(ids)} ids)")
    if viewer_ids is not None:
        for i, viewer in enumerate(viewer_ids):
            if viewer:
                try:
                    world.mover(int(viewer))
                except EngineError as error:
                    raise _refuse(i, error) from None
    cache: dict[int, ObjCell | None] = {}
    out = []
    for i, (a, b) in enumerate(zip(eyes, targets)):
        viewer = int(viewer_ids[i]) if viewer_ids is not None else 0
        if viewer:
            a = start_outside_viewer(world, a, b, r, viewer)
        out.append(_sight_checked(world, a, b, r, int(target_ids[i]) if target_ids is not None else 0, cache))
    return out


def grounds(world: World, positions: Sequence[Position], max_drop: float = MAX_GROUND_DROP) -> list[Ground | None]:
    """`ground` for each position, in order."""
    for i, p in enumerate(positions):
        try:
            check_point(world, p, "position")
        except EngineError as error:
            raise _refuse(i, error) from None
    drop = limits.check_number(max_drop, "max_drop")
    if not drop > 0.0:
        raise OutOfRangeError(f"max_drop must be above 0 m, got {max_drop!r}")
    cache: dict[int, ObjCell | None] = {}
    return [_ground_checked(world, p, drop, cache) for p in positions]


def positions_from_arrays(cells: ArrayLike, xyz: ArrayLike, field: str) -> list[Position]:
    """Positions from a (n,) array of cell ids and a (n, 3) array of coordinates."""
    cell_array = np.asarray(cells)
    coords = np.asarray(xyz, dtype=np.float64)
    if cell_array.ndim != 1 or coords.shape != (cell_array.shape[0], 3):
        raise ValueError(f"{field}: cell ids must have shape (n,) and coordinates (n, 3), got {cell_array.shape} and {coords.shape}")
    if cell_array.dtype.kind not in "iu":
        raise ValueError(f"{field}: cell ids must be integers, got {cell_array.dtype}")
    return [Position.at(int(c), Vec3(float(x), float(y), float(z))) for c, (x, y, z) in zip(cell_array.tolist(), coords.tolist())]


def rays_array(world: World, start_cells: ArrayLike, start_xyz: ArrayLike, end_cells: ArrayLike, end_xyz: ArrayLike, radius: float) -> list[RayHit]:
    """`rays` on numpy columns: cell ids (n,) and xyz (n, 3) of starts and ends."""
    starts = positions_from_arrays(start_cells, start_xyz, "starts")
    ends = positions_from_arrays(end_cells, end_xyz, "ends")
    return rays(world, starts, ends, radius)


def sights_array(world: World, eye_cells: ArrayLike, eye_xyz: ArrayLike, target_cells: ArrayLike, target_xyz: ArrayLike, radius: float = SIGHT_RADIUS) -> list[SightResult]:
    """`sights` on numpy columns: cell ids (n,) and xyz (n, 3) of eyes and targets."""
    eyes = positions_from_arrays(eye_cells, eye_xyz, "eyes")
    targets = positions_from_arrays(target_cells, target_xyz, "targets")
    return sights(world, eyes, targets, radius)


def grounds_array(world: World, cells: ArrayLike, xyz: ArrayLike, max_drop: float = MAX_GROUND_DROP) -> list[Ground | None]:
    """`grounds` on numpy columns: cell ids (n,) and xyz (n, 3)."""
    return grounds(world, positions_from_arrays(cells, xyz, "positions"), max_drop)
