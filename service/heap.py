"""The service process's garbage-collector settings.

A service holds its loaded world for hours: a few hundred thousand objects
that live as long as their landblock. CPython's collector is tuned for
neither side of that: every full collection walks the whole world again
(about 20 ms here, several per million moves), and the youngest generation
(700 objects by default) fills several times per batch with a batch's rows,
which all die when the reply is sent. Measured on the batch workload (benchmarks/bench_batches.py) with
the column form in one process (docs/performance.md, "Service over
loopback"): about 2 µs per move went to the collector, nothing after.

So a serving process (the CLI's `serve`, not a library caller: these are
process-wide settings) calls `tune()` once, and `settle()` whenever the
world changed: at start and after a landblock is loaded or unloaded.
"""

from __future__ import annotations

import gc

__all__ = ["YOUNG_THRESHOLD", "tune", "settle"]

#: objects allocated (net) before a young collection: above one batch's rows, so that a batch's
#: short-lived rows are freed by reference counting before the collector ever walks them
YOUNG_THRESHOLD = 10_000


def tune() -> None:
    """Raise the young generation's threshold (the older generations keep theirs)."""
    _young, middle, old = gc.get_threshold()
    gc.set_threshold(YOUNG_THRESHOLD, middle, old)


def settle() -> None:
    """Collect what is garbage now, then move every survivor (the world, mostly) out of the
    collector's sight: later full collections walk only what was made since. Everything is
    unfrozen first, so what an unload left unreachable is collected too."""
    gc.unfreeze()
    gc.collect()
    gc.freeze()
