"""NavCache: a World's navigation graphs, one per walker class, and the settings they are built with."""

from __future__ import annotations

from typing import TYPE_CHECKING

from ..settings import EngineSettings
from ..world.mover import Mover
from .graph import NavGraph
from .settings import DEFAULT_NAV, NavSettings
from .walker import WalkerClass, walker_class

if TYPE_CHECKING:
    from ..world.world import World

__all__ = ["NavCache"]


class NavCache:
    """The graphs of one World, by walker class; dropped whole when the World's engine settings or the
    navigation settings change (a graph's edges are walks made under them)."""

    def __init__(self, world: World, settings: NavSettings = DEFAULT_NAV) -> None:
        settings.check()
        self.world = world
        self._settings = settings
        self._engine_settings: EngineSettings = world.settings
        self.graphs: dict[WalkerClass, NavGraph] = {}

    @property
    def settings(self) -> NavSettings:
        return self._settings

    @settings.setter
    def settings(self, settings: NavSettings) -> None:
        settings.check()
        self._settings = settings
        self.graphs.clear()

    def graph_for(self, probe: Mover) -> NavGraph:
        """The graph of the probe's walker class, up to date with the World's landblocks."""
        if self.world.settings is not self._engine_settings:
            self.graphs.clear()
            self._engine_settings = self.world.settings
        key = walker_class(probe)
        graph = self.graphs.get(key)
        if graph is None:
            graph = self.graphs[key] = NavGraph(self.world, key, self._settings)
        else:
            graph.refresh()
        return graph

    def refresh(self) -> None:
        """Drop from every graph what the World's landblocks no longer match (NavGraph.refresh)."""
        for graph in self.graphs.values():
            graph.refresh()
