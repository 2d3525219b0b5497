"""A one-line progress display for long commands (no dependency).

On a terminal it redraws one line; otherwise it prints a line at every
quarter, so logs stay short.
"""

from __future__ import annotations

import sys
from typing import TextIO

__all__ = ["Progress"]


class Progress:
    def __init__(self, total: int, label: str, stream: TextIO | None = None, width: int = 30,
                 estimate: bool = False) -> None:
        """`estimate`: `total` is a guess, shown as `~total` until `done(final)` gives the real count."""
        self.total = max(1, total)
        self.estimate = estimate
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
            self.stream.write(f"\r{self.label} [{bar}] {count}/{self._total_text()}")
            self.stream.flush()
        else:
            quarter = int(frac * 4)
            if quarter > self._last_quarter:
                self._last_quarter = quarter
                self.stream.write(f"{self.label}: {count}/{self._total_text()}\n")

    def _total_text(self) -> str:
        return f"~{self.total}" if self.estimate else str(self.total)

    def done(self, final: int | None = None) -> None:
        """End the display; with `final`, the total was an estimate and `final` is the real count."""
        if final is not None:
            self.total, self.estimate = max(1, final), False
            if self.tty:
                self.update(final)
            else:
                self.stream.write(f"{self.label}: {final}/{final} done\n")
        if self.tty:
            self.stream.write("\n")
            self.stream.flush()
