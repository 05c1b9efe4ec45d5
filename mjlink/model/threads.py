"""Sewing threads by their count: one maker's published chart, so that a ``[tension]`` table can
name its thread (``thread = "40s/2"``) instead of its breaking load and elongation.

The chart is MH Thread's *Spun Polyester Sewing Thread Size Chart* (All About Polyester
Threads, 2024, mhthread.com): for each count its linear density (tex), average breaking
strength (cN) and elongation at break (a range, %). One maker, one kind of thread (spun
polyester, 100 % polyester staple fibres plied); a count names the singles' English cotton
count (Ne) and the plies. The thread's stiffness the tension model takes is the secant to break,
``EA = breaking load / elongation at break``, with the elongation the middle of the chart's
range. Two counts may share a tex (40s/2 and 60s/3 are both tex 30, of different strengths):
the count, not the tex, names a row.
"""

from __future__ import annotations

import difflib
import re
from dataclasses import dataclass

__all__ = ["CHART", "SOURCE", "Thread", "by_count", "count_of"]

SOURCE = "MH Thread, All About Polyester Threads (2024): the spun polyester sewing thread size chart"


@dataclass(frozen=True, kw_only=True)
class Thread:
    """One row of the chart: ``count`` as printed (``"40s/2"``), ``tex`` g/km, ``strength`` N (the
    chart's average breaking strength) and the elongation at break from ``elongation_low`` to
    ``elongation_high`` (fractions)."""

    count: str
    tex: float
    strength: float
    elongation_low: float
    elongation_high: float

    @property
    def elongation(self) -> float:
        """The elongation at break the model takes: the middle of the chart's range."""
        return 0.5 * (self.elongation_low + self.elongation_high)

    def describe(self) -> str:
        """The row as the chart gives it, e.g. ``spun polyester 40s/2, tex 30: 1,050 cN, 10-15 %``."""
        return (
            f"spun polyester {self.count}, tex {self.tex:g}: {self.strength * 100:,.0f} cN, "
            f"{self.elongation_low * 100:g}-{self.elongation_high * 100:g} %"
        )


def _row(count: str, tex: float, cn: float, low: float, high: float) -> Thread:
    return Thread(count=count, tex=tex, strength=cn / 100.0, elongation_low=low / 100.0, elongation_high=high / 100.0)


CHART: tuple[Thread, ...] = (
    _row("12s/3", 150, 5010, 8, 13),
    _row("12s/4", 200, 7080, 8, 13),
    _row("20s/2", 60, 2124, 10, 16),
    _row("20s/3", 90, 3540, 11, 16),
    _row("20s/6", 180, 5832, 8, 13),
    _row("20s/9", 270, 9045, 7, 12),
    _row("30s/2", 40, 1379, 10, 15),
    _row("30s/3", 60, 2245, 11, 16),
    _row("40s/2", 30, 1050, 10, 15),
    _row("40s/3", 45, 1642, 10, 15),
    _row("50s/2", 24, 850, 9, 14),
    _row("50s/3", 36, 1309, 10, 15),
    _row("60s/2", 20, 666, 9, 14),
    _row("60s/3", 30, 1030, 10, 15),
)
"""The chart's rows as it prints them (:data:`SOURCE`)."""

_BY_KEY = {t.count: t for t in CHART}
_SPELLED = re.compile(r"(\d+)s?/(\d+)")  # 40s/2 or 40/2, spaces and case aside


def by_count(name: str) -> Thread:
    """The chart's row for a count, written ``"40s/2"`` or ``"40/2"`` (spaces and case aside).

    Raises:
      KeyError: no such count, its message naming the nearest and the chart's counts.
    """
    spelled = _SPELLED.fullmatch("".join(name.split()).lower())
    key = f"{spelled[1]}s/{spelled[2]}" if spelled else ""
    if key in _BY_KEY:
        return _BY_KEY[key]
    counts = [t.count for t in CHART]
    near = difflib.get_close_matches(name.strip(), counts, n=1)
    hint = f"did you mean '{near[0]}'? " if near else ""
    raise KeyError(f"{hint}the chart's counts: {', '.join(counts)}")


def count_of(breaking_load: float, elongation_at_break: float) -> Thread | None:
    """The chart's row whose strength and middle elongation these are (to rounding), else None:
    how a ``[tension]`` table's thread is named in reports, whether the file gave the count or
    the numbers."""
    for t in CHART:
        if abs(t.strength - breaking_load) <= 1e-9 * t.strength and abs(t.elongation - elongation_at_break) <= 1e-9:
            return t
    return None
