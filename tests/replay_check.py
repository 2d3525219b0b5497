"""Comparing a replayed move with the reference's `expect` (tolerances of issue 2)."""

from __future__ import annotations

from typing import Any

POS_TOL = 1e-3
NORMAL_TOL = 1e-3


def _close(a: Any, b: Any, tol: float) -> bool:
    return len(a) == len(b) and all(abs(float(x) - float(y)) <= tol for x, y in zip(a, b))


def move_mismatches(expect: dict[str, Any], got: dict[str, Any]) -> list[str]:
    """Keys of `expect` on which `got` disagrees: flags, cells and counters
    exactly; origin within 1e-3 m; normals and planes within 1e-3."""
    bad = []
    for key, e in expect.items():
        g = got.get(key)
        if key == "position":
            if g is None or e["cell"] != g["cell"] or not _close(e["origin"], g["origin"], POS_TOL):
                bad.append(key)
        elif key == "contact_plane":
            if (e is None) != (g is None) or (
                e is not None and (not _close(e["normal"], g["normal"], NORMAL_TOL) or abs(e["d"] - g["d"]) > NORMAL_TOL)
            ):
                bad.append(key)
        elif key in ("collision_normal", "sliding_normal"):
            if (e is None) != (g is None) or (e is not None and not _close(e, g, NORMAL_TOL)):
                bad.append(key)
        elif e != g:
            bad.append(key)
    return bad


def first_mismatch(case: dict[str, Any], results: list[dict[str, Any]]) -> str | None:
    """A readable description of the first disagreeing move, or None."""
    moves = case["moves"]
    if len(results) != len(moves):
        placement_ended = any(m.get("placement") for m in moves)
        if not placement_ended:
            return f"{len(results)} results for {len(moves)} moves"
    for i, (move, got) in enumerate(zip(moves, results)):
        bad = move_mismatches(move["expect"], got)
        if bad:
            detail = "; ".join(f"{k}: expected {move['expect'][k]!r}, got {got.get(k)!r}" for k in bad)
            return f"move {i}: {detail}"
    return None


def case_mismatch(case: dict[str, Any], results: Any) -> str | None:
    """`first_mismatch` for a single-mover case, or for every mover of a
    `movers` case (results by mover id): None when all agree."""
    if "movers" not in case:
        return first_mismatch(case, results)
    problems = [
        f"mover {m['id']}: {p}" for m in case["movers"] if (p := first_mismatch(m, results[m["id"]])) is not None
    ]
    return "; ".join(problems) or None
