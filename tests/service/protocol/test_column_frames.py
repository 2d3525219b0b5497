"""Column replies and publications put together from their columns' bytes (service/protocol/column_frames.py)
against msgpack packing the same map: the same bytes, for every size of header msgpack chooses."""

from __future__ import annotations

from typing import Any

import msgpack
import numpy as np
import pytest

from service.protocol.column_frames import PUBLICATION_NAMES, REPLY_NAMES, rows_message
from service.protocol.columns import PUBLICATION_ID, REPLY_COLUMNS

_ROW_BYTES = {c.name: c.item_bytes for c in (PUBLICATION_ID, *REPLY_COLUMNS)}


def _columns(names: tuple[str, ...], rows: int, collided: int, seed: int) -> list[bytes]:
    rng = np.random.default_rng(seed)
    sizes = [8 * collided if name == "collide_ids" else rows * _ROW_BYTES[name] for name in names]
    return [rng.integers(0, 256, size, dtype=np.uint8).tobytes() for size in sizes]


def _packed(content: dict[str, Any]) -> bytes:
    return msgpack.packb({"v": 1, **content}, use_bin_type=True)


# rows around msgpack's header limits: positive fixint / uint8 / uint16 counts, bin8 / bin16 / bin32 columns
@pytest.mark.parametrize("rows", [0, 1, 7, 127, 128, 255, 256, 2731, 4096])
@pytest.mark.parametrize("collided", [0, 1, 40])
def test_reply_is_what_msgpack_packs(rows: int, collided: int) -> None:
    cols = _columns(REPLY_NAMES, rows, collided, rows + collided)
    want = _packed({"n": rows, "columns": dict(zip(REPLY_NAMES, cols)), "errors": []})
    assert rows_message(rows, rows, cols, []) == want
    errors = [{"index": 3, "id": 2**63 + 5, "error": {"kind": "unknown_mover", "message": "mover ? is not here",
                                                      "path": "columns.id[3]"}}]
    want = _packed({"n": rows, "columns": dict(zip(REPLY_NAMES, cols)), "errors": errors})
    assert rows_message(rows, rows, cols, errors) == want


@pytest.mark.parametrize("rows", [0, 3, 300])
def test_publication_is_what_msgpack_packs(rows: int) -> None:
    cols = _columns(PUBLICATION_NAMES, rows, 2, rows)
    want = _packed({"n": rows, "columns": dict(zip(PUBLICATION_NAMES, cols))})
    assert rows_message(rows, rows, cols, publication=True) == want
    assert msgpack.unpackb(rows_message(rows, rows, cols, publication=True)) == msgpack.unpackb(want)


def test_a_frame_is_reused_only_for_the_same_sizes() -> None:
    small, big = _columns(REPLY_NAMES, 2, 0, 1), _columns(REPLY_NAMES, 300, 0, 2)
    for cols, rows in ((small, 2), (big, 300), (small, 2), (big, 300)):
        assert rows_message(rows, rows, cols, []) == _packed({"n": rows, "columns": dict(zip(REPLY_NAMES, cols)),
                                                               "errors": []})


def test_a_column_too_many_or_too_few_is_refused() -> None:
    cols = _columns(REPLY_NAMES, 4, 0, 3)
    with pytest.raises(ValueError):
        rows_message(4, 4, cols[:-1], [])
    with pytest.raises(ValueError):
        rows_message(4, 4, [*cols, b""], [])
