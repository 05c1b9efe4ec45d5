"""What the design-study figures share: the plain :class:`Column` data they draw, their colours,
and the text and axis helpers (units in labels, numbers as the spread needs, readable ticks).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np
from matplotlib.axis import Axis
from matplotlib.ticker import MaxNLocator, ScalarFormatter

from .. import units
from .style import user_text

MAX_PANELS = 6  # parameters and metrics each, in the scatter matrix: more become unreadable
MAX_RINGED = 100  # variants that passed the MuJoCo check ringed (or 5 % of them, if more)
INFEASIBLE = "cannot assemble / dead point"
FEASIBLE_COLOR = "tab:blue"
INFEASIBLE_COLOR = "0.45"
FAILED_COLOR = "tab:red"
PASSED_COLOR = "tab:green"
NOMINAL_COLOR = "0.15"
NOMINAL_STYLE: dict[str, Any] = dict(color=NOMINAL_COLOR, lw=0.9, ls=(0, (5, 3)), alpha=0.85)
HATCH_FACE = "0.82"
HATCH_LINES = "0.45"
NO_VALUE_FACE = "0.94"
LIMIT_STYLE: dict[str, Any] = dict(colors="k", linewidths=2.4)
# Inadmissible side of a limit: washed out, so the admissible colours stand out.
VEIL = (1.0, 1.0, 1.0, 0.62)
ADMISSIBLE_FACE = "#8fd18f"
TEXT_BOX: dict[str, Any] = dict(boxstyle="round,pad=0.2", fc="white", ec="none", alpha=0.8)


@dataclass(frozen=True)
class Column:
    """One column of a study's table, as the figures draw it.

    ``name``: a parameter path ('construct.P3.length_a') or a metric column ('stroke_P5'), the
    key of ``nominal`` and ``limits``; ``label``: for axes ('stroke of P5'); ``unit``: 'mm',
    'deg', 'um', 'N*m', '' for none ...; ``values``: (V,) float in that unit, NaN where the
    variant is infeasible or the value was not computed ((ny, nx) accepted for grids)."""

    name: str
    label: str
    unit: str
    values: np.ndarray


# ----------------------------------------------------------------------------- text
def _shown_unit(unit: str) -> str:
    """A unit as printed (raw text): :func:`mjlink.units.shown`."""
    return units.shown(unit)


def _unit(unit: str) -> str:
    """A unit as drawn: :func:`_shown_unit`, escaped (the unit comes with user data)."""
    return user_text(_shown_unit(unit))


def _times(scale: int) -> str:
    """'×10⁻⁶' for ``scale`` -6: the factor of an axis's tick numbers ('' for 0)."""
    return f"×10{str(scale).translate(str.maketrans('-0123456789', '⁻⁰¹²³⁴⁵⁶⁷⁸⁹'))}" if scale else ""


def _with_unit(col: Column, scale: int = 0) -> str:
    """'label [unit]' (raw text; '[-]' without a unit), unless the label already ends in its unit
    in brackets ('construct.P3.length_a [mm]'); with the ticks' factor ('label [×10⁻⁶ m]') if
    ``scale``."""
    label, unit = (col.label or col.name).rstrip(), col.unit.strip()
    if not unit:  # a ratio, a count or a flag: '[-]', the figures' mark of no unit
        return f"{label} [{_times(scale) or '-'}]"
    if label.endswith(f"[{unit}]"):
        return f"{label} [{_times(scale)}]" if scale else label
    return f"{label} [{(_times(scale) + ' ') if scale else ''}{_shown_unit(unit)}]"


def _wrap(text: str, width: int, max_lines: int = 3) -> str:
    """``text`` (raw, from a user) broken into lines of about ``width`` characters, drawn
    literally. Long parameter paths break after a dot (else an underscore, a slash...), not
    mid-name; more than ``max_lines`` lines end in an ellipsis."""
    width = max(8, width)
    # (piece, whether a space separates it from the previous piece)
    pieces: list[tuple[str, bool]] = []
    for word in text.split():
        spaced = True
        while len(word) > width:
            cut = 0
            for breakers in (".", "_/-,"):
                cut = max(word.rfind(c, 0, width) for c in breakers) + 1
                if cut > width // 3:
                    break
            cut = cut if cut > width // 3 else width
            pieces.append((word[:cut], spaced))
            word, spaced = word[cut:], False
        pieces.append((word, spaced))
    lines: list[str] = []
    for piece, spaced in pieces:
        sep = " " if spaced else ""
        if lines and len(lines[-1]) + len(sep) + len(piece) <= width:
            lines[-1] += sep + piece
        else:
            lines.append(piece)
    if len(lines) > max_lines:
        lines = [*lines[: max_lines - 1], lines[max_lines - 1][: width - 1] + "…"]
    return "\n".join(user_text(line) for line in lines)


def _chars(width_in: float, fontsize: float) -> int:
    """About how many characters of the default sans-serif font at ``fontsize`` (pt) fit in
    ``width_in`` inches."""
    return int(width_in * 72.0 / (0.6 * fontsize))


def _fmt(v: float, spread: float) -> str:
    """``v`` with enough digits that values ``spread`` apart differ in their 3rd significant
    digit: fixed point for everyday magnitudes, else exponent notation."""
    if not math.isfinite(v):
        return "–"
    if spread <= 0:
        return f"{v:.4g}"
    if 1e-4 <= max(abs(v), spread) < 1e7:
        return f"{v:.{int(min(9, max(0, 2 - math.floor(math.log10(spread)))))}f}"
    digits = math.floor(math.log10(max(abs(v), spread))) - math.floor(math.log10(spread)) + 3
    return f"{v:.{int(min(12, max(3, digits)))}g}"


def _ordinal(p: float) -> str:
    """'median', '1st percentile', '2.5th percentile', '99th percentile'."""
    if p == 50:
        return "median"
    if p != int(p):
        return f"{p:g}th percentile"
    n = int(p)
    suffix = "th" if 10 <= n % 100 <= 20 else {1: "st", 2: "nd", 3: "rd"}.get(n % 10, "th")
    return f"{n}{suffix} percentile"


def _count(n: int, what: str) -> str:
    return f"{n:,} {what}" + ("" if n == 1 else "s")


# ----------------------------------------------------------------------------- axes
def _span(values: np.ndarray) -> tuple[float, float]:
    """The finite range of ``values``, widened when it is one value (or none) so an axis
    can show it: a constant metric sits in the middle of its axis."""
    v = values[np.isfinite(values)]
    if v.size == 0:
        return 0.0, 1.0
    lo, hi = float(v.min()), float(v.max())
    if hi > lo:
        return lo, hi
    d = 0.05 * abs(lo) if lo != 0 else 1.0
    return lo - d, hi + d


class _InsetLocator(MaxNLocator):
    """Ticks as :class:`MaxNLocator`'s, less those in the outer ``inset`` of the axis (a
    fraction): panels packed side by side would have their edge labels run into each other."""

    def __init__(self, inset: float, **kw: Any) -> None:
        super().__init__(**kw)
        self.inset = inset

    def __call__(self) -> Any:
        lo, hi = sorted(self.axis.get_view_interval()) if self.axis is not None else (0.0, 1.0)
        ticks = np.asarray(self.tick_values(lo, hi), dtype=float)
        m = self.inset * (hi - lo)
        inner = ticks[(ticks >= lo + m) & (ticks <= hi - m)]
        return inner if inner.size >= 2 else ticks


def _scale(lo: float, hi: float) -> int:
    """The power of ten (a multiple of 3) to divide tick numbers between ``lo`` and ``hi`` by:
    0 for everyday magnitudes (1e-3 to 1e5)."""
    m = max(abs(lo), abs(hi))
    if not math.isfinite(m) or m == 0 or 1e-3 <= m < 1e5:
        return 0
    return 3 * math.floor(math.log10(m) / 3)


def _tidy(axis: Axis, nbins: int = 4, inset: float = 0.0) -> int:
    """Few ticks, printed in full: tolerance studies vary a value in its 4th digit, and an
    offset ('+2.2e1') on every small panel is hard to read. Very large or small numbers are
    divided by a power of ten, returned for the axis label to name (:func:`_with_unit`):
    matplotlib would print it at the axis's end, where it collides with the neighbouring
    panel. Call once the axis's limits are set. ``inset``: see :class:`_InsetLocator`."""
    axis.set_major_locator(_InsetLocator(inset, nbins=nbins, min_n_ticks=2))
    scale = _scale(*axis.get_view_interval())
    fmt = ScalarFormatter(useOffset=False)
    # Equal limits fix the exponent (0: never scientific).
    fmt.set_powerlimits((scale, scale) if scale else (-99, 99))
    axis.set_major_formatter(fmt)
    axis.get_offset_text().set_visible(False)
    return scale


def _as_1d(col: Column, n: int) -> np.ndarray:
    v = np.asarray(col.values, dtype=float).ravel()
    if v.size != n:
        raise ValueError(f"column {col.name!r} has {v.size} values, expected {n}")
    return v


def _grid(n: int, ncols: int) -> tuple[int, int]:
    cols = min(ncols, n)
    return math.ceil(n / cols), cols


def _hide_unused(axs: np.ndarray, n: int) -> None:
    for ax in axs.flat[n:]:
        ax.set_visible(False)
