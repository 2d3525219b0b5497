"""Reader for the Asheron's Call client's dat files.

`DatFile` reads one dat container (`client_cell_1.dat`, `client_portal.dat`);
`DatCollection` reads a directory holding both and produces the same dicts as
the `acphys-scene/1` JSON format (shared/formats/README.md). The per-record
parsers are exported for tests and tools. Every problem with a file raises
`DatError` (a ValueError) naming the dat path and the file id.
"""

from .bsp import count_leaves, read_bsp
from .cell_records import CellLandblock, LandblockInfo, parse_cell_landblock, parse_env_cell, parse_landblock_info
from .collection import (
    CELL_DAT_NAME,
    PORTAL_DAT_NAME,
    SCENE_FORMAT,
    DatCollection,
    is_dat_directory,
    landblock_references,
)
from .container import DatFile, DatHeader, DirectoryEntry
from .environment import parse_environment
from .errors import DatError, DatFileMissing
from .gfxobj import parse_gfx_obj
from .region import REGION_ID, RegionInfo, parse_region
from .setup import parse_setup

__all__ = [
    "CELL_DAT_NAME",
    "PORTAL_DAT_NAME",
    "REGION_ID",
    "SCENE_FORMAT",
    "CellLandblock",
    "DatCollection",
    "DatError",
    "DatFile",
    "DatFileMissing",
    "DatHeader",
    "DirectoryEntry",
    "LandblockInfo",
    "RegionInfo",
    "count_leaves",
    "is_dat_directory",
    "landblock_references",
    "parse_cell_landblock",
    "parse_env_cell",
    "parse_environment",
    "parse_gfx_obj",
    "parse_landblock_info",
    "parse_region",
    "parse_setup",
    "read_bsp",
]
