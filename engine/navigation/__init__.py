"""Navigation: paths a walker can walk, found on a graph and proven by the client's own transition.

The layer above the spatial queries (engine.queries); the World answers it
(World.path, World.paths, World.reachable, World.random_point). A path's
guarantee, and the walk it is kept by, are in engine.navigation.walk; how a
query runs, in engine.navigation.path; the graph, in engine.navigation.graph.
"""

from .results import PathResult
from .settings import DEFAULT_NAV, REASONS, NavSettings

__all__ = ["DEFAULT_NAV", "NavSettings", "PathResult", "REASONS"]
