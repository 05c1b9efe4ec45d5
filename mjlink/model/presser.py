"""A sewing head's ``[presser]`` and ``[fabric]`` tables: the sprung presser foot and the fabric
the feed dog moves under it (:mod:`mjlink.sim.feed`).

Every key is optional; a missing one takes its default of :data:`PRESSER_DEFAULTS` or
:data:`FABRIC_DEFAULTS`, each with its source or marked ``[choice]`` where no public figure was
found (docs/head.md, The fabric under the presser foot). The file's units are N, N/mm, g and mm;
here SI::

    [presser]
    preload = 40.0     # N: the spring's push with the sole at the fabric's free top on the plate
    rate = 2.0         # N/mm
    mass = 50.0        # g moving with the foot (bar, foot and a third of the spring)
    damping = 0.05     # a fraction of critical
    lift = 7.0         # mm: the foot's sole at its highest above the throat plate (the bar's stop)

    [fabric]
    mass = 2.0             # g: the piece the dog carries
    stiffness = 130.0      # N/mm: across its thickness, under the foot
    damping = 0.3          # of critical, the foot on the fabric
    friction_dog = 1.0     # against the dog's teeth
    friction_foot = 0.2    # against the foot's sole
    friction_plate = 0.2   # against the throat plate

The fabric's thickness is ``[timing] fabric``. Both tables need a ``[timing]`` table that names
the feed dog.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

from ..units import MM, G
from .limits import Bound
from .reader import Reader

__all__ = [
    "FABRIC_BOUNDS",
    "FABRIC_DEFAULTS",
    "FABRIC_FIELDS",
    "FABRIC_SCALES",
    "FABRIC_SOURCES",
    "PRESSER_BOUNDS",
    "PRESSER_DEFAULTS",
    "PRESSER_SCALES",
    "PRESSER_SOURCES",
    "Fabric",
    "Presser",
    "read_fabric",
    "read_presser",
]


@dataclass(frozen=True, kw_only=True)
class Presser:
    """The presser bar and foot, SI: ``preload`` N the spring's push with the sole at the
    fabric's free top on the plate (the foot's weight adds to it; the fabric, pressed, lets the
    foot sink a little below), ``rate`` N/m, ``mass`` kg moving with the foot,
    ``damping`` a ratio of critical, ``lift`` m the foot's sole at its highest above the throat
    plate (where the bar meets its stop)."""

    preload: float
    rate: float
    mass: float
    damping: float
    lift: float

    @property
    def frequency(self) -> float:
        """Hz: the foot's free vibration on its spring, damped (closed form)."""
        wn = math.sqrt(self.rate / self.mass)
        return wn * math.sqrt(max(0.0, 1.0 - self.damping**2)) / (2.0 * math.pi)

    @property
    def static(self) -> float:
        """N: what the foot presses on the fabric at rest (the spring's preload and the foot's
        weight), the dynamic load factor's denominator."""
        return self.preload + self.mass * GRAVITY


@dataclass(frozen=True, kw_only=True)
class Fabric:
    """The fabric, SI: ``mass`` kg of the piece the dog carries, its ``stiffness`` N/m across its
    thickness under the foot and ``damping`` (a ratio of critical for the foot's mass on that
    stiffness), its friction coefficients against the dog's teeth (``dog``), the foot and the
    throat plate."""

    mass: float
    stiffness: float
    damping: float
    dog: float
    foot: float
    plate: float


GRAVITY = 9.81  # m/s^2

# Key -> (default in the file's unit, the factor to SI, bound, source).
_PRESSER: dict[str, tuple[float, float, Bound, str]] = {
    "preload": (
        40.0,
        1.0,
        Bound(0.0, 500.0, "N", "a presser spring's push, tens of newtons on industrial heads", lo_open=True),
        "[choice] about the 4 kgf of a DDL-class head; no maker's figure was found",
    ),
    "rate": (
        2.0,
        1.0 / MM,
        Bound(0.0, 100.0, "N/mm", "a presser spring's rate", lo_open=True),
        "[choice] the push grows by a tenth over 2 mm of the foot's rise",
    ),
    "mass": (
        50.0,
        G,
        Bound(0.0, 5000.0, "g", "the presser bar, the foot and a third of the spring", lo_open=True),
        "[choice] a steel bar of 8 mm and 100 mm with its foot",
    ),
    "damping": (
        0.05,
        1.0,
        Bound(0.0, 1.0, "", "a fraction of critical damping, below critical", hi_open=True),
        "[choice] a lightly damped bar in its bushings",
    ),
    "lift": (
        7.0,
        MM,
        Bound(
            0.0,
            20.0,
            "mm",
            "the foot's sole at its highest above the plate; heads lift it some 20 mm at most",
            lo_open=True,
        ),
        "Brother T-8420C/8450C/8720C/8750C instructions, 10-5: the foot raised by its lever stands about "
        "7 mm above the needle plate; [choice] that its bar meets the stop there when the fabric pushes it up",
    ),
}
_FABRIC: dict[str, tuple[float, float, Bound, str]] = {
    "mass": (
        2.0,
        G,
        Bound(0.0, 10_000.0, "g", "the piece of fabric the dog carries", lo_open=True),
        "[choice] a piece of shirting some 10 x 20 cm",
    ),
    "stiffness": (
        130.0,
        1.0 / MM,
        Bound(0.0, 1e5, "N/mm", "a fabric's compressive stiffness under a presser foot", lo_open=True),
        "[choice] 1.5 mm of woven fabric pressed 0.3 mm thinner by the foot's 40 N; no published "
        "figure for a fabric under a presser foot was found",
    ),
    "damping": (
        0.3,
        1.0,
        Bound(0.0, 2.0, "", "a fraction of critical damping"),
        "[choice] a fabric damps the foot's bounce on it well below critical",
    ),
    "friction_dog": (
        1.0,
        1.0,
        Bound(0.0, 5.0, "", "the dog's teeth grip: a coefficient of friction, teeth included", lo_open=True),
        "[choice] the teeth's grip as a coefficient of friction",
    ),
    "friction_foot": (
        0.2,
        1.0,
        Bound(0.0, 2.0, "", "a coefficient of friction of fabric on polished steel"),
        "[choice] fabric on polished steel",
    ),
    "friction_plate": (
        0.2,
        1.0,
        Bound(0.0, 2.0, "", "a coefficient of friction of fabric on polished steel"),
        "[choice] fabric on polished steel",
    ),
}

PRESSER_BOUNDS: dict[str, Bound] = {k: v[2] for k, v in _PRESSER.items()}
"""Each ``[presser]`` key's range in the file's unit, with its reason."""
PRESSER_SOURCES: dict[str, str] = {k: v[3] for k, v in _PRESSER.items()}
"""Each ``[presser]`` default's source (or ``[choice]`` and why)."""
FABRIC_BOUNDS: dict[str, Bound] = {k: v[2] for k, v in _FABRIC.items()}
"""Each ``[fabric]`` key's range in the file's unit, with its reason."""
FABRIC_SOURCES: dict[str, str] = {k: v[3] for k, v in _FABRIC.items()}
"""Each ``[fabric]`` default's source (or ``[choice]`` and why)."""
PRESSER_SCALES: dict[str, float] = {k: v[1] for k, v in _PRESSER.items()}
"""Each ``[presser]`` key's factor from the file's unit to SI."""
FABRIC_SCALES: dict[str, float] = {k: v[1] for k, v in _FABRIC.items()}
"""Each ``[fabric]`` key's factor from the file's unit to SI."""
FABRIC_FIELDS = {
    "mass": "mass",
    "stiffness": "stiffness",
    "damping": "damping",
    "friction_dog": "dog",
    "friction_foot": "foot",
    "friction_plate": "plate",
}
"""Each ``[fabric]`` key's field of :class:`Fabric` (a ``[presser]`` key is its field's name)."""
PRESSER_DEFAULTS = Presser(**{k: v[0] * v[1] for k, v in _PRESSER.items()})
"""The ``[presser]`` defaults (:data:`PRESSER_SOURCES`), SI."""
FABRIC_DEFAULTS = Fabric(**{FABRIC_FIELDS[k]: v[0] * v[1] for k, v in _FABRIC.items()})
"""The ``[fabric]`` defaults (:data:`FABRIC_SOURCES`), SI."""


def _needs_feed_dog(r: Reader, where: str, has_feed_dog: bool) -> None:
    if not has_feed_dog:
        raise r.fail(where, "needs a [timing] table that names the feed_dog (the fabric is fed by it)")


def read_presser(r: Reader, raw: Any, has_feed_dog: bool, fabric: float) -> Presser:
    """The ``[presser]`` table (see the module's docstring); ``fabric`` m the ``[timing]``
    fabric's thickness, which the foot's ``lift`` must clear."""
    _needs_feed_dog(r, "[presser]", has_feed_dog)
    out = Presser(**r.defaulted(raw, "[presser]", _PRESSER))
    if out.lift <= fabric:
        raise r.fail(
            "[presser] lift",
            f"the foot's highest point ({out.lift / MM:g} mm above the plate) must clear the fabric "
            f"([timing] fabric = {fabric / MM:g} mm)",
        )
    return out


def read_fabric(r: Reader, raw: Any, has_feed_dog: bool) -> Fabric:
    """The ``[fabric]`` table (see the module's docstring)."""
    _needs_feed_dog(r, "[fabric]", has_feed_dog)
    v = r.defaulted(raw, "[fabric]", _FABRIC)
    return Fabric(**{FABRIC_FIELDS[k]: x for k, x in v.items()})
