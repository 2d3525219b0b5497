"""Where the shared reference material lives, and loading its scenes."""

from __future__ import annotations

import json
import os
from pathlib import Path
from typing import Any


def shared_root() -> Path:
    """The shared reference material: $ACPHYS_SHARED, else `../shared` beside the project root,
    else /work/shared (where it lives on these machines, for clones made elsewhere)."""
    candidates = [Path(p) for p in (os.environ.get("ACPHYS_SHARED"),) if p]
    candidates += [Path(__file__).resolve().parents[3] / "shared", Path("/work/shared")]
    for candidate in candidates:
        if (candidate / "dats").is_dir():
            return candidate
    raise RuntimeError("the shared reference material (../shared) is not on this machine")


def load_scene_json(name: str) -> dict[str, Any]:
    """`shared/oracle/scenes/<name>.json`."""
    with open(shared_root() / "oracle" / "scenes" / f"{name}.json", encoding="utf-8") as f:
        return json.load(f)


def scene_names() -> list[str]:
    """Every reference scene's name."""
    return sorted(p.stem for p in (shared_root() / "oracle" / "scenes").glob("*.json"))
