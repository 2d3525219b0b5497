"""Comparing a replayed move with the reference's `expect`: the one place that says how close is close.

The reference is ACE's physics in float32; the engine reproduces most of its
arithmetic at that precision. Over every move of every shared trace (100 429
moves, from `to` and from offsets) the worst differences today are:
origin 2.34e-5 m (cellar-viewer-050-viewer-pull), a normal's component
1.6e-6 (dungeon-walk-006), a contact plane's d 7.4e-6 m (rolling-halfstep-023,
one float32 step at |d| < 128 m). The tolerances sit a little above those,
so that a change of the engine's arithmetic that moves an answer by more
than a few float32 steps is noticed. Everything the reference gives exactly
(cells, flags, counters, states, placement results, touched objects) is
compared exactly, type included (True is not 1).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

#: a position's origin, metres (a float32 step at 200 m is 1.5e-5 m)
POS_TOL = 1e-4
#: a unit normal's components (contact plane, collision and sliding normals)
NORMAL_TOL = 1e-5
#: a contact plane's d, metres
PLANE_D_TOL = 1e-5


@dataclass(frozen=True)
class Tolerances:
    """How close a replayed origin, normal and plane d must be to the reference's."""

    position: float = POS_TOL
    normal: float = NORMAL_TOL
    plane_d: float = PLANE_D_TOL


#: the engine's own setting (single precision, as the reference computes)
REFERENCE = Tolerances()
#: `single_precision=False`: double arithmetic against a float32 reference differs by up to a few
#: float32 steps compounded over a case (p99 1.7e-4 m, tests/test_double_precision_replay.py)
DOUBLE_PRECISION = Tolerances(position=1e-3, normal=1e-3, plane_d=1e-3)

#: the keys compared within tolerances; every other key (and every other
#: field of a position or plane) must be equal exactly
_POSITION = "position"
_PLANE = "contact_plane"
_NORMALS = ("collision_normal", "sliding_normal")


def _close(a: Any, b: Any, tol: float) -> bool:
    return (isinstance(b, (list, tuple)) and len(a) == len(b)
            and all(abs(float(x) - float(y)) <= tol for x, y in zip(a, b)))


def exactly(expected: Any, got: Any) -> bool:
    """Equal, and of the same kind all the way down (a bool is not an int, a list not a tuple)."""
    if type(expected) is not type(got):
        return False
    if isinstance(expected, list):
        return len(expected) == len(got) and all(exactly(e, g) for e, g in zip(expected, got))
    if isinstance(expected, dict):
        return expected.keys() == got.keys() and all(exactly(expected[k], got[k]) for k in expected)
    return bool(expected == got)


def _dict_close(e: dict[str, Any], g: Any, tolerances: dict[str, float]) -> bool:
    """A position or plane: the listed fields within their tolerance, the rest exactly."""
    if not isinstance(g, dict) or e.keys() - g.keys():
        return False
    for key, value in e.items():
        tol = tolerances.get(key)
        if tol is None:
            if not exactly(value, g[key]):
                return False
        elif isinstance(value, list):
            if not _close(value, g[key], tol):
                return False
        elif not isinstance(g[key], (int, float)) or abs(float(value) - float(g[key])) > tol:
            return False
    return True


def field_agrees(key: str, e: Any, g: Any, tol: Tolerances = REFERENCE) -> bool:
    """Does the replayed value `g` of the `expect` field `key` agree with the reference's `e`?"""
    if e is None or g is None:
        return e is None and g is None  # `null` means "not valid": both or neither
    if key == _POSITION:
        return _dict_close(e, g, {"origin": tol.position})
    if key == _PLANE:
        return _dict_close(e, g, {"normal": tol.normal, "d": tol.plane_d})
    if key in _NORMALS:
        return _close(e, g, tol.normal)
    return exactly(e, g)


def move_mismatches(expect: dict[str, Any], got: dict[str, Any], tol: Tolerances = REFERENCE) -> list[str]:
    """Keys of `expect` on which `got` disagrees (or that `got` lacks)."""
    return [key for key, e in expect.items() if key not in got or not field_agrees(key, e, got[key], tol)]


def _ended_by_failed_placement(moves: list[dict[str, Any]], n_results: int) -> bool:
    """Fewer results than moves is right only when the last result is a placement the reference saw fail."""
    if not 0 < n_results < len(moves):
        return False
    last = moves[n_results - 1]
    return bool(last.get("placement")) and last["expect"].get("placement_result", "OK") != "OK"


def first_mismatch(case: dict[str, Any], results: list[dict[str, Any]], tol: Tolerances = REFERENCE) -> str | None:
    """A readable description of the first disagreeing move, or None."""
    moves = case["moves"]
    if len(results) != len(moves) and not _ended_by_failed_placement(moves, len(results)):
        return f"{len(results)} results for {len(moves)} moves"
    for i, (move, got) in enumerate(zip(moves, results)):
        bad = move_mismatches(move["expect"], got, tol)
        if bad:
            detail = "; ".join(f"{k}: expected {move['expect'][k]!r}, got {got.get(k)!r}" for k in bad)
            return f"move {i}: {detail}"
    return None


def case_mismatch(case: dict[str, Any], results: Any, tol: Tolerances = REFERENCE) -> str | None:
    """`first_mismatch` for a single-mover case, or for every mover of a
    `movers` case (results by mover id): None when all agree."""
    if "movers" not in case:
        return first_mismatch(case, results, tol)
    if not isinstance(results, dict) or set(results) != {m["id"] for m in case["movers"]}:
        return f"results for movers {sorted(results) if isinstance(results, dict) else results!r}"
    problems = [
        f"mover {m['id']}: {p}" for m in case["movers"] if (p := first_mismatch(m, results[m["id"]], tol)) is not None
    ]
    return "; ".join(problems) or None
