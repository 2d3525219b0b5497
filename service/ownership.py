"""Which landblocks an instance owns: every one ("*"), or an explicit set.

An instance declares the per-landblock keys only for what it owns, so the
key space routes each landblock's requests to exactly one instance.
"""

from __future__ import annotations

from dataclasses import dataclass

from .wire import lb_hex, parse_lb_hex

__all__ = ["Ownership"]


@dataclass(frozen=True, slots=True)
class Ownership:
    landblocks: frozenset[int] | None = None  # None: every landblock

    @classmethod
    def parse(cls, text: str | None) -> Ownership:
        """`*` (or nothing) for all, else comma-separated XXYY ids: `A9B4,A9B5`."""
        if text is None or text.strip() in ("", "*"):
            return cls(None)
        ids = set()
        for part in text.split(","):
            part = part.strip()
            if part:
                ids.add(parse_lb_hex(part.upper()))  # the command line may say a9b4
        if not ids:
            raise ValueError(f"no landblocks in {text!r}")
        return cls(frozenset(ids))

    @property
    def everything(self) -> bool:
        return self.landblocks is None

    def owns(self, lb: int) -> bool:
        return self.landblocks is None or lb in self.landblocks

    def key_parts(self) -> list[str]:
        """The `<XXYY>` chunks to declare: `*` or each owned landblock."""
        if self.landblocks is None:
            return ["*"]
        return [lb_hex(lb) for lb in sorted(self.landblocks)]

    def to_wire(self) -> str | list[int]:
        return "*" if self.landblocks is None else sorted(self.landblocks)
