"""benchmarks/round_trip_launches.py: a launch starts its own service and bound, asks the three series in
every order (an unanswered request fails the launch), stops both and reports each series' median."""

from __future__ import annotations

import math

from benchmarks.round_trip_launches import _launch


def test_a_launch_answers_every_series_and_reports_their_medians() -> None:
    medians = _launch(None, 12)  # two requests of each series in each of the six orders
    assert set(medians) == {"engine_echo", "raw_move", "move"}
    for name, value in medians.items():
        # a loopback round trip: more than nothing, less than the requests' 10 s timeout
        assert math.isfinite(value) and 0.0 < value < 10e6, name
