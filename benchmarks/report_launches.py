"""docs/performance.md's words for the round trip's launches (benchmarks/round_trip_launches.py): the target
row's figure, and section 3's note on each launch, the protocol's floor in the same launches and the launches
with every process on one core."""

from __future__ import annotations

import statistics
from typing import Any

__all__ = ["launches_measured", "launches_note"]


def launches_measured(lat: dict[str, Any]) -> str:
    """The target row's figure: the median over the launches, its spread, the two shares, the floor and the
    one-core launches beside it."""
    launches = lat["launches"]
    m, svc_share, client_share = launches["over_bound"], launches["service"], launches["client"]
    floor = launches.get("floor_over_bound")
    floor_text = ("" if floor is None else
                  f"; the protocol's own floor, in the same launches, {floor['median']:.0f} µs over (section 3)")
    return (f"{m['median']:.0f} µs over, the median of {len(launches['launches'])} fresh launches of every process, "
            f"each asked one request at a time in every order ({_spread(m)}; "
            f"the service {svc_share['median']:.0f} µs, the client library {client_share['median']:.0f} µs"
            f"{floor_text}){_one_core_text(lat)}")


def _spread(m: dict[str, float]) -> str:
    """How far the launches' figures spread: their quartiles (when recorded) and their range, in µs."""
    quartiles = f"quartiles {m['q1']:.0f} to {m['q3']:.0f}, " if "q1" in m else ""
    return f"{quartiles}launches {m['min']:.0f} to {m['max']:.0f} µs"


def _one_core_text(lat: dict[str, Any]) -> str:
    """The target row's words for the launches with every process on one core, when measured."""
    pinned = lat.get("launches_one_core")
    if not pinned:
        return ""
    m = pinned["over_bound"]
    floor = pinned.get("floor_over_bound")
    floor_text = "" if floor is None else f"; the floor {floor['median']:.0f} µs"
    return (f"; with every process on one core, {m['median']:.0f} µs over in {len(pinned['launches'])} launches "
            f"({_spread(m)}{floor_text}), beside the verdict")


def launches_note(lat: dict[str, Any]) -> str:
    """The same three asked again in several fresh launches of every process (benchmarks/round_trip_launches.py)."""
    launches = lat.get("launches")
    if not launches:
        return ""
    each = ", ".join(f"{e['over_bound']:+.0f}" for e in launches["over_bound_each"])
    m = launches["over_bound"]
    return (f" Asked the same way in {len(launches['launches'])} fresh launches of the service, the bound and the "
            f"asking process, one after the other, `Client.move` took {each} µs over each launch's bound: "
            f"median {m['median']:+.0f} µs ({_spread(m)}; the service {launches['service']['median']:+.0f}, the client library "
            f"{launches['client']['median']:+.0f}). Where the scheduler puts a launch's processes stays for the "
            "whole launch, so one launch's figure is one draw of these." + _protocol_floor_note(launches)
            + _one_core_note(lat, launches))


def _one_core_note(lat: dict[str, Any], launches: dict[str, Any]) -> str:
    """The same launches again with every process pinned to one core (benchmarks/round_trip_launches.py)."""
    pinned = lat.get("launches_one_core")
    if not pinned:
        return ""
    m = pinned["over_bound"]
    bound = statistics.median(launch["engine_echo"] for launch in pinned["launches"])
    free_bound = statistics.median(launch["engine_echo"] for launch in launches["launches"])
    floor = pinned.get("floor_over_bound")
    floor_text = "" if floor is None else f", the protocol's floor {floor['median']:+.0f} µs"
    return (f" Then {len(pinned['launches'])} more launches ran with every process pinned to core {pinned['cpu']} "
            f"(a request then wakes its server on the core it is already on): `Client.move` took "
            f"{m['median']:+.0f} µs over each launch's bound at the median ({_spread(m)}; the service "
            f"{pinned['service']['median']:+.0f}, the client library {pinned['client']['median']:+.0f}{floor_text}), "
            f"the bound itself {bound:.0f} µs against {free_bound:.0f} µs unpinned (medians over the launches). "
            "The target's verdict is read from the unpinned launches; this one is the steadier reading of what the "
            "service and the client library add.")


def _protocol_floor_note(launches: dict[str, Any]) -> str:
    """The protocol's own floor, asked in a second phase of the same launches (benchmarks/round_trip_launches.py)."""
    if "floor_over_bound" not in launches:  # launches recorded before the floor was measured
        return ""
    floor, over = launches["floor_over_bound"], launches["over_bound"]["median"]
    each = ", ".join(f"{e['floor_over_bound']:+.0f}" for e in launches["over_bound_each"])
    return (f" In a second phase of each launch, the service stopped, the same bound and one move as the protocol "
            f"alone makes any service and client do it (benchmarks/service_floor.py: the service's own reader, "
            f"`World.move` and State packer behind a bare queryable on a literal key, asked by the least client, the "
            f"move map packed and the State read by the client library's reader) were asked the same way: that "
            f"floor took {each} µs over each launch's bound, median {floor['median']:+.0f} µs (its server "
            f"{launches['floor_service']['median']:+.0f}, its client {launches['floor_client']['median']:+.0f}). "
            f"The rest of the {over:.0f} µs, {over - floor['median']:.0f} µs, is what the service's own work (its "
            "key dispatch, checks, stats, queue and engine lock, records; a single move's publication check "
            "comes after its reply) and the client "
            "library's (the Move object, the landblock it routes by, its redirects) add to the protocol's.")
