"""Walking a parsed TOML table: every problem becomes one clear line naming the file and key.

Used by the mechanism reader and by every block's own ``read``. A file's values are echoed in
messages only through :func:`shown`: escaped (no raw control characters or newlines), clipped
and safe for any value TOML can hold (integers of thousands of digits, deep nesting).
"""

from __future__ import annotations

import difflib
import math
import reprlib
import sys
import tomllib
from collections.abc import Iterable
from pathlib import Path
from typing import Any

import numpy as np

from ..errors import MechanismFileError
from ..quantity import QuantityError, parse
from . import names as _names
from .limits import Bound, above, below

_INT_DIGITS = sys.get_int_max_str_digits() or 4300  # Python refuses str() of longer integers


def digits(v: int) -> str:
    """How many decimal digits ``v`` has, as text: exact where Python can print ``v``, else
    'about N' (from its bit length; str() of a longer integer raises ValueError)."""
    try:
        return str(len(str(abs(v))))
    except ValueError:
        return f"about {math.floor(abs(v).bit_length() * math.log10(2)) + 1}"


class _Shown(reprlib.Repr):
    """repr() of a file's value for a message: strings escaped, everything clipped."""

    def __init__(self) -> None:
        super().__init__()
        self.maxlevel, self.maxlist, self.maxtuple, self.maxdict = 3, 8, 8, 6
        self.maxstring, self.maxother, self.maxlong = 80, 80, 40

    def repr_int(self, x: int, level: int) -> str:
        if x.bit_length() > 256:  # repr() of a long enough integer raises ValueError
            return f"<an integer of {digits(x)} digits>"
        return super().repr_int(x, level)


_shown = _Shown()


def shown(v: Any) -> str:
    """``v`` as a message may echo it: repr-escaped (no raw control characters or newlines),
    clipped to about 80 characters, three levels deep; never raises."""
    try:
        return _shown.repr(v)
    except Exception:  # a value no repr can show (none from TOML): name its type
        return f"<{type(v).__name__}>"


class Reader:
    """Walks a parsed TOML table, turning every problem into one clear line."""

    shown = staticmethod(shown)  # for blocks, which see the reader but do not import it

    def __init__(self, path: Path | str):
        self.path = str(path)

    def toml(self, text: str) -> dict[str, Any]:
        """The parsed TOML ``text``; every way tomllib can fail is one line naming the file."""
        try:
            return tomllib.loads(text)
        except tomllib.TOMLDecodeError as e:
            raise self.fail("", f"TOML syntax error: {e}") from None
        except RecursionError:
            raise self.fail("", "TOML nested too deeply (arrays or inline tables within each other)") from None
        except ValueError:  # an integer literal beyond Python's limit for str -> int
            raise self.fail(
                "",
                f"TOML: an integer of more than {_INT_DIGITS} digits (mechanism files hold mm, deg, g: "
                "write a plain number)",
            ) from None

    def fail(self, where: str, msg: str) -> MechanismFileError:
        return MechanismFileError(f"{self.path}: {where}: {msg}" if where else f"{self.path}: {msg}")

    def table(self, data: Any, where: str) -> dict:
        if not isinstance(data, dict):
            raise self.fail(where, f"must be a table, got {type(data).__name__}")
        return data

    def defaulted(self, raw: Any, where: str, table: dict[str, tuple[float, float, Bound, str]]) -> dict[str, float]:
        """A table of optional numbers: ``table`` maps each key to (its default in the file's
        unit, the factor to SI, its bound, its source); unknown keys are refused. Returns SI."""
        t = self.table(raw, where)
        self.keys(t, where, [], list(table))
        out = {}
        for key, (default, scale, bound, _) in table.items():
            unit = f" {bound.unit}" if bound.unit else ""
            out[key] = self.number(t, key, where, default=default, unit=unit, bound=bound) * scale
        return out

    def keys(self, data: dict, where: str, required: Iterable[str], optional: Iterable[str] = ()):
        required, optional = list(required), list(optional)
        valid = required + optional
        for k in data:
            if k not in valid:
                near = difflib.get_close_matches(k, valid, n=1)
                hint = f" (did you mean '{near[0]}'?)" if near else f" (valid keys: {', '.join(valid)})"
                raise self.fail(where, f"unknown key {shown(k)}{hint}")
        for k in required:
            if k not in data:
                raise self.fail(where, f"missing key '{k}'")

    def number(
        self,
        data: dict,
        key: str,
        where: str,
        *,
        default=None,
        positive=False,
        nonneg=False,
        scale=1.0,
        lo=None,
        hi=None,
        unit="",
        why="",
        bound: Bound | None = None,
    ) -> float:
        """A finite number times ``scale``; ``lo``/``hi`` bound its magnitude (file units, ``unit``
        for messages), ``bound`` its signed range (limits.Bound); both compared with
        limits.BOUND_RTOL. A missing key gives ``default`` as it is: already scaled (SI)."""
        if key not in data:
            if default is None:
                raise self.fail(where, f"missing key '{key}'")
            return default
        v = data[key]
        if isinstance(v, str) and unit.strip():
            # A number with its unit, in the grammar every place shares ('12mm', '1.2 cm').
            try:
                v = parse(v, unit.strip(), require_unit=True)
            except QuantityError as e:
                raise self.fail(f"{where} {key}", str(e)) from None
        if isinstance(v, bool) or not isinstance(v, (int, float)):
            with_unit = f" (or a string with its unit, e.g. '12{unit.strip()}')" if unit.strip() else ""
            raise self.fail(f"{where} {key}", f"must be a number, got {type(v).__name__} {shown(v)}{with_unit}")
        try:
            v = float(v)
        except OverflowError:  # TOML integers may have any number of digits
            raise self.fail(f"{where} {key}", f"must be finite, got an integer of {digits(int(v))} digits") from None
        if not math.isfinite(v):
            raise self.fail(f"{where} {key}", f"must be finite, got {v}")
        # Values are echoed in the file's own unit, as written: 'got -5 mm', never SI.
        if positive and v <= 0:
            raise self.fail(f"{where} {key}", f"must be > 0, got {v:g}{unit}")
        if nonneg and v < 0:
            raise self.fail(f"{where} {key}", f"must be >= 0, got {v:g}{unit}")
        why = f" ({why})" if why else ""
        if hi is not None and above(abs(v), hi):
            raise self.fail(f"{where} {key}", f"must be at most {hi:g}{unit} in magnitude{why}, got {v:g}{unit}")
        if lo is not None and below(abs(v), lo):
            raise self.fail(f"{where} {key}", f"must be at least {lo:g}{unit} in magnitude{why}, got {v:g}{unit}")
        refused = bound.refuses(v) if bound is not None else None
        if refused:
            raise self.fail(f"{where} {key}", refused)
        return v * scale

    def string(self, data: dict, key: str, where: str, *, default=None, max_length: int | None = None) -> str:
        """A string; with ``max_length``, one line of printable text of at most that many
        characters (text shown in listings, plot titles and reports)."""
        if key not in data:
            if default is None:
                raise self.fail(where, f"missing key '{key}'")
            return default
        v = data[key]
        if not isinstance(v, str):
            raise self.fail(f"{where} {key}", f"must be a string, got {type(v).__name__} {shown(v)}")
        if max_length is not None:
            if len(v) > max_length:
                raise self.fail(
                    f"{where} {key}",
                    f"must be at most {max_length} characters (one line; see mechanisms/README.md, Limits), "
                    f"got {len(v)}: {shown(v)}",
                )
            if not v.isprintable():
                raise self.fail(f"{where} {key}", f"must be one line of printable text, got {shown(v)}")
        return v

    def name(self, v: Any, where: str) -> str:
        if not _names.is_valid(v):
            raise self.fail(where, f"invalid name {shown(v)}: use a letter then letters, digits or _ (at most 32)")
        return v

    def vector(
        self,
        v: Any,
        where: str,
        sizes=(2, 3),
        scale=1.0,
        hi=None,
        unit="",
        what="coordinates",
        why="mjlink models machine linkages; see mechanisms/README.md",
    ) -> np.ndarray:
        """A list of 2 or 3 finite numbers (z = 0 if absent) in ``unit``; ``hi`` bounds each
        one's magnitude (``what`` they are and ``why`` for the message). With ``unit``, a
        number may be written with its unit ('12mm', '1.2 cm')."""
        if not isinstance(v, list) or len(v) not in sizes:
            raise self.fail(where, f"must be a list of {' or '.join(map(str, sizes))} numbers, got {shown(v)}")
        out = []
        for x in v:
            if isinstance(x, str) and unit:
                try:
                    x = parse(x, unit, require_unit=True)
                except QuantityError as e:
                    raise self.fail(where, str(e)) from None
            try:
                ok = not isinstance(x, bool) and isinstance(x, (int, float)) and math.isfinite(float(x))
            except OverflowError:
                ok = False
            if not ok:
                raise self.fail(where, f"must hold finite numbers, got {shown(v)}")
            if hi is not None and above(abs(float(x)), hi):
                raise self.fail(where, f"{what} must be at most {hi:g} {unit} in magnitude ({why}), got {shown(v)}")
            out.append(float(x) * scale)
        while len(out) < 3:
            out.append(0.0)
        return np.array(out)

    def names(self, v: Any, where: str, *, length: int | None = None, min_length: int = 1) -> tuple[str, ...]:
        if not isinstance(v, list) or (length is not None and len(v) != length) or len(v) < min_length:
            want = f"{length}" if length is not None else f"at least {min_length}"
            raise self.fail(where, f"must be a list of {want} point names, got {shown(v)}")
        return tuple(self.name(x, where) for x in v)
