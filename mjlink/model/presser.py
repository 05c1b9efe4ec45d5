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
    area = 160.0           # cm^2: the piece the dog carries
    mass = 125.0           # g/m^2
    stiffness = 130.0      # N/mm: across its thickness, under the foot
    damping = 0.3          # of critical, the foot on the fabric
    friction_dog = 1.0     # against the dog's teeth
    friction_foot = 0.2    # against the foot's sole
    friction_plate = 0.2   # against the throat plate
    friction_ply = 0.5     # one ply on the next

The fabric's thickness is ``[timing] fabric``: one ply. Two or more plies are a list, the
bottom one (on the dog) first, each with its own thickness and, optionally, its own mass per
area, stiffness and damping (the table's defaults otherwise); the table then gives neither
``mass``, ``stiffness`` nor ``damping``, and ``[timing] fabric`` is the plies' thickness
together (left out, or equal)::

    [[fabric.ply]]
    thickness = 0.8        # mm
    stiffness = 250.0      # N/mm
    [[fabric.ply]]
    thickness = 0.7
    mass = 110.0

Both tables need a ``[timing]`` table that names the feed dog.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace
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
    "MAX_PLIES",
    "PER_PLY",
    "PLY_THICKNESS",
    "PRESSER_BOUNDS",
    "PRESSER_DEFAULTS",
    "PRESSER_SCALES",
    "PRESSER_SOURCES",
    "Fabric",
    "Ply",
    "Presser",
    "feed_step",
    "read_fabric",
    "read_presser",
    "too_fast",
    "unfit",
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
        weight; the spring's dynamic load factor is over its preload alone)."""
        return self.preload + self.mass * GRAVITY


@dataclass(frozen=True, kw_only=True)
class Ply:
    """One ply of the fabric, SI: its ``thickness`` m, ``mass`` kg/m^2 (per area), its
    ``stiffness`` N/m across its thickness under the foot and ``damping`` (a ratio of critical
    for the foot's mass on that stiffness)."""

    thickness: float
    mass: float
    stiffness: float
    damping: float


@dataclass(frozen=True, kw_only=True)
class Fabric:
    """The fabric, SI: the ``area`` m^2 of the piece the dog carries; one ply's ``mass`` kg/m^2,
    ``stiffness`` N/m across its thickness under the foot and ``damping`` (a ratio of critical
    for the foot's mass on that stiffness), or ``plies`` (the bottom one first) that replace
    them; friction coefficients against the dog's teeth (``dog``, the bottom ply's), the foot
    (the top ply's), the throat plate and of one ply on the next (``ply``)."""

    area: float
    mass: float
    stiffness: float
    damping: float
    dog: float
    foot: float
    plate: float
    ply: float
    plies: tuple[Ply, ...] = ()

    def layers(self, thickness: float) -> tuple[Ply, ...]:
        """The plies, the bottom one first: the table's own, or one ply of ``thickness`` m (the
        ``[timing]`` fabric's) with the table's mass, stiffness and damping."""
        if self.plies:
            return self.plies
        return (Ply(thickness=thickness, mass=self.mass, stiffness=self.stiffness, damping=self.damping),)

    def piece(self, thickness: float) -> float:
        """kg: the piece the dog carries, every ply of it."""
        return self.area * sum(p.mass for p in self.layers(thickness))

    def stiffness_of(self, thickness: float) -> float:
        """N/m: the plies' stiffness under the foot, one on the next (in series)."""
        return 1.0 / sum(1.0 / p.stiffness for p in self.layers(thickness))

    def damper_of(self, thickness: float, foot: float) -> float:
        """N s/m: the plies' damping under a foot of mass ``foot`` kg, each ply's its ratio of
        critical for that mass on its stiffness, one on the next as their springs (exact when
        the plies' dampers and springs keep one ratio; 0 where a ply has none)."""
        dampers = [2.0 * p.damping * math.sqrt(p.stiffness * foot) for p in self.layers(thickness)]
        return 0.0 if min(dampers) <= 0.0 else 1.0 / sum(1.0 / c for c in dampers)


GRAVITY = 9.81  # m/s^2
# The feed (mjlink.sim.feed) steps the fabric's spring under the foot explicitly (MuJoCo's soft
# contact): its step turns the spring's vibration by at most SPRING_STEP rad and lets the
# damper take at most DAMPER_STEP of the motion per step. A fabric that asks for steps below
# MIN_FEED_STEP s (a piece of milligrams on a stiff fabric) is refused rather than stepped for
# minutes.
SPRING_STEP, DAMPER_STEP = 0.2, 0.5
MIN_FEED_STEP = 1e-6

# Key -> (default in the file's unit, the factor to SI, bound, source).
_PRESSER: dict[str, tuple[float, float, Bound, str]] = {
    "preload": (
        40.0,
        1.0,
        Bound(
            0.1,
            500.0,
            "N",
            "a presser spring's push, tens of newtons on industrial heads; below a tenth of a newton the foot "
            "rests on its weight and the spring's load factor, against its preload, means nothing",
        ),
        "[choice] about the 4 kgf of a DDL-class head; no maker's figure was found",
    ),
    "rate": (
        2.0,
        1.0 / MM,
        Bound(
            0.001,
            100.0,
            "N/mm",
            "a presser spring's rate; below 0.001 N/mm a constant push (the spring at rest "
            "would stand metres from its free length)",
        ),
        "[choice] the push grows by a tenth over 2 mm of the foot's rise",
    ),
    "mass": (
        50.0,
        G,
        Bound(1.0, 5000.0, "g", "the presser bar, the foot and a third of the spring: tens of grams"),
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
    "area": (
        160.0,
        1e-4,
        Bound(1.0, 1e4, "cm^2", "the piece of fabric the dog carries, no smaller than the foot"),
        "[choice] a piece some 10 x 16 cm between the operator's hands and the foot",
    ),
    "mass": (
        125.0,
        G,
        Bound(1.0, 5000.0, "g/m^2", "a ply's mass per area: sheer fabrics weigh tens, canvas hundreds"),
        "[choice] a light woven fabric; the ten garment fabrics Wang, Ramamoorthi and O'Brien measured "
        "weigh 113 to 324 g/m^2 (Data-Driven Elastic Models for Cloth, ACM TOG 30(4), 2011; their "
        "material files as the ARCSim simulator ships them)",
    ),
    "stiffness": (
        130.0,
        1.0 / MM,
        Bound(0.001, 1e5, "N/mm", "a fabric's compressive stiffness under a presser foot"),
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
    "friction_ply": (
        0.5,
        1.0,
        Bound(0.0, 2.0, "", "a coefficient of friction of fabric on fabric"),
        "[choice] fabric on fabric grips more than on polished steel",
    ),
}
MAX_PLIES = 8  # a sewing head's foot clears some 20 mm of fabric: a few plies of a garment
PLY_THICKNESS = Bound(
    0.01,
    20.0,
    "mm",
    "a ply under the raised presser foot, no thinner than a thread, which heads lift some 20 mm at most",
)
"""A ply's ``thickness`` range, mm."""
PER_PLY = ("mass", "stiffness", "damping")
"""The ``[fabric]`` keys a ``[[fabric.ply]]`` gives for itself."""

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
    "area": "area",
    "mass": "mass",
    "stiffness": "stiffness",
    "damping": "damping",
    "friction_dog": "dog",
    "friction_foot": "foot",
    "friction_plate": "plate",
    "friction_ply": "ply",
}
"""Each ``[fabric]`` key's field of :class:`Fabric` (a ``[presser]`` key is its field's name)."""


def _fields(numbers: dict[str, float]) -> dict[str, Any]:
    """A :class:`Fabric`'s numbers as its keyword arguments (its plies apart)."""
    return dict(numbers)


PRESSER_DEFAULTS = Presser(**{k: v[0] * v[1] for k, v in _PRESSER.items()})
"""The ``[presser]`` defaults (:data:`PRESSER_SOURCES`), SI."""
FABRIC_DEFAULTS = Fabric(**_fields({FABRIC_FIELDS[k]: v[0] * v[1] for k, v in _FABRIC.items()}))
"""The ``[fabric]`` defaults (:data:`FABRIC_SOURCES`), SI."""


def feed_step(presser: Presser, fabric: Fabric, thickness: float) -> float:
    """s: the longest step that steps the fabric's spring and damper under the foot stably (the
    top ply and the foot on them, :data:`SPRING_STEP`, :data:`DAMPER_STEP`)."""
    top = fabric.area * fabric.layers(thickness)[-1].mass
    inv = 1.0 / top + 1.0 / presser.mass
    k, c = fabric.stiffness_of(thickness), fabric.damper_of(thickness, presser.mass)
    return min(SPRING_STEP / math.sqrt(k * inv), DAMPER_STEP / (c * inv) if c > 0.0 else math.inf)


def too_fast(presser: Presser, fabric: Fabric, thickness: float) -> tuple[str, str]:
    """Why the fabric cannot be stepped under the foot, as (the table or key at fault, why), or
    ('', '') if it can: it asks for steps below :data:`MIN_FEED_STEP`, set by the lighter of the
    top ply (the ``[fabric]`` table at fault) and the foot (``[presser] mass``)."""
    step = feed_step(presser, fabric, thickness)
    if step >= MIN_FEED_STEP:
        return "", ""
    top = fabric.area * fabric.layers(thickness)[-1].mass
    needs = f"it needs steps of {step * 1e6:.2g} us, at least {MIN_FEED_STEP * 1e6:g} us"
    if presser.mass < top:
        return "[presser] mass", (
            f"the foot ({presser.mass * 1e3:.3g} g) on the fabric's {fabric.stiffness_of(thickness) * 1e-3:.4g} N/mm "
            f"moves too fast to step ({needs}): a heavier presser bar and foot"
        )
    return "[fabric]", (
        f"its top ply ({top * 1e3:.3g} g: area times mass per area) on {fabric.stiffness_of(thickness) * 1e-3:.4g} "
        f"N/mm under the foot moves too fast to step ({needs}): a larger area or mass per area, or a softer fabric"
    )


def unfit(presser: Presser, fabric: Fabric, thickness: float, *, default_presser: bool = False) -> tuple[str, str]:
    """Why a presser and fabric cannot be fed over ``thickness`` m of fabric, as (the table or
    key at fault, why), or ('', '') if they can: no fabric, a fabric the foot's lift does not
    clear, a fabric under the foot that moves too fast to step (:func:`too_fast`), or a
    presser that presses a ply through its thickness at rest (each ply is a linear spring,
    mjlink.sim.feed, which no fabric is that far). ``default_presser``: the presser is the
    defaults (the message says so)."""
    if thickness <= 0.0:
        return "[timing] fabric", "the feed dog feeds a fabric under the presser foot: give its thickness (above 0 mm)"
    if presser.lift <= thickness:
        return "[timing] fabric", (
            f"{thickness / MM:g} mm of fabric does not fit under the presser foot, which lifts to "
            f"{presser.lift / MM:g} mm above the plate{' (the default)' if default_presser else ''}: "
            "a [presser] lift above it"
        )
    where, fast = too_fast(presser, fabric, thickness)
    if fast:
        return where, fast
    # The foot sinks into the plies one on the next; each gives the load over its stiffness.
    k = fabric.stiffness_of(thickness)
    load = k * (presser.preload + presser.mass * GRAVITY) / (k + presser.rate)
    layers = fabric.layers(thickness)
    for i, ply in enumerate(layers, 1):
        pressed = load / ply.stiffness
        if pressed >= ply.thickness:
            what = (
                f"the {ply.thickness / MM:g} mm fabric" if len(layers) == 1 else f"ply {i} ({ply.thickness / MM:g} mm)"
            )
            return "[presser] preload", (
                f"the foot at rest ({presser.preload:g} N and its weight) presses {what} by {pressed / MM:.3g} mm, "
                "through its thickness: a lighter preload or a stiffer [fabric] stiffness"
            )
    return "", ""


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
    """The ``[fabric]`` table with its ``[[fabric.ply]]`` list if any (see the module's
    docstring)."""
    _needs_feed_dog(r, "[fabric]", has_feed_dog)
    table = dict(r.table(raw, "[fabric]"))
    listed = table.pop("ply", None)
    v = r.defaulted(table, "[fabric]", _FABRIC)
    fabric = Fabric(**_fields({FABRIC_FIELDS[k]: x for k, x in v.items()}))
    if listed is None:
        return fabric
    if not isinstance(listed, list) or not 1 <= len(listed) <= MAX_PLIES:
        raise r.fail("[[fabric.ply]]", f"must be a list of 1 to {MAX_PLIES} tables, one per ply, the bottom one first")
    given = [k for k in PER_PLY if k in table]
    if given:
        raise r.fail(
            f"[fabric] {given[0]}",
            "with [[fabric.ply]] give the mass, stiffness and damping per ply, not for the table",
        )
    plies = []
    for i, entry in enumerate(listed, 1):
        where = f"[[fabric.ply]] {i}"
        t = r.table(entry, where)
        r.keys(t, where, ["thickness"], PER_PLY)
        own = {
            k: r.number(t, k, where, default=_FABRIC[k][0], unit=_unit(_FABRIC[k][2]), bound=_FABRIC[k][2])
            * _FABRIC[k][1]
            for k in PER_PLY
        }
        thick = r.number(t, "thickness", where, unit=" mm", bound=PLY_THICKNESS) * MM
        plies.append(Ply(thickness=thick, **own))
    return replace(fabric, plies=tuple(plies))


def _unit(b: Bound) -> str:
    return f" {b.unit}" if b.unit else ""
