"""The stats' latency windows (service/stats.py): the latest `size` samples whichever way they came (one at
a time, a batch's list, a column batch's finishing times as float64 bytes and shift), and what the stats key
reports of them."""

from __future__ import annotations

import random
import struct

import pytest

from service.stats import LatencyWindow, ServiceStats


def _fed(window: LatencyWindow, rng: random.Random, rounds: int) -> list[float]:
    """Feeds `window` a random mix of singles, lists and shifted lists; every sample it was given, in order."""
    given: list[float] = []
    for _ in range(rounds):
        how = rng.randrange(3)
        if how == 0:
            s = rng.random()
            window.add(s)
            given.append(s)
        else:
            values = [rng.random() for _ in range(rng.randrange(0, 150))]
            if how == 1:
                window.extend(values)
                given += values
            else:
                shift = rng.uniform(-5.0, 5.0)
                window.extend_shifted(shift, _f64(values))
                given += [shift + v for v in values]
    return given


def _f64(values: list[float]) -> bytes:
    """Values as the engine's batch rows write times: little-endian float64s."""
    return struct.pack(f"<{len(values)}d", *values)


@pytest.mark.parametrize("size", [1, 10, 100, 1000])
def test_window_holds_the_latest_samples_exactly(size: int) -> None:
    rng = random.Random(size)
    window = LatencyWindow(size=size)
    given = _fed(window, rng, 400)
    assert window.count == len(given)
    assert window.samples() == given[-size:]
    s = window.summary_ms()
    kept = sorted(given[-size:])
    assert s["window"] == len(kept) and s["max"] == pytest.approx(kept[-1] * 1000.0)
    assert s["mean"] == pytest.approx(sum(kept) / len(kept) * 1000.0)


def test_window_of_singles_keeps_a_bounded_number() -> None:
    window = LatencyWindow(size=50)
    for k in range(100_000):
        window.add(k * 1e-6)
    assert window.count == 100_000 and window.samples() == [k * 1e-6 for k in range(99_950, 100_000)]
    assert window._kept <= 50 + 1024  # the chunk being filled and the ones that make up the window


def test_a_column_batch_reports_its_latencies_and_engine_times() -> None:
    stats = ServiceStats()
    stats.move_done(0.004, 0.001)
    stats.batch_done(0.5, _f64([0.001, 0.002, 0.003]), _f64([0.0005, 0.0006, 0.0007]))
    assert stats.moves == 4
    got = stats.samples()
    assert got["latency_s"] == [0.004, 0.5 + 0.001, 0.5 + 0.002, 0.5 + 0.003]
    assert got["engine_s"] == [0.001, 0.0005, 0.0006, 0.0007]
    snap = stats.snapshot()
    assert snap["moves"] == 4 and snap["latency_ms"]["count"] == 4 and snap["latency_ms"]["window"] == 4
    assert snap["latency_ms"]["max"] == pytest.approx(503.0) and snap["engine_ms"]["max"] == pytest.approx(1.0)
