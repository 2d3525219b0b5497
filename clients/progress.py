"""A one-line progress display for long commands (no dependency).

On a terminal it redraws one line; otherwise it prints a line at every
quarter, so logs stay short.
"""

from __future__ import annotations

import sys
from typing import TextIO

__all__ = ["Progress"]


class Progress:
    def __init__(self, total: int, label: str, stream: TextIO | None = None, width: int = 30) -> None:
        self.total = max(1, total)
        self.label = label
        self.stream = stream if stream is not None else sys.stderr
        self.width = width
        self.tty = bool(getattr(self.stream, "isatty", lambda: False)())
        self._last_quarter = -1
        self.count = 0

    def update(self, count: int) -> None:
        self.count = count
        frac = min(1.0, count / self.total)
        if self.tty:
            filled = int(frac * self.width)
            bar = "#" * filled + "." * (self.width - filled)
            self.stream.write(f"\r{self.label} [{bar}] {count}/{self.total}")
            self.stream.flush()
        else:
            quarter = int(frac * 4)
            if quarter > self._last_quarter:
                self._last_quarter = quarter
                self.stream.write(f"{self.label}: {count}/{self.total}\n")

    def done(self) -> None:
        if self.tty:
            self.stream.write("\n")
            self.stream.flush()
