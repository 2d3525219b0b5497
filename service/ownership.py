"""Which landblocks an instance owns: every one ("*"), an explicit set, or a rule.

An instance declares the per-landblock keys only for what it owns, so the
key space routes each landblock's requests to exactly one instance.

The rule form, `x=LO-HI` (two hex bytes), owns every landblock whose X (the
id's high byte, west to east) lies in LO..HI: a stripe of the map running
north to south, for worlds whose landblocks are not known in advance (a dat
directory). Its keys are chunk prefixes (`A$*`, `A9$*`), so the stripe
costs a few dozen declarations, not one per landblock.
"""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import dataclass

from service.protocol.wire import lb_hex, parse_lb_hex

__all__ = ["Ownership"]

_X_MAX = 0xFF


@dataclass(frozen=True, slots=True)
class Ownership:
    landblocks: frozenset[int] | None = None  # None (and no x_range): every landblock
    #: the rule form: landblock X in [lo, hi] (inclusive), whatever Y
    x_range: tuple[int, int] | None = None

    def __post_init__(self) -> None:
        if self.landblocks is not None and self.x_range is not None:
            raise ValueError("an ownership is a landblock list or an X range, not both")
        if self.x_range is not None:
            lo, hi = self.x_range
            if not 0 <= lo <= hi <= _X_MAX:
                raise ValueError(f"X range {lo:02X}-{hi:02X} is not within 00-FF, low end first")

    @classmethod
    def parse(cls, text: str | None) -> Ownership:
        """`*` (or nothing) for all; `x=LO-HI` for the X stripe LO..HI (hex bytes, `x=00-7F`);
        else comma-separated XXYY ids: `A9B4,A9B5`."""
        if text is None or text.strip() in ("", "*"):
            return cls()
        text = text.strip()
        if text[:2].lower() == "x=":
            return cls.x_stripe(*_parse_x_range(text[2:]))
        ids = set()
        for part in text.split(","):
            part = part.strip()
            if part:
                ids.add(parse_lb_hex(part.upper()))  # the command line may say a9b4
        if not ids:
            raise ValueError(f"no landblocks in {text!r}")
        return cls(frozenset(ids))

    @classmethod
    def x_stripe(cls, lo: int, hi: int) -> Ownership:
        """Landblocks with X in lo..hi; the whole map (00-FF) is the same as `*`."""
        if (lo, hi) == (0, _X_MAX):
            return cls()
        return cls(x_range=(lo, hi))

    @property
    def everything(self) -> bool:
        return self.landblocks is None and self.x_range is None

    def owns(self, lb: int) -> bool:
        if self.x_range is not None:
            return self.x_range[0] <= (lb >> 8) & 0xFF <= self.x_range[1]
        return self.landblocks is None or lb in self.landblocks

    def key_parts(self) -> list[str]:
        """The `<XXYY>` chunks to declare: `*`, each owned landblock, or the chunk prefixes of an X range."""
        if self.x_range is not None:
            return _x_range_parts(*self.x_range)
        if self.landblocks is None:
            return ["*"]
        return [lb_hex(lb) for lb in sorted(self.landblocks)]

    def to_wire(self) -> str | list[int] | dict[str, int]:
        """`"*"`, the sorted landblock ids, or `{"x_min", "x_max"}` for the rule form."""
        if self.x_range is not None:
            return {"x_min": self.x_range[0], "x_max": self.x_range[1]}
        return "*" if self.landblocks is None else sorted(self.landblocks)

    def to_text(self) -> str:
        """The `--own` argument that parses back to this ownership."""
        if self.x_range is not None:
            return f"x={self.x_range[0]:02X}-{self.x_range[1]:02X}"
        return "*" if self.landblocks is None else ",".join(self.key_parts())

    # -- dividing an ownership between workers ---------------------------------------------
    def split(self, parts: int, known: Iterable[int] = ()) -> list[Ownership]:
        """At most `parts` disjoint ownerships covering this one, each contiguous (few borders).

        A list (or `*` with the world's landblocks `known`, as for a scene) is sorted west to
        east, then south to north, and cut into runs of nearly equal length: vertical stripes of
        whole columns when the area is a rectangle. `*` with nothing known (a dat directory) and an
        X range become X stripes of nearly equal width. Fewer parts come back when there are
        fewer landblocks (or X columns) than `parts`.
        """
        if parts < 1:
            raise ValueError("split into at least one part")
        ids: list[int] | None = None
        if self.landblocks is not None:
            ids = sorted(self.landblocks)
        elif self.x_range is None:
            known_ids = sorted({lb & 0xFFFF for lb in known})
            ids = known_ids or None
        if ids is not None:
            n = min(parts, len(ids))
            cuts = [len(ids) * k // n for k in range(n + 1)]
            return [Ownership(frozenset(ids[cuts[k]:cuts[k + 1]])) for k in range(n)]
        lo, hi = self.x_range if self.x_range is not None else (0, _X_MAX)
        width = hi - lo + 1
        n = min(parts, width)
        edges = [lo + width * k // n for k in range(n + 1)]
        return [Ownership.x_stripe(edges[k], edges[k + 1] - 1) for k in range(n)]


def _parse_x_range(text: str) -> tuple[int, int]:
    lo_text, sep, hi_text = text.partition("-")
    if not sep or len(lo_text.strip()) != 2 or len(hi_text.strip()) != 2:
        raise ValueError(f"X range {text!r} is not LO-HI with two hex digits each (x=00-7F)")
    try:
        lo, hi = int(lo_text, 16), int(hi_text, 16)
    except ValueError:
        raise ValueError(f"X range {text!r} is not hexadecimal") from None
    if lo > hi:
        raise ValueError(f"X range {text!r}: the low end comes first")
    return lo, hi


def _x_range_parts(lo: int, hi: int) -> list[str]:
    """Chunk patterns matching exactly the XXYY ids with X in lo..hi: a whole hex digit `D$*`
    where all sixteen X values DX are in, else `XX$*` per X value."""
    out: list[str] = []
    for digit in range(16):
        first, last = digit << 4, (digit << 4) | 0xF
        if last < lo or first > hi:
            continue
        if lo <= first and last <= hi:
            out.append(f"{digit:X}$*")
        else:
            out.extend(f"{x:02X}$*" for x in range(max(first, lo), min(last, hi) + 1))
    return out
