"""The needle thread's periodic state over its stitches: when the stitches a run has stepped
repeat (:func:`periodic`), which of a period's stitches is its hardest pulled (:func:`hardest`),
how many stitches a run steps at most (:func:`at_most`) and the thread its path holds at a
stitch's end (:func:`in_path`). One set of rules for the plain twin (:func:`.tension.step`)
and the array step (:func:`.tension_many.step_many`)."""

from __future__ import annotations

import numpy as np

__all__ = ["PERIODIC", "at_most", "hardest", "in_path", "periodic"]

PERIODIC = 1e-8  # m: the periodic state: two stitches' draws through the discs this close


def in_path(prev: list[float], s: list[float]) -> float:
    """m: the thread the path holds, its stretches' paths ``prev`` less their stretches ``s``
    (summed in one order, so that the twin and the array step agree to the bit)."""
    return sum(p - q for p, q in zip(prev, s, strict=True))


def at_most(most_cycles: int, cycles: int | None) -> int:
    """Stitches a run steps at most: ``cycles`` if given, else ``most_cycles`` to find its
    periodic state and, a state found, up to its period less one more to its hardest pulled
    stitch (:func:`periodic` finds periods up to half the stitches run)."""
    return cycles if cycles is not None else most_cycles + most_cycles // 2 - 1


def hardest(ran: int, tops: list[float]) -> int:
    """The stitch, from ``ran`` on, that repeats the hardest pulled of a period's stitches: their
    peaks ``tops`` (N, the last ``len(tops)`` stitches to ``ran``, oldest first)."""
    return ran + (int(np.argmax(tops)) + 1) % len(tops)


def periodic(feds: list[float], helds: list[float]) -> int:
    """The least ``p`` for which each of the last ``p`` stitches drew the same thread through
    the discs and ended with the same thread in the path (``feds`` and ``helds``, m; within
    :data:`PERIODIC`) as the stitch ``p`` before it (1: the last two alike), else 0: any period
    the stitches show twice over (a check spring striking its stop may repeat its motion only
    every dozen stitches or so). The draws alone are not the state: a thread that starts with
    slack in its path draws nothing for a stitch or two while the stitches use the slack up."""
    for p in range(1, len(feds) // 2 + 1):
        if all(
            abs(feds[-i] - feds[-i - p]) <= PERIODIC and abs(helds[-i] - helds[-i - p]) <= PERIODIC
            for i in range(1, p + 1)
        ):
            return p
    return 0
