"""One grammar for a number with its unit, everywhere a quantity is written.

The command line, mechanism files and study files take a quantity as a bare number in the
place's own unit (a file's mm, deg, g, rad/s ...) or as a number followed by a unit, with or
without a space: ``12mm``, ``1.2 cm``, ``3deg``, ``100rpm``, ``10.5rad/s``, ``2s``, ``500 ms``.
:func:`parse` converts such a text to the unit the place expects; a unit of another kind
(``12 s`` where a length goes) is a one-line :class:`QuantityError` naming the units that fit.

Units are case-sensitive, written exactly as listed below: ``mm`` is a millimetre and ``ms`` a
millisecond, so ``MM``, ``Ms`` or ``RPM`` are refused, the message naming the spelling meant.
Numbers are written with the digits 0-9 (a decimal point, an exponent ``e``/``E``); digits of
other scripts (fullwidth, Arabic-Indic, ...) are refused in one line, as is a result that is
not finite. The micro sign of ``µm`` may also be typed as the Greek small mu (``μm``).

The units, by kind (the factor is to the SI unit of the kind):
"""

from __future__ import annotations

import math
import re
import reprlib

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
    "force": {"N": 1.0, "kN": 1e3, "cN": 1e-2, "gf": 9.80665e-3},
    "stiffness": {"N/m": 1.0, "N/mm": 1e3},
    "acceleration": {"m/s^2": 1.0, "m/s²": 1.0, "mm/s^2": 1e-3},
    "frequency": {"Hz": 1.0, "1/s": 1.0},
}
_KIND_OF: dict[str, str] = {u: k for k, units in KINDS.items() for u in units}
# Spellings that look like a listed unit but are other characters: the Greek small mu (U+03BC),
# which many keyboards give for the micro sign (U+00B5) of µm.
_ALIASES: dict[str, str] = {"μm": "µm"}

__doc__ = (__doc__ or "") + "\n".join(f"* {kind}: {', '.join(units)}" for kind, units in KINDS.items()) + "\n"

# ASCII digits only: Python's \d and float() also take other scripts' digits ('١٢', '１２').
_NUMBER = r"[-+]?(?:[0-9]+\.?[0-9]*|\.[0-9]+)(?:[eE][-+]?[0-9]+)?"
_TEXT = re.compile(rf"\s*({_NUMBER})\s*(\S*)\s*")
_ANY_DIGITS = re.compile(r"\s*[-+]?[\d.]*\d")  # a number in any script's digits, at the start


_REPR = reprlib.Repr()
_REPR.maxstring = 60


def _shown(text: str) -> str:
    """``text`` as a message echoes it: repr-escaped and clipped (a file's string may be long)."""
    return _REPR.repr(text)


class QuantityError(InputError):
    """A quantity's text that is not a number with a unit of the expected kind."""


class NotANumberError(QuantityError):
    """A quantity's text that does not start with a number of the grammar at all."""


def kind_of(unit: str) -> str | None:
    """The kind of ``unit`` ('mm' -> 'length'), None for a unit this grammar does not know."""
    u = unit.strip()
    return _KIND_OF.get(_ALIASES.get(u, u))


def _fits(kind: str | None) -> str:
    return f" ({', '.join(KINDS[kind])})" if kind else ""


def read(text: str, unit: str) -> tuple[float, str]:
    """The number of ``text`` and its unit as listed in :data:`KINDS` ('' for a bare number),
    the unit checked to be of ``unit``'s kind (``unit`` '' for a plain number: no unit fits).
    ``read("955 rpm", "rad/s")`` is (955.0, 'rpm'). Raises QuantityError as :func:`parse`."""
    digits = _ANY_DIGITS.match(text)
    if digits is not None and not digits[0].isascii():
        odd = next(c for c in digits[0] if not c.isascii())
        raise QuantityError(f"{_shown(text)}: write the number with the digits 0-9 ({_shown(odd)} is not one of them)")
    m = _TEXT.fullmatch(text)
    kind = kind_of(unit)
    if m is None:
        want = f": write e.g. 12{unit.strip()} or 12 {unit.strip()}" if unit.strip() else ": write e.g. 12 or 0.5"
        raise NotANumberError(f"{_shown(text)} is not a number{' with a unit' if unit.strip() else ''}{want}")
    value, written = float(m[1]), m[2]
    if not math.isfinite(value):
        raise QuantityError(f"{_shown(text)} is not finite")
    written = _ALIASES.get(written, written)
    if not written or written == unit.strip():
        return value, written
    if kind is None:
        if not unit.strip():
            raise QuantityError(f"{_shown(text)}: a plain number goes here, without a unit ({_shown(written)})")
        raise QuantityError(f"{_shown(text)}: {_shown(written)} is not a unit of {unit}")
    if kind_of(written) != kind:
        same = [u for u in KINDS[kind] if u.lower() == written.lower()]
        if same:  # the one case rule: as listed, so that mm and Mm, ms and Ms never mean one thing
            raise QuantityError(
                f"{_shown(text)}: {_shown(written)} is not a unit of {kind}: units are case-sensitive, write "
                f"'{same[0]}'{_fits(kind)}"
            )
        raise QuantityError(f"{_shown(text)}: {_shown(written)} is not a unit of {kind}{_fits(kind)}")
    return value, written


def convert(value: float, written: str, unit: str) -> float:
    """``value`` in the unit ``written`` (of :data:`KINDS`) as a number in ``unit``, same kind."""
    written, unit = _ALIASES.get(written, written), unit.strip()
    if not written or written == unit:
        return value
    kind = _KIND_OF[written]
    return value * KINDS[kind][written] / KINDS[kind][unit]


def parse(text: str, unit: str, *, require_unit: bool = False) -> float:
    """``text`` (a number, optionally with a unit) in ``unit``: ``parse("1.2cm", "mm")`` is
    12.0, ``parse("100rpm", "rad/s")`` 10.47..., ``parse("12", "mm")`` 12.0 (a bare number is
    in ``unit`` already; with ``require_unit`` it is refused, as a file's quoted number is).
    Raises QuantityError for text that is not a finite number with a unit of ``unit``'s kind
    (a unit in another case than listed included, and digits other than 0-9)."""
    value, written = read(text, unit)
    if not written and require_unit:
        number = _TEXT.fullmatch(text)
        shown = number[1] if number else text.strip()
        raise QuantityError(
            f"must be a number, not the text {_shown(text)}: write {_shown(shown)[1:-1]}, or "
            f"'{_shown(shown)[1:-1]}{unit}' with its unit"
        )
    out = convert(value, written, unit)
    if not math.isfinite(out):
        raise QuantityError(f"{_shown(text)} is not finite in {unit.strip()}")
    return out
