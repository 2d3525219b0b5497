"""Which diagonal splits a terrain cell: the client's seeded rule.

The client derives the split of every 24 m cell from the cell's global
coordinates with a fixed 32-bit pseudo-random hash, so that the same terrain
always gets the same triangles. It must be bit-exact: the wrong diagonal puts
the ground up to several metres off on a slope.
"""

from __future__ import annotations

from typing import Final

__all__ = ["split_sw_to_ne"]

_MASK: Final = 0xFFFFFFFF


def split_sw_to_ne(gx: int, gy: int) -> bool:
    """True when the cell at global cell coordinates (gx, gy) is cut SW-NE.

    Cut SW-NE the triangles are (v00, v10, v11) and (v00, v11, v01); otherwise
    (v00, v10, v01) and (v11, v01, v10). (LandblockStruct.ConstructPolygons)
    """
    s = (gy * ((214614067 * gx + 1813693831) & _MASK) - 1109124029 * gx - 1369149221) & _MASK
    return s * 2.3283064e-10 >= 0.5
