"""Every value a study writes into its mechanism, held to the mechanism file's own validation.

The values a study will write (its [set] values, grid values, the ends of a range, tolerance
samples, a robust optimization's range widened by its deviations) are written into the
mechanism's file as a user would and read by the mechanism reader
(:func:`mjlink.model.paths.check_values`); a refusal is the study file's error, with its line
(:func:`_line`: the file's text is scanned for the table and key) and the reader's own words.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from ..errors import MjlinkError
from ..model import paths
from ..model.mechanism import Mechanism
from . import sampling
from .errors import StudyFileError
from .varied import Varied

# Tolerance samples held to the mechanism file's validation one by one up to this many values;
# beyond, the band is bounded instead (uniform: +-tolerance; normal: +-2 tolerance, six standard
# deviations).
MAX_CHECKED_SAMPLES = 20_000_000


def _line(text: str, table: str, index: int = 0, key: str | None = None) -> int | None:
    """The 1-based line of the ``index``-th ``[table]`` (``[[table]]``) header in a study file's
    text, or of ``key`` within that table; None if not found (the text is scanned, not parsed:
    a line number for a message)."""
    seen = -1
    inside = False
    for n, raw in enumerate(text.splitlines(), 1):
        line = raw.strip()
        if line.startswith("["):
            head = line.split("#", 1)[0].strip().strip("[]").strip()
            inside = head == table and (seen := seen + 1) == index
            if inside and key is None:
                return n
            continue
        if inside and key is not None:
            name = line.split("=", 1)[0].strip().strip("'\"")
            if "=" in line and name == key:
                return n
    return None


def _at(src: object, line: int | None) -> str:
    return f"{src}:{line}" if line is not None else f"{src}"


def _values_fail(src: object, line: int | None, where: str, e: MjlinkError) -> StudyFileError:
    why = str(e).split(": ", 1)[-1]  # the reader's message without its file's path
    return StudyFileError(f"{_at(src, line)}: {where}: {why}")


def check_set(src: object, text: str, mech: Mechanism, fixed: tuple[tuple[str, float], ...]) -> None:
    """Every ``[set]`` value through the mechanism file's own validation, one at a time (so the
    message names its line), then all together."""
    if mech.path is None or not fixed:
        return
    resolved = [(k, paths.resolve(mech, k), v) for k, v in fixed]
    for k, p, v in resolved:
        try:
            paths.check_values(mech, {p: v})
        except MjlinkError as e:
            raise _values_fail(src, _line(text, "set", key=k), f"[set] {k} = {v:g}", e) from None
    try:
        paths.check_values(mech, {p: v for _, p, v in resolved})
    except MjlinkError as e:
        raise _values_fail(src, _line(text, "set"), "[set]", e) from None


def check_varied(
    src: object,
    text: str,
    mech: Mechanism,
    fixed: tuple[tuple[str, float], ...],
    varied: list[Varied],
    method: str,
    samples: int,
    seed: int,
    robust: Any,
) -> None:
    """Every value a study will write into the mechanism (grid values, the ends of a range, the
    tolerance samples, a robust optimization's range widened by its deviations) held to the
    mechanism file's own validation with the other numbers at their [set] or file values.

    The rules of a mechanism file bound a value from below, from above or in magnitude, so the
    smallest, the largest and the smallest in magnitude of the values a parameter takes (0 if
    a range spans it) are the ones to check."""
    if mech.path is None:
        return
    base = {paths.resolve(mech, k): v for k, v in fixed}
    extremes = _extremes(varied, method, samples, seed, robust)
    for i, (v, (what, xs)) in enumerate(zip(varied, extremes, strict=True)):
        for x in xs:
            try:
                paths.check_values(mech, {**base, v.param: x})
            except MjlinkError as e:
                where = f"[[parameter]] #{i + 1} ({v.param.path}) {what}"
                unit = f" {v.param.unit}" if v.param.unit else ""
                raise _values_fail(
                    src,
                    _line(text, "parameter", i, "path"),
                    f"{where}: {x:g}{unit} would make an invalid mechanism file",
                    e,
                ) from None


def _extremes(varied: list[Varied], method: str, samples: int, seed: int, robust: Any) -> list[tuple[str, list[float]]]:
    """Per parameter: what its values are called in a message, and the values to check."""
    dev_lo = dev_hi = np.zeros(len(varied))
    if method == "optimize" and robust is not None:
        d = sampling.robust_deviations(varied, robust.samples, robust.seed)
        dev_lo, dev_hi = d.min(axis=0), d.max(axis=0)
    sampled = None
    if method == "tolerance" and samples * len(varied) <= MAX_CHECKED_SAMPLES:
        sampled = sampling.tolerance(varied, samples, seed)
    out = []
    for j, v in enumerate(varied):
        if method == "grid":
            xs, what = list(v.values), "values"
        elif method == "optimize" and math.isnan(v.low):  # an operating condition: the file's value deviated
            lo, hi = v.param.nominal + float(dev_lo[j]), v.param.nominal + float(dev_hi[j])
            xs, what = [lo, hi] + ([0.0] if lo < 0 < hi else []), "value with its tolerance"
        elif method in ("random", "optimize"):
            lo, hi = v.low + float(dev_lo[j]), v.high + float(dev_hi[j])
            xs = [lo, hi] + ([0.0] if lo < 0 < hi else [])
            what = "range" + (" with its tolerance" if robust is not None and v.tolerance > 0 else "")
        elif sampled is not None:
            col = sampled[:, j]
            xs, what = list(col) if len(col) <= 3 else [float(col.min()), float(col.max())], "tolerance samples"
            xs.append(float(col[np.argmin(np.abs(col))]))
        else:
            band = v.tolerance * (2.0 if v.distribution == "normal" else 1.0)
            lo, hi = v.param.nominal - band, v.param.nominal + band
            xs, what = [lo, hi] + ([0.0] if lo < 0 < hi else []), "tolerance band"
        if xs:
            a = np.asarray(xs, dtype=float)
            xs = sorted({float(a.min()), float(a.max()), float(a[np.argmin(np.abs(a))])})
        out.append((what, xs))
    return out
