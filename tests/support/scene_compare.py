"""Compare `acphys-scene/1` dicts: defaults filled in, floats within a tolerance.

Scene JSON holds decimal renderings of float32 values and leaves out fields
that take their default; dats hold the float32 values and every field. So
both sides are normalised (absent optional fields get the format README's
defaults) and floats compare with a small relative tolerance; everything
else (ints, strings, bools, keys, list lengths) must match exactly.
"""

from __future__ import annotations

import copy
import math
from typing import Any

ZERO_SPHERE = {"origin": [0.0, 0.0, 0.0], "radius": 0.0}
REL_TOL = 1e-6
ABS_TOL = 1e-6  # for values that are zero on one side and -1e-8 on the other


def normalize_scene(scene: dict[str, Any]) -> dict[str, Any]:
    """A copy of `scene` with every absent optional field set to its default."""
    s = copy.deepcopy(scene)
    for lb in s.get("landblocks", []):
        lb.setdefault("terrain", [0] * 81)
        for key in ("env_cells", "buildings", "objects"):
            if not lb.get(key):
                lb.pop(key, None)
        for cell in lb.get("env_cells", []):
            cell.setdefault("static_objects", [])
            cell.setdefault("restriction_obj", 0)
            cell.setdefault("seen_outside", False)
    for setup in s.get("setups", {}).values():
        setup.setdefault("sorting_sphere", copy.deepcopy(ZERO_SPHERE))
        setup.setdefault("selection_sphere", copy.deepcopy(ZERO_SPHERE))
        setup.setdefault("allow_free_heading", False)
        setup.setdefault("spheres", [])
        setup.setdefault("cyl_spheres", [])
        setup.setdefault("placement_frames", {})
        for key in ("height", "radius", "step_up_height", "step_down_height"):
            setup.setdefault(key, 0.0)
    for key in ("environments", "gfx_objs", "setups"):
        if not s.get(key):
            s.pop(key, None)
    return s


def differences(a: Any, b: Any, path: str = "$", limit: int = 20) -> list[str]:
    """Where `a` and `b` differ (floats within tolerance count as equal)."""
    out: list[str] = []
    _diff(a, b, path, out, limit)
    return out


def _diff(a: Any, b: Any, path: str, out: list[str], limit: int) -> None:
    if len(out) >= limit:
        return
    if isinstance(a, dict) and isinstance(b, dict):
        for k in sorted(set(a) | set(b)):
            if k not in a or k not in b:
                out.append(f"{path}.{k}: only in {'second' if k not in a else 'first'}")
            else:
                _diff(a[k], b[k], f"{path}.{k}", out, limit)
    elif isinstance(a, list) and isinstance(b, list):
        if len(a) != len(b):
            out.append(f"{path}: length {len(a)} != {len(b)}")
            return
        for i, (x, y) in enumerate(zip(a, b)):
            _diff(x, y, f"{path}[{i}]", out, limit)
    elif isinstance(a, bool) or isinstance(b, bool):
        if a is not b:
            out.append(f"{path}: {a!r} != {b!r}")
    elif isinstance(a, float) or isinstance(b, float):
        if not isinstance(a, (int, float)) or not isinstance(b, (int, float)):
            out.append(f"{path}: {a!r} != {b!r}")
        elif not math.isclose(a, b, rel_tol=REL_TOL, abs_tol=ABS_TOL):
            out.append(f"{path}: {a!r} != {b!r}")
    elif type(a) is not type(b) or a != b:
        out.append(f"{path}: {a!r} != {b!r}")
