"""The client's physics-step ladder: how elapsed time becomes physics steps.

PhysicsObj.update_object does not integrate a frame's elapsed time in one
piece. Of the time since the object's last update it

- runs nothing while that is shorter than the minimum quantum (1/30 s; the
  time is not lost, it waits for the next frame),
- drops all of it when it is longer than the huge quantum (2 s; the
  object's clock is set to now and nothing moves),
- runs it in one step when it is at most the maximum quantum,
- otherwise runs steps of the maximum quantum while more than that is
  left, then the remainder as one more step if it is longer than the
  minimum quantum, else keeps the remainder for the next frame.

`split_elapsed` is that decision as a pure function, so that the World can
apply it to each mover's own clock.
"""

from __future__ import annotations

from .._compat import mypyc_attr
from ..constants import HUGE_QUANTUM, MIN_QUANTUM

__all__ = ["QuantumSplit", "split_elapsed"]


@mypyc_attr(acyclic=True)
class QuantumSplit:
    """What update_object does with some elapsed time (a value: not changed once made).

    A slots class with its __init__ written out, not a dataclass: one is made per physics step, and a
    dataclass's generated __init__ stays interpreted in the compiled engine."""

    __slots__ = ("quanta", "held", "dropped")

    def __init__(self, quanta: tuple[float, ...], held: float, dropped: bool = False) -> None:
        #: the physics steps to run, in order (seconds)
        self.quanta = quanta
        #: time kept for the next update (seconds)
        self.held = held
        #: True when the elapsed time was beyond the huge quantum and dropped
        self.dropped = dropped


def split_elapsed(elapsed: float, max_quantum: float) -> QuantumSplit:
    """Split `elapsed` seconds (held time plus this frame's) into physics steps
    as the client's PhysicsObj.update_object does, with steps of at most
    `max_quantum` seconds."""
    if elapsed > HUGE_QUANTUM:
        return QuantumSplit((), 0.0, dropped=True)
    if elapsed < MIN_QUANTUM:
        return QuantumSplit((), elapsed)
    if elapsed <= max_quantum:
        return QuantumSplit((elapsed,), 0.0)
    quanta: list[float] = []
    left = elapsed
    while left > max_quantum:
        quanta.append(max_quantum)
        left -= max_quantum
    if left > MIN_QUANTUM:
        quanta.append(left)
        left = 0.0
    return QuantumSplit(tuple(quanta), left)
