"""One grammar for a number with its unit, everywhere a quantity is written.

The command line, mechanism files and study files take a quantity as a bare number in the
place's own unit (a file's mm, deg, g, rad/s ...) or as a number followed by a unit, with or
without a space: ``12mm``, ``1.2 cm``, ``3deg``, ``100rpm``, ``10.5rad/s``, ``2s``, ``500 ms``.
:func:`parse` converts such a text to the unit the place expects; a unit of another kind
(``12 s`` where a length goes) is a one-line :class:`QuantityError` naming the units that fit.

The units, by kind (the factor is to the SI unit of the kind):
"""

from __future__ import annotations

import math
import re

from .errors import InputError

# kind -> unit -> factor to the kind's SI unit. Spellings of one unit share its factor.
KINDS: dict[str, dict[str, float]] = {
    "length": {"m": 1.0, "cm": 1e-2, "mm": 1e-3, "um": 1e-6, "µm": 1e-6},
    "angle": {"rad": 1.0, "deg": math.pi / 180.0, "°": math.pi / 180.0, "rev": 2.0 * math.pi, "turn": 2.0 * math.pi},
    "angular speed": {
        "rad/s": 1.0,
        "deg/s": math.pi / 180.0,
        "rpm": math.pi / 30.0,
        "rev/min": math.pi / 30.0,
        "r/min": math.pi / 30.0,
        "rev/s": 2.0 * math.pi,
    },
    "time": {"s": 1.0, "ms": 1e-3, "min": 60.0},
    "mass": {"kg": 1.0, "g": 1e-3},
    "moment of inertia": {"kg*m^2": 1.0, "kg·m²": 1.0, "g*mm^2": 1e-9, "g*cm^2": 1e-7, "kg*mm^2": 1e-6},
    "torque": {"N*m": 1.0, "N·m": 1.0, "Nm": 1.0, "N*mm": 1e-3, "N·mm": 1e-3},
    "rotational damping": {"N*m*s": 1.0, "N·m·s": 1.0, "N*m*s/rad": 1.0},
    "force": {"N": 1.0, "kN": 1e3},
    "acceleration": {"m/s^2": 1.0, "m/s²": 1.0, "mm/s^2": 1e-3},
    "frequency": {"Hz": 1.0, "1/s": 1.0},
}
_KIND_OF: dict[str, str] = {u: k for k, units in KINDS.items() for u in units}

__doc__ = (__doc__ or "") + "\n".join(f"* {kind}: {', '.join(units)}" for kind, units in KINDS.items()) + "\n"

_NUMBER = r"[-+]?(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?"
_TEXT = re.compile(rf"\s*({_NUMBER})\s*(\S*)\s*")


class QuantityError(InputError):
    """A quantity's text that is not a number with a unit of the expected kind."""


def kind_of(unit: str) -> str | None:
    """The kind of ``unit`` ('mm' -> 'length'), None for a unit this grammar does not know."""
    return _KIND_OF.get(unit.strip())


def parse(text: str, unit: str, *, require_unit: bool = False) -> float:
    """``text`` (a number, optionally with a unit) in ``unit``: ``parse("1.2cm", "mm")`` is
    12.0, ``parse("100rpm", "rad/s")`` 10.47..., ``parse("12", "mm")`` 12.0 (a bare number is
    in ``unit`` already; with ``require_unit`` it is refused, as a file's quoted number is).
    Raises QuantityError for text that is not a finite number with a unit of ``unit``'s kind."""
    m = _TEXT.fullmatch(text)
    kind = kind_of(unit)
    fits = f" ({', '.join(KINDS[kind])})" if kind else ""
    if m is None:
        raise QuantityError(f"{text!r} is not a number with a unit: write e.g. 12{unit} or 12 {unit}".rstrip())
    value, written = float(m[1]), m[2]
    if not math.isfinite(value):
        raise QuantityError(f"{text!r} is not finite")
    if not written and require_unit:
        raise QuantityError(f"must be a number, not the text {text!r}: write {m[1]}, or '{m[1]}{unit}' with its unit")
    if not written or written == unit.strip():
        return value
    if kind is None or kind_of(written) != kind:
        raise QuantityError(f"{text!r}: '{written}' is not a unit of {kind or unit}{fits}")
    return value * KINDS[kind][written] / KINDS[kind][unit.strip()]
