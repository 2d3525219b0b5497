"""The values the `acphys` commands take, read with messages that say what was expected.

Ids are hex, as everywhere the project shows them: a mover id (`7A`, up to 64 bits), a landblock id (`A9B4`,
clients/cli/landblock.py) and a cell id, which is always 8 hex digits, `XXYYnnnn` (landblock XXYY, cell
nnnn): `A9B4` where a cell id belongs is a landblock id, and said to be one rather than read as cell
0000A9B4. A position is CELL X Y Z (the cell id and landblock-local metres).

Each reader raises argparse.ArgumentTypeError, so that as an argparse `type` (or inside
`PositionAction`) a bad value is a usage error (exit status 2) that names the option.
"""

from __future__ import annotations

import argparse
import math
import re
from collections.abc import Sequence
from typing import Any

from engine.geometry import Position, Vec3

__all__ = ["hex_id", "cell_id", "number", "parse_position", "PositionAction", "TargetAction", "CELL_FORM"]

#: how a cell id is written, with an example
CELL_FORM = "8 hex digits XXYYnnnn (landblock XXYY, cell nnnn), e.g. A9B40001"
#: mover ids are uint64 (docs/protocol.md; the service assigns ids from 2^32 up)
_MAX_MOVER_ID = 2**64 - 1
_HEX = re.compile(r"^[0-9A-Fa-f]+$")


def _digits(text: str) -> str | None:
    """The hex digits of `text` (a leading 0x dropped), or None when it is not plain hex."""
    t = text.strip()
    t = t[2:] if t[:2].lower() == "0x" else t
    return t if _HEX.match(t) else None


def hex_id(text: str) -> int:
    """A mover id: hex, 64 bits at most (`7A`, `0x7A`, `100000001`)."""
    digits = _digits(text)
    if digits is None:
        raise argparse.ArgumentTypeError(f"{text!r} is not a hex mover id (e.g. 7A or 100000001)")
    value = int(digits, 16)
    if value > _MAX_MOVER_ID:
        raise argparse.ArgumentTypeError(f"{text!r} is not a mover id: at most 16 hex digits")
    return value


def cell_id(text: str) -> int:
    """A cell id: exactly 8 hex digits (`A9B40001`); a landblock id alone (`A9B4`) is refused as one."""
    digits = _digits(text)
    if digits is None or len(digits) not in (1, 2, 3, 4, 8):
        raise argparse.ArgumentTypeError(f"{text!r} is not a cell id: {CELL_FORM}")
    value = int(digits, 16)
    if len(digits) <= 4:
        raise argparse.ArgumentTypeError(f"{text!r} is a landblock id, not a cell id: a cell id is 8 hex digits "
                                         f"XXYYnnnn (landblock XXYY, cell nnnn), e.g. {value:04X}0001")
    return value


def number(text: str) -> float:
    """A finite number (metres, seconds): `nan` and `inf` are refused here, before anything is sent."""
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r} is not a number") from None
    if not math.isfinite(value):
        raise argparse.ArgumentTypeError(f"{text!r} is not a finite number")
    return value


def parse_position(values: Sequence[str]) -> Position:
    """CELL X Y Z (hex cell id, landblock-local metres) as a Position; ArgumentTypeError naming the bad word."""
    if len(values) != 4:
        raise argparse.ArgumentTypeError(f"{' '.join(values)!r} is not CELL X Y Z (a hex cell id, three numbers)")
    cell = cell_id(values[0])
    x, y, z = (number(v) for v in values[1:])
    return Position.at(cell, Vec3(x, y, z))


class PositionAction(argparse.Action):
    """An option of four words, CELL X Y Z, stored as a Position (a usage error naming the option when not)."""

    def __call__(self, parser: argparse.ArgumentParser, namespace: argparse.Namespace, values: Any,
                 option_string: str | None = None) -> None:
        try:
            setattr(namespace, self.dest, parse_position(values))
        except argparse.ArgumentTypeError as e:
            raise argparse.ArgumentError(self, str(e)) from None


class TargetAction(argparse.Action):
    """`move --to`: X Y Z (in the mover's current cell) or CELL X Y Z, stored as (cell or None, Vec3)."""

    def __call__(self, parser: argparse.ArgumentParser, namespace: argparse.Namespace, values: Any,
                 option_string: str | None = None) -> None:
        try:
            if len(values) not in (3, 4):
                raise argparse.ArgumentTypeError(f"takes X Y Z or CELL X Y Z, not {len(values)} value(s)")
            cell = cell_id(values[0]) if len(values) == 4 else None
            x, y, z = (number(v) for v in values[-3:])
        except argparse.ArgumentTypeError as e:
            raise argparse.ArgumentError(self, str(e)) from None
        setattr(namespace, self.dest, (cell, Vec3(x, y, z)))
