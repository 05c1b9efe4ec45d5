"""The kinematic design metrics: positions (stroke, extremes, position error), the thread
(range, feed, deviation from a demand), transmission and pressure angles, and the motion's
quality (peak acceleration, distances, dwell, path error). Definitions in each class's
docstring and in ``studies/README.md``.
"""

from __future__ import annotations

import math
from typing import Any, ClassVar

import numpy as np

from ..errors import did_you_mean
from ..model.limits import MAX_LENGTH_MM
from ..model.mechanism import Mechanism
from ..model.reader import shown
from ..reference.batch import Batch
from .metric_base import (
    AtSpeed,
    Column,
    Curve,
    Loads,
    Metric,
    MetricError,
    _axis,
    _coordinate,
    _dead_points,
    _main_axis,
    _peak,
    _step,
)


# ----------------------------------------------------------------------------- positions
class Stroke(Metric):
    """Stroke of a point: max - min of its coordinate along ``axis`` (x, y or z; default the
    axis along which the nominal design's point moves most) over the period, mm; the extremes
    are refined between the sampled angles with the exact derivatives (:func:`_peak`)."""

    kind = "stroke"
    needs_point = True
    options = ("axis",)

    def read(self, raw: dict[str, Any]) -> None:
        self.axis = _axis(raw, self.where)
        self.ax = self.axis if self.axis is not None else _main_axis(self.mech, self.point)

    def _ax(self, nominal: Batch) -> int:
        return self.ax

    def columns(self) -> list[Column]:
        ax = "" if self.axis is None else "_" + "xyz"[self.axis]
        return [Column(f"stroke_{self.point}{ax}", "mm", f"stroke of {self.point} along {'xyz'[self.ax]}")]

    def compute(self, b: Batch, nominal: Batch, loads: Loads) -> dict[str, np.ndarray]:
        x, d, dd = _coordinate(b, self.point, self._ax(nominal))
        hi, lo = _peak(x, d, dd, _step(b), True), _peak(x, d, dd, _step(b), False)
        return {self.columns()[0].name: (hi - lo) * 1e3}

    def curve(self, b: Batch, loads: Loads) -> Curve | None:
        x = _coordinate(b, self.point, self.ax)[0] * 1e3
        return Curve(f"{'xyz'[self.ax]} of {self.point}", "mm", x)


class Extremes(Metric):
    """Extreme positions of a point: the smallest and largest of its coordinate along ``axis``
    (default as for ``stroke``) over the period, mm (world frame), refined as for ``stroke``."""

    kind = "extremes"
    needs_point = True
    options = ("axis",)

    def read(self, raw: dict[str, Any]) -> None:
        axis = _axis(raw, self.where)
        self.axis = axis if axis is not None else _main_axis(self.mech, self.point)

    def columns(self) -> list[Column]:
        ax = "xyz"[self.axis]
        return [
            Column(f"{self.point}_{ax}_min", "mm", f"lowest {ax} of {self.point}"),
            Column(f"{self.point}_{ax}_max", "mm", f"highest {ax} of {self.point}"),
        ]

    def compute(self, b: Batch, nominal: Batch, loads: Loads) -> dict[str, np.ndarray]:
        x, d, dd = _coordinate(b, self.point, self.axis)
        lo, hi = self.columns()
        return {lo.name: _peak(x, d, dd, _step(b), False) * 1e3, hi.name: _peak(x, d, dd, _step(b), True) * 1e3}

    def curve(self, b: Batch, loads: Loads) -> Curve | None:
        return Curve(f"{'xyz'[self.axis]} of {self.point}", "mm", _coordinate(b, self.point, self.axis)[0] * 1e3)


class PositionError(Metric):
    """Position error of a point: the largest distance, over the period, between the point and
    where the nominal design has it at the same crank angle (from phi0), um. What tolerances
    on the links and pivots cost in the point's path."""

    kind = "position_error"
    needs_point = True

    def columns(self) -> list[Column]:
        return [Column(f"position_error_{self.point}", "um", f"position error of {self.point}")]

    def compute(self, b: Batch, nominal: Batch, loads: Loads) -> dict[str, np.ndarray]:
        d = b.per_variant(b.kin.points[self.point].v) - nominal.kin.points[self.point].v[None]
        return {self.columns()[0].name: np.sqrt((d**2).sum(axis=2)).max(axis=1) * 1e6}


# -------------------------------------------------------------------------------- thread
def _thread(b: Batch, where: str) -> np.ndarray:
    """(V, A) thread length, m."""
    lf = b.kin.thread_length()
    if lf is None:
        raise MetricError(f"{where}: {b.mechanism.name} has no [thread]")
    return b.per_variant(lf.v)


class ThreadRange(Metric):
    """Thread length range: max - min of the thread polyline's length lF over the period, mm
    (extremes refined as for ``stroke``)."""

    kind = "thread_range"

    def columns(self) -> list[Column]:
        return [Column("thread_range", "mm", "thread length range")]

    def compute(self, b: Batch, nominal: Batch, loads: Loads) -> dict[str, np.ndarray]:
        lf = b.kin.thread_length()
        if lf is None:
            raise MetricError(f"{self.where}: {b.mechanism.name} has no [thread]")
        x, d, dd = b.per_variant(lf.v), b.per_variant(lf.d), b.per_variant(lf.dd)
        return {"thread_range": (_peak(x, d, dd, _step(b), True) - _peak(x, d, dd, _step(b), False)) * 1e3}

    def curve(self, b: Batch, loads: Loads) -> Curve | None:
        return Curve("thread length lF", "mm", _thread(b, self.where) * 1e3)


class ThreadFeed(Metric):
    """Thread feed per turn: the thread the lever draws in one input turn, the sum of the
    increases of lF over the turn (its positive variation), mm. For a length with one rise
    and one fall per turn this equals the range."""

    kind = "thread_feed"

    def columns(self) -> list[Column]:
        return [Column("thread_feed", "mm", "thread feed per turn")]

    def compute(self, b: Batch, nominal: Batch, loads: Loads) -> dict[str, np.ndarray]:
        lf = _thread(b, self.where)
        turns = max(1, round(b.mechanism.period / (2 * math.pi)))
        closed = np.concatenate([lf, lf[:, :1]], axis=1)
        rise = np.clip(np.diff(closed, axis=1), 0.0, None).sum(axis=1) / turns
        return {"thread_feed": rise * 1e3}


class FeedDeviation(Metric):
    """Deviation of the thread feed Pd = lF(phi) - lF(phi0) - dP (seed 003) from a demand table
    (``angles`` deg from phi0, ``values`` mm; linear, periodic over the period): the largest
    and the RMS of |Pd - demand| over the period, mm."""

    kind = "feed_deviation"
    options = ("angles", "values")

    def read(self, raw: dict[str, Any]) -> None:
        a, v = raw.get("angles"), raw.get("values")
        if not isinstance(a, list) or not isinstance(v, list) or len(a) != len(v) or len(a) < 2:
            raise MetricError(f"{self.where}: needs 'angles' (deg) and 'values' (mm), lists of equal length >= 2")
        try:
            self.angles = np.radians(np.array(a, dtype=float))
            self.values = np.array(v, dtype=float) * 1e-3
        except (TypeError, ValueError, OverflowError):
            raise MetricError(f"{self.where}: 'angles' and 'values' must be numbers") from None
        if not (np.all(np.isfinite(self.angles)) and np.all(np.isfinite(self.values))):
            raise MetricError(f"{self.where}: 'angles' and 'values' must be finite")
        if not np.all(np.diff(self.angles) > 0):
            raise MetricError(f"{self.where}: 'angles' must increase strictly")

    def columns(self) -> list[Column]:
        return [
            Column("feed_deviation_max", "mm", "largest |Pd - demand|"),
            Column("feed_deviation_rms", "mm", "RMS of Pd - demand"),
        ]

    def compute(self, b: Batch, nominal: Batch, loads: Loads) -> dict[str, np.ndarray]:
        lf = _thread(b, self.where)
        pd = lf - lf[:, :1] - (b.mechanism.thread_elongation or 0.0)
        if np.ndim(pd) == 3:  # pragma: no cover - elongation varies per row
            pd = pd[..., 0]
        demand = np.interp(b.theta, self.angles, self.values, period=b.mechanism.period)
        dev = np.abs(pd - demand[None])
        return {"feed_deviation_max": dev.max(axis=1) * 1e3, "feed_deviation_rms": np.sqrt((dev**2).mean(axis=1)) * 1e3}

    def _pd(self, b: Batch) -> np.ndarray:
        lf = _thread(b, self.where)
        pd: np.ndarray = lf - lf[:, :1] - (b.mechanism.thread_elongation or 0.0)
        return pd

    def curve(self, b: Batch, loads: Loads) -> Curve | None:
        demand = np.interp(b.theta, self.angles, self.values, period=b.mechanism.period)
        return Curve("thread feed Pd", "mm", self._pd(b) * 1e3, demand * 1e3, "demand")


# ----------------------------------------------------------------------- transmission
class TransmissionMin(Metric):
    """Minimum transmission angle over the period and every dyad, folded to 0..90 deg
    (min(mu, 180 - mu): 90 is best, 0 a dead point), deg."""

    kind = "transmission_min"

    def columns(self) -> list[Column]:
        # The folded value is how far the angle keeps from a dead point (0 or 180 deg), not the
        # angle itself: the take-up's 25.4 is an angle reaching 154.6.
        return [Column("transmission_min", "deg", "transmission angle's least distance from a dead point")]

    def compute(self, b: Batch, nominal: Batch, loads: Loads) -> dict[str, np.ndarray]:
        worst = np.full(b.variants, np.nan)
        for dp in _dead_points(b):
            if dp.quantity == "transmission angle":
                m = b.per_variant(dp.margin_deg).min(axis=1)
                worst = np.fmin(worst, m)
        return {"transmission_min": worst}

    def curve(self, b: Batch, loads: Loads) -> Curve | None:
        worst = None
        for dp in _dead_points(b):
            if dp.quantity == "transmission angle":
                m = b.per_variant(dp.margin_deg)
                worst = m if worst is None else np.fmin(worst, m)
        return None if worst is None else Curve("transmission angle's distance from a dead point", "deg", worst)


class PressureMax(Metric):
    """Maximum pressure angle over the period and every slider (between the rod and the
    guide's direction of motion, 0..90 deg), deg."""

    kind = "pressure_max"

    def columns(self) -> list[Column]:
        return [Column("pressure_max", "deg", "maximum pressure angle")]

    def compute(self, b: Batch, nominal: Batch, loads: Loads) -> dict[str, np.ndarray]:
        worst = np.full(b.variants, np.nan)
        for dp in _dead_points(b):
            if dp.quantity == "pressure angle":
                worst = np.fmax(worst, b.per_variant(dp.value_deg).max(axis=1))
        return {"pressure_max": worst}

    def curve(self, b: Batch, loads: Loads) -> Curve | None:
        worst = None
        for dp in _dead_points(b):
            if dp.quantity == "pressure angle":
                m = b.per_variant(dp.value_deg)
                worst = m if worst is None else np.fmax(worst, m)
        return None if worst is None else Curve("largest pressure angle", "deg", worst)


# ------------------------------------------------------------------------ motion quality
def _points(mech: Mechanism, raw: Any, where: str, n: int) -> tuple[str, ...]:
    if not isinstance(raw, list) or len(raw) != n or not all(isinstance(p, str) for p in raw):
        raise MetricError(f"{where}: 'points' must be a list of {n} point names")
    for p in raw:
        if p not in mech.point_names:
            hint = did_you_mean(p, list(mech.point_names))
            raise MetricError(f"{where}: unknown point '{p}' ({hint}points: {', '.join(mech.point_names)})")
    return tuple(raw)


class AccelerationPeak(AtSpeed):
    """Peak acceleration of a point at constant crank speed (``speed`` rad/s, default the
    file's): max over the period of |a|, a = r''(phi) omega^2 its acceleration (exact second
    derivative of the position on jets), along ``axis`` if given, else the vector's magnitude,
    m/s^2. The inertia load of a needle bar is its mass times this."""

    kind = "acceleration_peak"
    needs_point = True
    needs_loads = False
    options: ClassVar[tuple[str, ...]] = ("speed", "axis")

    def read(self, raw: dict[str, Any]) -> None:
        super().read(raw)
        self.axis = _axis(raw, self.where)

    def columns(self) -> list[Column]:
        ax = "" if self.axis is None else "_" + "xyz"[self.axis]
        what = "|a|" if self.axis is None else f"a_{'xyz'[self.axis]}"
        return [
            Column(f"accel_peak_{self.point}{ax}" + self._tag(), "m/s^2", f"peak acceleration {what} of {self.point}")
        ]

    def _acc(self, b: Batch) -> np.ndarray:
        dd = b.kin.points[self.point].dd
        a = dd[:, self.axis] if self.axis is not None else np.sqrt((dd * dd).sum(axis=1))
        return b.per_variant(a) * self.speed**2

    def compute(self, b: Batch, nominal: Batch, loads: Loads) -> dict[str, np.ndarray]:
        return {self.columns()[0].name: np.abs(self._acc(b)).max(axis=1)}

    def curve(self, b: Batch, loads: Loads) -> Curve | None:
        what = "|a|" if self.axis is None else f"a_{'xyz'[self.axis]}"
        return Curve(f"acceleration {what} of {self.point} at {self.speed:g} rad/s", "m/s^2", self._acc(b))


class Distance(Metric):
    """Largest distance between two points (``points`` = [A, B]) over the period, mm: the
    length of a link between them, or how far a working point reaches from a pivot (the head
    height a needle bar's drive needs)."""

    kind = "distance"
    options = ("points",)

    def read(self, raw: dict[str, Any]) -> None:
        self.pair = _points(self.mech, raw.get("points"), self.where, 2)

    def columns(self) -> list[Column]:
        a, c = self.pair
        return [Column(f"distance_{a}_{c}", "mm", f"largest distance {a}-{c}")]

    def _d(self, b: Batch) -> np.ndarray:
        a, c = (b.kin.points[p].v for p in self.pair)
        return b.per_variant(np.sqrt(((a - c) ** 2).sum(axis=1))) * 1e3

    def compute(self, b: Batch, nominal: Batch, loads: Loads) -> dict[str, np.ndarray]:
        return {self.columns()[0].name: self._d(b).max(axis=1)}

    def curve(self, b: Batch, loads: Loads) -> Curve | None:
        return Curve(f"distance {self.pair[0]}-{self.pair[1]}", "mm", self._d(b))


class Dwell(Metric):
    """Dwell of a point at its extreme: the crank angle over which its coordinate along
    ``axis`` (default as for ``stroke``) stays within ``within`` mm of its highest (``at`` =
    'max', default) or lowest ('min') value over the period, deg of the input crank: the
    contiguous arc around the extreme, its ends interpolated linearly between the samples.
    A hook needle's dwell at the top is the time the guide bars have to lap."""

    kind = "dwell"
    needs_point = True
    options = ("axis", "within", "at")

    def read(self, raw: dict[str, Any]) -> None:
        self.axis = _axis(raw, self.where)
        self.ax = self.axis if self.axis is not None else _main_axis(self.mech, self.point)
        w = raw.get("within")
        if isinstance(w, bool) or not isinstance(w, int | float) or not 0 < w <= MAX_LENGTH_MM:
            raise MetricError(
                f"{self.where}: needs 'within', the band in mm (> 0, at most {MAX_LENGTH_MM:g}), got {shown(w)}"
            )
        self.within = float(w) * 1e-3
        self.at = raw.get("at", "max")
        if self.at not in ("max", "min"):
            raise MetricError(f"{self.where}: 'at' must be 'max' or 'min', got {shown(self.at)}")

    def columns(self) -> list[Column]:
        return [
            Column(
                f"dwell_{self.point}_{self.at}",
                "deg",
                f"dwell of {self.point} within {self.within * 1e3:g} mm of its {self.at}",
            )
        ]

    def compute(self, b: Batch, nominal: Batch, loads: Loads) -> dict[str, np.ndarray]:
        x = _coordinate(b, self.point, self.ax)[0]
        if self.at == "min":
            x = -x
        V, A = x.shape
        j = np.argmax(x, axis=1)
        # Samples in order around the extreme: forward k = 0..A-1 and backward.
        k = np.arange(A)
        r = np.arange(V)[:, None]
        fwd = x[r, (j[:, None] + k) % A]
        bwd = x[r, (j[:, None] - k) % A]
        level = x[np.arange(V), j] - self.within
        out = np.zeros(V)
        for seq in (fwd, bwd):
            inside = seq >= level[:, None]
            n = np.where(inside.all(axis=1), A, np.argmin(inside, axis=1))  # samples inside, from the extreme
            last = seq[np.arange(V), np.maximum(n - 1, 0)]
            nxt = seq[np.arange(V), n % A]
            with np.errstate(all="ignore"):
                frac = np.where(n < A, np.clip((last - level) / (last - nxt), 0.0, 1.0), 0.0)
            out += (n - 1) + frac
        return {self.columns()[0].name: np.minimum(out * np.degrees(_step(b)), np.degrees(b.mechanism.period))}

    def curve(self, b: Batch, loads: Loads) -> Curve | None:
        x = _coordinate(b, self.point, self.ax)[0] * 1e3
        return Curve(f"{'xyz'[self.ax]} of {self.point}", "mm", x)


class PathError(Metric):
    """Path generation: how far a point's path misses given precision points (``targets`` =
    [[x, y], ...] mm, in the plane, no prescribed timing): the RMS over the targets of the
    distance from each target to the nearest of the path's positions at the study's angles,
    mm. A four-bar coupler curve through precision points is the classical problem."""

    kind = "path_error"
    needs_point = True
    options = ("targets",)

    def read(self, raw: dict[str, Any]) -> None:
        t = raw.get("targets")
        try:
            arr = np.array(t, dtype=float)
        except (TypeError, ValueError, OverflowError):
            arr = np.zeros((0,))
        if arr.ndim != 2 or arr.shape[1] != 2 or len(arr) < 1 or not np.all(np.isfinite(arr)):
            raise MetricError(f"{self.where}: 'targets' must be a list of [x, y] points, mm")
        self.targets = arr * 1e-3

    def columns(self) -> list[Column]:
        return [Column(f"path_error_{self.point}", "mm", f"RMS miss of {self.point}'s path at the precision points")]

    def compute(self, b: Batch, nominal: Batch, loads: Loads) -> dict[str, np.ndarray]:
        p = b.kin.points[self.point].v
        px, py = b.per_variant(p[:, 0]), b.per_variant(p[:, 1])
        d2 = np.full((b.variants, len(self.targets)), np.inf)
        for k, (tx, ty) in enumerate(self.targets):
            d2[:, k] = ((px - tx) ** 2 + (py - ty) ** 2).min(axis=1)
        return {self.columns()[0].name: np.sqrt(d2.mean(axis=1)) * 1e3}
