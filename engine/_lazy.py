"""Package attributes imported on first use (PEP 562), so that importing a light
part of the engine (its geometry, its value types) does not load the per-move
machinery behind the package's other names."""

from __future__ import annotations

import importlib
from typing import Any
from collections.abc import Callable, Mapping

__all__ = ["lazy_getattr"]


def lazy_getattr(package: str, exports: Mapping[str, str], namespace: dict[str, Any]) -> Callable[[str], Any]:
    """A module `__getattr__` for `package` that imports `exports[name]` (a module
    relative to the package) on first access of `name`, then keeps the value in
    `namespace` (the package's globals) so later accesses are plain lookups."""

    def __getattr__(name: str) -> Any:
        module = exports.get(name)
        if module is None:
            raise AttributeError(f"module {package!r} has no attribute {name!r}")
        value = getattr(importlib.import_module(module, package), name)
        namespace[name] = value
        return value

    return __getattr__
