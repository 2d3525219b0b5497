"""Errors the engine raises: clear, specific, and all ValueErrors."""

from __future__ import annotations

__all__ = [
    "EngineError",
    "UnknownCellError",
    "LandblockNotLoadedError",
    "NonFiniteError",
    "OutOfRangeError",
    "UnknownMoverError",
    "SceneFormatError",
]


class EngineError(ValueError):
    """Base of every error the engine raises on bad input.

    `field` names the argument at fault when one is known, in the words of
    the call ("position.origin[0]", "spec.spheres[1].radius", "dt").
    """

    def __init__(self, message: str = "", field: str | None = None) -> None:
        super().__init__(message)
        self.field = field


class UnknownCellError(EngineError):
    """A cell id that is malformed or names no cell of a loaded landblock."""


class LandblockNotLoadedError(EngineError):
    """A move or query needs a landblock the World does not hold."""


class NonFiniteError(EngineError):
    """A NaN or infinite coordinate, orientation or velocity."""


class OutOfRangeError(EngineError):
    """A finite number outside the engine's limits (engine.limits): too large
    for single precision, or outside the physical bounds of its field."""


class UnknownMoverError(EngineError, KeyError):
    """No mover with that id is registered."""

    def __str__(self) -> str:  # KeyError would quote the message
        return str(self.args[0]) if self.args else "unknown mover"


class SceneFormatError(EngineError):
    """A scene or trace file that does not follow its format."""


class PlacementFailedError(EngineError):
    """A mover registered with a placement found no place: it is not registered."""
