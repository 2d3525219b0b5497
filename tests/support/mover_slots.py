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


#: Slots that are views of the mover, re-made from its state whenever they are
#: read: `obstacle` (how others see it, refreshed before every collision test)
#: and `broad_phase_bounds` (the box round its shapes, made again for every new
#: position). What a move or query may change is the rest.
VIEW_SLOTS = ("__weakref__", "obstacle", "broad_phase_bounds")


def mover_state_slot_names() -> tuple[str, ...]:
    """The Mover's slots without its views (VIEW_SLOTS)."""
    return tuple(name for name in mover_slot_names() if name not in VIEW_SLOTS)
