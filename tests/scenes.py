"""Small synthetic worlds for scenario tests: now benchmarks/scenes.py's, re-exported until the tests import it."""

from benchmarks.scenes import HEIGHT_TABLE, PLAYER, world_from_heights

__all__ = ["HEIGHT_TABLE", "PLAYER", "world_from_heights"]
