"""The serving process's collector settings (service/heap.py) and where the node applies them."""

from __future__ import annotations

import gc
import weakref
from collections.abc import Iterator

import pytest

from engine import World, load_scene
from service import heap
from service.bus.dispatch import OPERATIONS
from service.bus.node import NodeOptions, ServiceNode
from service.bus.zconfig import make_config
from support.service_harness import DEMO_SCENE, endpoint, free_port


class _Cycle:
    """An object that only the cyclic collector can free (it refers to itself)."""

    def __init__(self) -> None:
        self.me = self


@pytest.fixture
def restored_gc() -> Iterator[None]:
    """Whatever a test does to the collector is undone: this is the whole test run's process."""
    threshold = gc.get_threshold()
    try:
        yield
    finally:
        gc.unfreeze()
        gc.set_threshold(*threshold)


def test_tune_raises_the_young_threshold_only(restored_gc: None) -> None:
    gc.set_threshold(700, 11, 12)
    heap.tune()
    assert gc.get_threshold() == (heap.YOUNG_THRESHOLD, 11, 12)


def test_settle_hides_survivors_from_the_collector_and_frees_what_became_garbage(restored_gc: None) -> None:
    kept = _Cycle()
    alive = weakref.ref(kept)
    heap.settle()
    assert gc.get_freeze_count() > 0
    del kept  # like a landblock unloaded: unreachable, but frozen with everything else
    gc.collect()
    assert alive() is not None, "a frozen object is out of the collector's sight"
    heap.settle()  # what `unload` runs: unfreeze, collect, freeze again
    assert alive() is None


def _counting_settles(monkeypatch: pytest.MonkeyPatch) -> list[int]:
    calls: list[int] = []
    monkeypatch.setattr(heap, "settle", lambda: calls.append(1))
    monkeypatch.setattr(heap, "tune", lambda: calls.append(0))
    return calls


@pytest.mark.parametrize("tuned", [True, False])
def test_a_serving_node_settles_at_start_and_after_each_load_and_unload(
        tuned: bool, monkeypatch: pytest.MonkeyPatch, restored_gc: None) -> None:
    calls = _counting_settles(monkeypatch)
    source = load_scene(str(DEMO_SCENE))
    world = World(source.settings, loader=source.landblocks.get)  # a world that can load a landblock again
    for lb in source.landblocks:
        world.load_landblock(lb)
    node = ServiceNode(world, make_config(listen=[endpoint(free_port())]), NodeOptions(tune_heap=tuned))
    node.start()
    try:
        assert calls == ([0, 1] if tuned else [])  # tuned once, settled once, at start
        lb = sorted(world.loaded_landblocks())[-1]
        assert OPERATIONS["unload"].prepare(node, lb, {"v": 1}, 0.0)() == {"landblock": lb, "loaded": False}
        assert OPERATIONS["load"].prepare(node, lb, {"v": 1}, 0.0)() == {"landblock": lb, "loaded": True, "already": False}
        assert calls == ([0, 1, 1, 1] if tuned else [])
        OPERATIONS["load"].prepare(node, lb, {"v": 1}, 0.0)()  # already loaded: nothing changed, nothing to settle
        assert calls == ([0, 1, 1, 1] if tuned else [])
    finally:
        node.shutdown(timeout=5.0)
