"""How an option's text becomes a value: the argparse types of every option.

Speeds (:func:`speed_arg`) are written with their unit, ``955rpm`` or ``100rad/s``, and signed:
counter-clockwise positive about +Z, as a file's ``[input] speed``; quantities
(:func:`quantity_arg`) and plain numbers (:data:`number_arg`, :func:`whole_arg`) are read by the
grammar mechanism files use (:mod:`mjlink.quantity`: the digits 0-9, units as listed); paths
(:func:`path_arg`) are expanded and held to what a file system can hold; memory sizes
(:func:`size_arg`) carry their unit. A text that is none of these is a usage error
(``argparse.ArgumentTypeError``, exit status 2) in one line.
"""

from __future__ import annotations

import argparse
import math
import os
import re
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

from ..quantity import KINDS, NotANumberError, QuantityError
from ..quantity import convert as convert_quantity
from ..quantity import parse as parse_quantity
from ..quantity import read as read_quantity
from ..units import from_rpm
from . import text


@dataclass(frozen=True)
class Speed:
    """A speed as written on the command line: ``value`` in its ``unit`` (an angular speed of
    mjlink.quantity: 'rpm' for rpm, rev/min and r/min, else as written: 'rad/s', 'rev/s',
    'deg/s'), signed, counter-clockwise positive about +Z; ``rad_s`` the same in rad/s."""

    value: float
    unit: str

    @property
    def rad_s(self) -> float:
        if self.unit == "rpm":
            return from_rpm(self.value)  # the order of operations the speeds have always had
        return convert_quantity(self.value, self.unit, "rad/s")

    @property
    def arg(self) -> str:
        """As an argument: '955rpm', '-100rad/s'."""
        return f"{self.value:g}{self.unit}"

    def __str__(self) -> str:
        """As messages show it: '955 rpm'."""
        return f"{self.value:g} {self.unit}"


# The spellings of rpm, shown as one; every other unit of angular speed as written.
_UNITS = {"rev/min": "rpm", "r/min": "rpm"}


_SPEED_UNITS = ", ".join(KINDS["angular speed"])


def speed_arg(s: str) -> Speed:
    """argparse type of every speed option: a signed number with its unit, in the grammar of
    mjlink.quantity that files use (see :data:`SPEEDS`); a bare number is refused."""
    try:
        value, unit = read_quantity(s, "rad/s")
    except NotANumberError:
        raise argparse.ArgumentTypeError(
            f"{text.error_line(repr(s))} is not a speed: write a signed number and its unit, e.g. 955rpm or "
            f"-100rad/s ({_SPEED_UNITS})"
        ) from None
    except QuantityError as e:
        raise argparse.ArgumentTypeError(text.error_line(str(e))) from None
    if not unit:
        raise argparse.ArgumentTypeError(
            f"write the speed with its unit: {s.strip()}rpm or {s.strip()}rad/s (signed, counter-clockwise "
            "positive as the file's [input] speed); a bare number is ambiguous"
        )
    speed = Speed(value, _UNITS.get(unit, unit))
    if not math.isfinite(speed.rad_s):
        raise argparse.ArgumentTypeError(f"{s.strip()} is not a finite speed")
    return speed


def path_arg(s: str) -> Path:
    """argparse type of every path option: not empty, ``~`` and ``~user`` expanded (as the shell
    does when it is not quoted); an unknown user is a usage error."""
    if not s.strip():
        raise argparse.ArgumentTypeError("empty path: give a file or folder name")
    try:
        p = Path(s).expanduser()
    except RuntimeError:  # ~user of no such user, or no home folder
        raise argparse.ArgumentTypeError(
            f"{text.error_line(s)}: cannot expand {text.error_line(s.split('/')[0])}: no such user or home folder"
        ) from None
    # A name the file system cannot hold fails every later look at it with an OSError: refused
    # here, once, for every path option.
    long = next((part for part in p.parts if len(os.fsencode(part)) > _NAME_MAX), None)
    if long is not None or len(os.fsencode(str(p))) > _PATH_MAX:
        what = f"a name of {len(os.fsencode(long))} bytes" if long is not None else f"{len(os.fsencode(str(p)))} bytes"
        raise argparse.ArgumentTypeError(
            f"{_clipped(s)}: path too long for the file system ({what}; at most {_NAME_MAX} bytes a name, "
            f"{_PATH_MAX} in all)"
        )
    return p


_NAME_MAX, _PATH_MAX = 255, 4096  # bytes: Linux's (and most file systems') limits


def _clipped(s: str) -> str:
    return text.error_line(s if len(s) <= 80 else f"{s[:37]}...{s[-37:]}")


def quantity_arg(unit: str) -> Callable[[str], float]:
    """argparse type of an option in ``unit``: a bare number in ``unit`` or a number with any
    unit of its kind, with or without a space ('2', '2s', '500 ms'; mjlink.quantity)."""

    def read(s: str) -> float:
        try:
            return parse_quantity(s, unit)
        except QuantityError as e:
            raise argparse.ArgumentTypeError(text.error_line(str(e))) from None

    read.__name__ = f"quantity in {unit}" if unit else "number"  # argparse names the type in its messages
    return read


number_arg = quantity_arg("")
"""argparse type of a plain number (no unit): the quantity grammar's, so the digits 0-9 only."""


_WHOLE = re.compile(r"\s*([-+]?[0-9]+)\s*")


def whole_arg(s: str) -> int:
    """argparse type of a whole number, written with the digits 0-9 (int() would also take
    other scripts' digits)."""
    m = _WHOLE.fullmatch(s)
    if m is None:
        raise argparse.ArgumentTypeError(
            f"{text.error_line(repr(s))} is not a whole number: write it with the digits 0-9, e.g. 2"
        )
    return int(m[1])


_SIZES = {"": 1.0, "b": 1.0, "k": 1e3, "kb": 1e3, "m": 1e6, "mb": 1e6, "g": 1e9, "gb": 1e9, "t": 1e12, "tb": 1e12}


_SIZES |= {"kib": 2.0**10, "mib": 2.0**20, "gib": 2.0**30, "tib": 2.0**40}


def parse_size(text: str) -> float:
    """'64GiB', '500MB', '2e9' -> bytes; ValueError for anything else."""
    t = text.strip().lower().replace(" ", "")
    i = len(t)
    while i and t[i - 1].isalpha():
        i -= 1
    number, unit = t[:i], t[i:]
    if not number.isascii():  # float() would take other scripts' digits
        raise ValueError(text)
    v = float(number)
    if unit not in _SIZES or not math.isfinite(v) or v <= 0:
        raise ValueError(text)
    return v * _SIZES[unit]


def size_arg(s: str) -> float:
    """argparse type of --max-memory: a size with its unit, 64GiB, 500MB, 2e9 (bytes)."""

    try:
        return parse_size(s)
    except ValueError:
        raise argparse.ArgumentTypeError(
            f"{text.error_line(repr(s))} is not a memory size: write a number and its unit, e.g. 64GiB or 500MB"
        ) from None
