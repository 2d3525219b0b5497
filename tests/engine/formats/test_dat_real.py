"""Against a real client's dat files, when ACPHYS_DAT_DIR names a directory holding them.

The end-of-retail dats are not redistributable, so these tests are skipped
(with the reason shown) unless ACPHYS_DAT_DIR is set. The checks they apply
also run on the shared reference dats in test_dat_scenes.py.
"""

from __future__ import annotations

import itertools
import os
import time

import pytest

from engine.formats.dat import DatCollection, DatFileMissing
from support.scene_checks import check_scene

DAT_DIR = os.environ.get("ACPHYS_DAT_DIR")
pytestmark = pytest.mark.skipif(
    not DAT_DIR, reason="ACPHYS_DAT_DIR not set: no real client dats on this machine"
)

HOLTBURG = 0xA9B4  # a town: terrain, buildings with interiors, static objects


@pytest.fixture(scope="module")
def dats():  # type: ignore[no-untyped-def]
    assert DAT_DIR is not None
    with DatCollection(DAT_DIR) as collection:
        yield collection


def test_headers_and_region(dats: DatCollection) -> None:
    assert (dats.cell.header.block_size, dats.cell.header.data_set) == (256, 2)
    assert (dats.portal.header.block_size, dats.portal.header.data_set) == (1024, 1)
    region = dats.region
    assert region.name == "Dereth"
    assert (region.num_block_length, region.square_length, region.lblock_length) == (255, 24.0, 8)
    table = dats.height_table()
    assert len(table) == 256 and table[0] == 0.0
    assert all(a < b for a, b in zip(table, table[1:]))


def test_holtburg(dats: DatCollection) -> None:
    scene = dats.scene_dict([HOLTBURG], name="holtburg")
    check_scene(scene)
    lb = scene["landblocks"][0]
    assert lb["buildings"], "Holtburg has buildings"
    assert lb["env_cells"], "Holtburg's buildings have interiors"
    assert scene["gfx_objs"] and scene["environments"]


def test_first_landblocks_of_the_directory(dats: DatCollection) -> None:
    ids = list(itertools.islice(dats.iter_landblock_ids(), 6))
    assert ids == sorted(ids) and len(ids) == 6
    check_scene(dats.scene_dict(ids))


def test_lookup_is_fast(dats: DatCollection) -> None:
    """One landblock costs a B-tree descent, not a scan of a multi-gigabyte file."""
    start = time.perf_counter()
    for lb in (HOLTBURG, 0x7D64, 0xC6A9, 0x0000):
        try:
            dats.landblock_dict(lb)
        except DatFileMissing:
            pass
    assert time.perf_counter() - start < 5.0
