"""A lockstitch head's ``[tension]`` table: the needle thread and the parts that tension it.

Every key is optional; a missing one takes the published default of :data:`DEFAULTS` (each
with its source, or marked as a choice where no public figure was found; docs/head.md, The
thread under tension). The file's units are N for forces, N/mm for the spring's rate, g for
its mass and deg for the eye's wrap; here SI::

    [tension]
    needle_tension = 1.6      # N: the thread drawn slowly out of the needle's eye
    breaking_load = 10.5      # N
    elongation_at_break = 0.125
    friction = 0.15           # thread on polished steel, at every contact
    eye_wrap = 180.0          # deg: the turn through the needle's eye
    hook_wrap = 180.0         # deg: the loop's turn over the hook's blade, at most
    spring_force = 0.3        # N: the check spring's force at rest (at its start)
    spring_rate = 0.03        # N/mm
    spring_mass = 0.1         # g, at its hook
    spring_damping = 0.1      # a fraction of critical
    bobbin_tension = '25 gf'  # the bobbin thread drawn out of its case
    fabric_give = 0.0         # mm/N: the last stitch's give into the fabric under the pull

Instead of ``breaking_load`` and ``elongation_at_break`` the table may name its thread by its count
in one maker's chart, ``thread = "50s/2"`` (:mod:`.threads`): the row's breaking strength and the
middle of its elongation range. The check spring's point and travel are the ``[balance]`` table's
(``check_spring``, ``check_spring_travel``).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

from ..units import DEG, MM, G
from .limits import Bound
from .reader import Reader, shown
from .threads import Thread, by_count, count_of

__all__ = ["BOUNDS", "DEFAULTS", "SCALES", "SOURCES", "THREAD_KEYS", "ThreadTension", "read_tension"]

THREAD_KEYS = ("breaking_load", "elongation_at_break")
"""The numbers a ``thread`` count names (:mod:`.threads`)."""

GF = 9.80665e-3  # N per gram-force: makers quote tensions in g


@dataclass(frozen=True, kw_only=True)
class ThreadTension:
    """The ``[tension]`` table in SI units (see the module's docstring).

    ``needle_tension`` N, the tension a mechanic reads drawing the thread slowly out of the
    needle's eye with the needle bar at its top (it sets the discs' hold); ``breaking_load`` N
    and ``elongation_at_break`` (a fraction) the thread's, which give its stiffness
    ``EA = breaking_load / elongation_at_break`` (the secant modulus to break); ``friction`` the
    coefficient of thread on steel; ``eye_wrap`` rad; ``hook_wrap`` rad, the most the loop turns over
    the hook's blade while the hook carries it (it turns as its legs meet there, at most this;
    0: the thread slides round the hook freely, over the blade and the bobbin case); the check spring's ``spring_force`` N at
    rest, ``spring_rate`` N/m, ``spring_mass`` kg and ``spring_damping`` (of critical); the
    bobbin thread's ``bobbin_tension`` N, drawn out of its case (the stitch is drawn up only
    where the needle thread pulls it harder); ``fabric_give`` m/N, how far the last stitch's
    end gives into the fabric per newton of the thread below the eye (a compressible fabric:
    a spring in series with the thread anchored there; 0, a fabric that does not give)."""

    needle_tension: float
    breaking_load: float
    elongation_at_break: float
    friction: float
    eye_wrap: float
    hook_wrap: float
    spring_force: float
    spring_rate: float
    spring_mass: float
    spring_damping: float
    bobbin_tension: float
    fabric_give: float

    @property
    def stiffness(self) -> float:
        """EA, N: the thread's tension per unit strain."""
        return self.breaking_load / self.elongation_at_break

    @property
    def thread(self) -> Thread | None:
        """The row of the chart of :mod:`.threads` whose breaking strength and middle elongation
        these are, whether the file named the count or gave the numbers; None for another thread."""
        return count_of(self.breaking_load, self.elongation_at_break)


# Key -> (default in the file's unit, the factor to SI, bound, source).
_TABLE: dict[str, tuple[float, float, Bound, str]] = {
    "needle_tension": (
        1.6,
        1.0,
        Bound(0.0, 50.0, "N", "a needle thread's static tension, some 0.5 to 3 N on industrial heads", lo_open=True),
        "[choice] 6.5 x the bobbin thread's 25 g (Duerkopp Adler 650-10 instructions, p. 29), "
        "needle to bobbin about 6:1 to 7:1 (Analysis of the Structure of Lockstitched Seam according "
        "to Sewing Thread Tension, 2001)",
    ),
    "breaking_load": (
        10.5,
        1.0,
        Bound(0.1, 1000.0, "N", "a sewing thread breaks at some 2 to 100 N; none below 0.1 N (10 gf)"),
        "spun polyester 40s/2, tex 30: 1,050 cN (MH Thread, All About Polyester Threads, 2024)",
    ),
    "elongation_at_break": (
        0.125,
        1.0,
        Bound(
            0.005,
            1.0,
            "",
            "a fraction: sewing threads break at some 5 to 35 % elongation, glass and carbon at 1.5 to 4 %",
        ),
        "spun polyester 40s/2, tex 30: 10 to 15 % (MH Thread, All About Polyester Threads, 2024)",
    ),
    "friction": (
        0.15,
        1.0,
        Bound(0.0, 2.0, "", "a coefficient of friction of thread on metal, some 0.1 to 0.5"),
        "[choice] no published value was found for sewing thread on polished steel; at 0.2 the "
        "discs' hold that gives the default needle tension through the shipped head's path lets "
        "the thread pull its check spring with less than the spring's 0.3 N, and it never moves",
    ),
    "eye_wrap": (
        180.0,
        DEG,
        Bound(0.0, 360.0, "deg", "the turn through the needle's eye, up to a turn"),
        "[choice] the thread turns back through the eye, down the long groove and up the short one",
    ),
    "hook_wrap": (
        180.0,
        DEG,
        Bound(0.0, 180.0, "deg", "the loop's turn over the hook's blade, at most a hairpin's"),
        "[choice] the loop turns over the blade as its two legs meet there (a hairpin where they run "
        "in the hook's plane), at most this; 0 lets the thread slide round the hook freely (blade and bobbin case)",
    ),
    "spring_force": (
        0.3,
        1.0,
        Bound(0.0, 10.0, "N", "a check spring's force, some 0.05 to 0.5 N in makers' manuals"),
        "[choice] the force at the hook at rest; Brother reads 0.25 to 0.35 N (the -3 specification; "
        "S-1110A, SL-710A and S-7300A manuals) in the thread pulled until the spring reaches its guide, "
        "which the shipped spring meets (0.32 N, docs/head.md)",
    ),
    "spring_rate": (
        0.03,
        1.0 / MM,
        Bound(0.0, 10.0, "N/mm", "a check spring's rate: its force grows by a fraction of itself over its travel"),
        "[choice] the force at rest grows by 0.21 N over the 7 mm travel",
    ),
    "spring_mass": (
        0.1,
        G,
        Bound(0.0, 100.0, "g", "a check spring's moving mass at its hook, a fraction of a gram", lo_open=True),
        "[choice] a wire spring's arm and hook",
    ),
    "spring_damping": (
        0.1,
        1.0,
        Bound(0.0, 10.0, "", "a fraction of critical damping"),
        "[choice] a lightly damped steel spring",
    ),
    "bobbin_tension": (
        25.0 * GF,
        1.0,
        Bound(0.0, 10.0, "N", "a bobbin thread's tension, some 0.1 to 1 N", lo_open=True),
        "Duerkopp Adler 650-10 instructions, p. 29: the bobbin thread's tension about 25 g",
    ),
    "fabric_give": (
        0.0,
        MM,
        Bound(
            0.0,
            10.0,
            "mm/N",
            "how far the last stitch gives into the fabric per newton of pull: nothing in a hard "
            "fabric, tenths of a millimetre in a soft one, millimetres in wadding",
        ),
        "[choice] a fabric that does not give under the stitch; no published figure for a "
        "fabric's give under a stitch's pull was found",
    ),
}

BOUNDS: dict[str, Bound] = {k: v[2] for k, v in _TABLE.items()}
"""Each key's range in the file's unit, with its reason."""
SCALES: dict[str, float] = {k: v[1] for k, v in _TABLE.items()}
"""Each key's factor from the file's unit to SI."""
SOURCES: dict[str, str] = {k: v[3] for k, v in _TABLE.items()}
"""Each default's source (or ``[choice]`` and why)."""
DEFAULTS = ThreadTension(**{k: v[0] * v[1] for k, v in _TABLE.items()})
"""The published defaults (:data:`SOURCES`), SI."""


def read_tension(r: Reader, raw: Any, has_balance: bool) -> ThreadTension:
    """The ``[tension]`` table: needs a ``[balance]`` table (the thread's path to the eye, the
    check spring's point and travel)."""
    t = r.table(raw, "[tension]")
    if not has_balance:
        raise r.fail("[tension]", "needs a [balance] table (the check spring's point and travel)")
    numbers = {k: v for k, v in t.items() if k != "thread"}
    r.keys(t, "[tension]", [], [*_TABLE, "thread"])
    values = r.defaulted(numbers, "[tension]", _TABLE)
    if "thread" in t:
        given = [k for k in THREAD_KEYS if k in t]
        if given:
            raise r.fail(
                "[tension]",
                f"'thread' names the thread's breaking load and elongation at break (its row of the chart): "
                f"give it or {' and '.join(given)}, not both",
            )
        name = r.string(t, "thread", "[tension]", max_length=16)
        try:
            row = by_count(name)
        except KeyError as e:
            raise r.fail(
                "[tension] thread", f"no spun polyester count {shown(name)} in MH Thread's chart: {e.args[0]}"
            ) from None
        values["breaking_load"], values["elongation_at_break"] = row.strength, row.elongation
    out = ThreadTension(**values)
    if not math.isfinite(out.stiffness):
        raise r.fail("[tension]", "the thread's stiffness breaking_load / elongation_at_break is not finite")
    return out


def in_grams(force: float) -> float:
    """A force in N as the gram-force makers quote."""
    return force / GF
