"""Shims for building the engine with mypyc and running it without."""

from __future__ import annotations

from typing import Any, TypeVar
from collections.abc import Callable

T = TypeVar("T")

try:
    from mypy_extensions import mypyc_attr
except ImportError:  # pure Python without mypy installed: a no-op decorator

    def mypyc_attr(*_args: Any, **_kwargs: Any) -> Callable[[T], T]:  # type: ignore[misc]
        def wrap(cls: T) -> T:
            return cls

        return wrap


__all__ = ["mypyc_attr"]
