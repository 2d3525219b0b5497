"""The Mover's slot names, read from its source: a compiled Mover (mypyc) has no `__slots__` attribute."""

from __future__ import annotations

import ast
from pathlib import Path

MOVER_SOURCE = Path(__file__).resolve().parents[2] / "engine" / "world" / "mover.py"


def mover_slot_names() -> tuple[str, ...]:
    """`Mover.__slots__` as written in engine/world/mover.py, whichever build is installed."""
    tree = ast.parse(MOVER_SOURCE.read_text(encoding="utf-8"))
    for node in ast.walk(tree):
        if isinstance(node, ast.ClassDef) and node.name == "Mover":
            for stmt in node.body:
                if isinstance(stmt, ast.Assign) and any(isinstance(t, ast.Name) and t.id == "__slots__" for t in stmt.targets):
                    value = ast.literal_eval(stmt.value)
                    return tuple(value)
    raise AssertionError(f"no Mover.__slots__ in {MOVER_SOURCE}")
