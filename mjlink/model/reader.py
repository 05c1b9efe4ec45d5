"""Walking a parsed TOML table: every problem becomes one clear line naming the file and key.

Used by the mechanism reader and by every block's own ``read``.
"""

from __future__ import annotations

import difflib
import math
from collections.abc import Iterable
from pathlib import Path
from typing import Any

import numpy as np

from ..errors import MechanismFileError
from . import names as _names


class Reader:
    """Walks a parsed TOML table, turning every problem into one clear line."""

    def __init__(self, path: Path | str):
        self.path = str(path)

    def fail(self, where: str, msg: str) -> MechanismFileError:
        return MechanismFileError(f"{self.path}: {where}: {msg}" if where else f"{self.path}: {msg}")

    def table(self, data: Any, where: str) -> dict:
        if not isinstance(data, dict):
            raise self.fail(where, f"must be a table, got {type(data).__name__}")
        return data

    def keys(self, data: dict, where: str, required: Iterable[str], optional: Iterable[str] = ()):
        required, optional = list(required), list(optional)
        valid = required + optional
        for k in data:
            if k not in valid:
                near = difflib.get_close_matches(k, valid, n=1)
                hint = f" (did you mean '{near[0]}'?)" if near else f" (valid keys: {', '.join(valid)})"
                raise self.fail(where, f"unknown key '{k}'{hint}")
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
    ) -> float:
        """A finite number; ``lo``/``hi`` bound its magnitude (file units, ``unit`` for messages)."""
        if key not in data:
            if default is None:
                raise self.fail(where, f"missing key '{key}'")
            return default
        v = data[key]
        if isinstance(v, bool) or not isinstance(v, (int, float)):
            raise self.fail(f"{where} {key}", f"must be a number, got {type(v).__name__} {v!r}")
        try:
            v = float(v)
        except OverflowError:  # TOML integers may have any number of digits
            raise self.fail(f"{where} {key}", f"must be finite, got an integer of {len(str(v))} digits") from None
        if not math.isfinite(v):
            raise self.fail(f"{where} {key}", f"must be finite, got {v}")
        if positive and v <= 0:
            raise self.fail(f"{where} {key}", f"must be > 0, got {v:g}")
        if nonneg and v < 0:
            raise self.fail(f"{where} {key}", f"must be >= 0, got {v:g}")
        why = f" ({why})" if why else ""
        if hi is not None and abs(v) > hi:
            raise self.fail(f"{where} {key}", f"must be at most {hi:g}{unit} in magnitude{why}, got {v:g}")
        if lo is not None and abs(v) < lo:
            raise self.fail(f"{where} {key}", f"must be at least {lo:g}{unit} in magnitude{why}, got {v:g}")
        return v * scale

    def string(self, data: dict, key: str, where: str, *, default=None) -> str:
        if key not in data:
            if default is None:
                raise self.fail(where, f"missing key '{key}'")
            return default
        v = data[key]
        if not isinstance(v, str):
            raise self.fail(f"{where} {key}", f"must be a string, got {type(v).__name__} {v!r}")
        return v

    def name(self, v: Any, where: str) -> str:
        if not _names.is_valid(v):
            raise self.fail(where, f"invalid name {v!r}: use a letter then letters, digits or _ (at most 32)")
        return v

    def vector(self, v: Any, where: str, sizes=(2, 3), scale=1.0, hi=None) -> np.ndarray:
        """A list of 2 or 3 finite numbers (z = 0 if absent); ``hi`` bounds each coordinate, mm."""
        if not isinstance(v, list) or len(v) not in sizes:
            raise self.fail(where, f"must be a list of {' or '.join(map(str, sizes))} numbers, got {v!r}")
        out = []
        for x in v:
            try:
                ok = not isinstance(x, bool) and isinstance(x, (int, float)) and math.isfinite(float(x))
            except OverflowError:
                ok = False
            if not ok:
                raise self.fail(where, f"must hold finite numbers, got {v!r}")
            if hi is not None and abs(float(x)) > hi:
                raise self.fail(
                    where,
                    f"coordinates must be at most {hi:g} mm in magnitude (mjlink models machine "
                    f"linkages; see mechanisms/README.md), got {v!r}",
                )
            out.append(float(x) * scale)
        while len(out) < 3:
            out.append(0.0)
        return np.array(out)

    def names(self, v: Any, where: str, *, length: int | None = None, min_length: int = 1) -> tuple[str, ...]:
        if not isinstance(v, list) or (length is not None and len(v) != length) or len(v) < min_length:
            want = f"{length}" if length is not None else f"at least {min_length}"
            raise self.fail(where, f"must be a list of {want} point names, got {v!r}")
        return tuple(self.name(x, where) for x in v)
