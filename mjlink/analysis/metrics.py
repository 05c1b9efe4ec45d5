"""Design metrics: one number per variant, computed from the reference over a batch of variants.

A metric is one class (:class:`Metric`), registered by its ``kind`` (the name a study file
uses); it reads its options from the study file, names its columns with their units, and
computes them for every variant of a :class:`~mjlink.reference.batch.Batch` at once
(arrays of V variants x A crank angles, never a loop over variants). Each column's unit is in
its :class:`Column`; every definition is in the class's docstring (and the studies README).

Feasibility comes first (:func:`feasibility`): a variant that cannot be assembled at every
crank angle of its period, or that passes within the dead-point limits of ``check``
(transmission angle below 20 deg or above 160 deg, pressure angle above 60 deg), is infeasible
with the reason and the crank-angle range; its metrics are NaN, never a number.

Units of the columns: mm, um, deg, N, N*m, W or none, as each says; angles of a period are
sampled uniformly from phi0, the end excluded (a mean over them is the exact cycle mean).
"""

from __future__ import annotations

import difflib
import itertools
import math
from abc import ABC, abstractmethod
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any, ClassVar

import numpy as np

from ..errors import InputError, MjlinkError
from ..model.jet import norms
from ..model.limits import MAX_LENGTH_MM, MAX_PRESSURE_DEG, MAX_SPEED, MIN_SPEED, MIN_TRANSMISSION_DEG
from ..model.mechanism import Mechanism
from ..model.reader import shown
from ..model.topology import pairs
from ..reference import kinetostatics
from ..reference.batch import Batch
from ..reference.dynamics import reduced
from ..reference.kinematics import angle_ranges


class MetricError(MjlinkError):
    """A study file's metric is unknown or badly specified."""


class MetricLimitError(MetricError, InputError):
    """A metric's option beyond one of mjlink's limits (exit status 2)."""


@dataclass(frozen=True)
class Column:
    """A metric's output column: ``name`` (also its CSV header stem), ``unit``, ``label``."""

    name: str
    unit: str
    label: str


@dataclass(frozen=True)
class Curve:
    """The quantity over the cycle whose summary a metric is (for before/after figures):
    ``values`` (V, A) in ``unit`` at the batch's angles; ``target`` (A,) what it should follow
    (a demand table), or None; ``limit`` a level drawn across (a bound, a dwell band), or None."""

    label: str
    unit: str
    values: np.ndarray
    target: np.ndarray | None = None
    target_label: str = ""
    limit: float | None = None


@dataclass
class Loads:
    """What several load metrics share, computed once per batch and speed."""

    torque: dict[float, np.ndarray] = field(default_factory=dict)  # speed -> (V, A) N*m
    reactions: dict[float, kinetostatics.Reactions] = field(default_factory=dict)
    frame: dict[tuple[str, float], Any] = field(default_factory=dict)  # shaking loads by speed


class Metric(ABC):
    """A design metric: options from the study file, columns, values per variant."""

    kind: ClassVar[str]
    types: ClassVar[dict[str, type[Metric]]] = {}
    needs_point: ClassVar[bool] = False
    options: ClassVar[tuple[str, ...]] = ()
    doc: ClassVar[str] = ""
    # Computed from dynamics (kinetostatics, steady motion): rows that do not assemble could
    # make such a batch singular, so their variants are evaluated on a safe stand-in.
    needs_loads: ClassVar[bool] = False

    def __init_subclass__(cls, **kw: Any) -> None:
        super().__init_subclass__(**kw)
        if "kind" in cls.__dict__:  # abstract helpers (shared options) have none
            Metric.types[cls.kind] = cls

    def __init__(self, mech: Mechanism, raw: dict[str, Any], where: str):
        self.mech = mech
        self.where = where
        allowed = {"kind", *self.options} | ({"point"} if self.needs_point else set())
        for k in raw:
            if k not in allowed:
                near = difflib.get_close_matches(k, sorted(allowed), n=1)
                hint = f"did you mean '{near[0]}'? " if near else ""
                raise MetricError(f"{where}: unknown key '{k}' ({hint}valid: {', '.join(sorted(allowed))})")
        self.point = ""
        if self.needs_point:
            p = raw.get("point")
            if not isinstance(p, str):
                raise MetricError(f"{where}: needs 'point' (a point of {mech.name})")
            if p not in mech.point_names:
                near = difflib.get_close_matches(p, list(mech.point_names), n=1)
                hint = f"did you mean '{near[0]}'? " if near else ""
                raise MetricError(f"{where}: unknown point '{p}' ({hint}points: {', '.join(mech.point_names)})")
            self.point = p
        self.read(raw)

    def read(self, raw: dict[str, Any]) -> None:  # noqa: B027 (optional hook)
        """Read the metric's own options (raise MetricError)."""

    @abstractmethod
    def columns(self) -> list[Column]:
        """The columns this metric fills."""

    @abstractmethod
    def compute(self, b: Batch, nominal: Batch, loads: Loads) -> dict[str, np.ndarray]:
        """Column name -> (V,) values (NaN-free for feasible variants)."""

    def curve(self, b: Batch, loads: Loads) -> Curve | None:
        """The metric's quantity over the cycle for every variant (None: it has no such curve)."""
        return None

    def _speed(self, raw: dict[str, Any]) -> float:
        w = raw.get("speed", self.mech.speed)
        try:
            ok = not isinstance(w, bool) and isinstance(w, int | float) and math.isfinite(w) and w != 0
        except OverflowError:  # an integer too large for a float
            raise MetricLimitError(
                f"{self.where}: speed must be {MIN_SPEED:g} to {MAX_SPEED:g} rad/s, got {shown(w)}"
            ) from None
        if not ok:
            raise MetricError(f"{self.where}: speed must be a non-zero number (rad/s), got {shown(w)}")
        if not MIN_SPEED <= abs(w) <= MAX_SPEED:
            raise MetricLimitError(
                f"{self.where}: speed must be {MIN_SPEED:g} to {MAX_SPEED:g} rad/s in magnitude (the limits of a "
                f"file's [input] speed), got {float(w):g}"
            )
        return float(w)


def _axis(raw: dict[str, Any], where: str) -> int | None:
    a = raw.get("axis")
    if a is None:
        return None
    if a not in ("x", "y", "z"):
        raise MetricError(f"{where}: axis must be 'x', 'y' or 'z', got {shown(a)}")
    return "xyz".index(a)


def _peak(x: np.ndarray, d: np.ndarray, dd: np.ndarray, step: float, high: bool) -> np.ndarray:
    """The largest (or smallest) value of each row of (V, A) samples, refined between samples
    with the exact derivatives there (d, dd per unit of the sample spacing's variable): at the
    best sample a Newton step on the derivative gives x - d^2 / (2 dd), the extremum of the
    local parabola, taken if it lies within one spacing ``step``. Sampling alone would miss
    a stroke by up to about 1e-4 of it at 1 deg spacing."""
    j = np.argmax(x, axis=1) if high else np.argmin(x, axis=1)
    r = np.arange(len(x))
    xv, dv, ddv = x[r, j], d[r, j], dd[r, j]
    with np.errstate(all="ignore"):
        h = -dv / ddv
        ok = (np.abs(h) <= step) & ((ddv < 0) if high else (ddv > 0))
        return np.where(ok, xv - dv * dv / (2.0 * ddv), xv)


def _coordinate(b: Batch, point: str, ax: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(V, A) coordinate ``ax`` of a point with its first and second derivative in phi."""
    p = b.kin.points[point]
    return b.per_variant(p.v[:, ax]), b.per_variant(p.d[:, ax]), b.per_variant(p.dd[:, ax])


def _step(b: Batch) -> float:
    return float(b.theta[1] - b.theta[0]) if b.angles > 1 else 0.0


def _main_axis(mech: Mechanism, point: str) -> int:
    """The axis along which the nominal design's point moves most (over one period)."""
    from ..reference.batch import angle_grid
    from ..reference.kinematics import solve

    kin = solve(mech, mech.phi0 + angle_grid(mech, 72), check=False)
    return int(np.argmax(np.ptp(kin.points[point].v, axis=0)))


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
        return lf - lf[:, :1] - (b.mechanism.thread_elongation or 0.0)

    def curve(self, b: Batch, loads: Loads) -> Curve | None:
        demand = np.interp(b.theta, self.angles, self.values, period=b.mechanism.period)
        return Curve("thread feed Pd", "mm", self._pd(b) * 1e3, demand * 1e3, "demand")


# ----------------------------------------------------------------------- transmission
class TransmissionMin(Metric):
    """Minimum transmission angle over the period and every dyad, folded to 0..90 deg
    (min(mu, 180 - mu): 90 is best, 0 a dead point), deg."""

    kind = "transmission_min"

    def columns(self) -> list[Column]:
        return [Column("transmission_min", "deg", "minimum transmission angle")]

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
        return None if worst is None else Curve("smallest transmission angle", "deg", worst)


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


def _dead_points(b: Batch) -> list[Any]:
    P = b.kin.positions()
    return [d for d in (s.dead_point(P) for s in b.mechanism.steps) if d is not None]


# -------------------------------------------------------------------------------- loads
class _AtSpeed(Metric):
    options: ClassVar[tuple[str, ...]] = ("speed",)
    needs_loads = True

    def read(self, raw: dict[str, Any]) -> None:
        self.speed = self._speed(raw)

    def _tag(self) -> str:
        return "" if self.speed == self.mech.speed else f"_at_{self.speed:g}rad_s".replace("-", "m").replace(".", "p")

    def _torque(self, b: Batch, loads: Loads) -> np.ndarray:
        """(V, A) driving torque at constant speed, N*m (the reference's inverse dynamics)."""
        if self.speed not in loads.torque:
            red = reduced(b.mechanism, b.kin)
            w = self.speed
            tau = 0.5 * red.dJ * w**2 + b.mechanism.dynamics.damping * w - red.Q
            loads.torque[self.speed] = b.per_variant(np.broadcast_to(tau, b.kin.phi.shape))
        return loads.torque[self.speed]

    def _reactions(self, b: Batch, loads: Loads) -> kinetostatics.Reactions:
        if self.speed not in loads.reactions:
            loads.reactions[self.speed] = kinetostatics.reactions(b.mechanism, b.kin.phi, self.speed, kin=b.kin)
        return loads.reactions[self.speed]


class TorquePeak(_AtSpeed):
    """Peak driving torque at constant crank speed (``speed`` rad/s, default the file's
    [input] speed): max |tau| over the period, N*m."""

    kind = "torque_peak"

    def columns(self) -> list[Column]:
        return [Column("torque_peak" + self._tag(), "N*m", "peak driving torque")]

    def compute(self, b: Batch, nominal: Batch, loads: Loads) -> dict[str, np.ndarray]:
        return {self.columns()[0].name: np.abs(self._torque(b, loads)).max(axis=1)}

    def curve(self, b: Batch, loads: Loads) -> Curve | None:
        return Curve(f"driving torque at {self.speed:g} rad/s", "N*m", self._torque(b, loads))


class TorqueRms(_AtSpeed):
    """RMS driving torque at constant crank speed over the period, N*m."""

    kind = "torque_rms"

    def columns(self) -> list[Column]:
        return [Column("torque_rms" + self._tag(), "N*m", "RMS driving torque")]

    def compute(self, b: Batch, nominal: Batch, loads: Loads) -> dict[str, np.ndarray]:
        return {self.columns()[0].name: np.sqrt((self._torque(b, loads) ** 2).mean(axis=1))}


class PowerMean(_AtSpeed):
    """Mean driving power at constant crank speed, the period mean of tau * omega, W."""

    kind = "power_mean"

    def columns(self) -> list[Column]:
        return [Column("power_mean" + self._tag(), "W", "mean driving power")]

    def compute(self, b: Batch, nominal: Batch, loads: Loads) -> dict[str, np.ndarray]:
        return {self.columns()[0].name: self._torque(b, loads).mean(axis=1) * self.speed}


class ReactionPeak(_AtSpeed):
    """Peak reaction in every kinematic pair at constant crank speed: max over the period of
    the force's magnitude (for a prismatic pair its normal force), N. One column per pair,
    ``reaction_peak_<pair>`` (pair label as in ``reactions``)."""

    kind = "reaction_peak"

    def columns(self) -> list[Column]:
        return [
            Column(f"reaction_peak_{_slug(pr.label)}" + self._tag(), "N", f"peak reaction {pr.label}")
            for _, pr in pairs(self.mech)
        ]

    def compute(self, b: Batch, nominal: Batch, loads: Loads) -> dict[str, np.ndarray]:
        r = self._reactions(b, loads)
        out = {}
        for col, (_, pr) in zip(self.columns(), pairs(self.mech), strict=True):
            f = r.forces[pr.label]
            out[col.name] = b.per_variant(np.sqrt((f**2).sum(axis=1))).max(axis=1)
        return out


class _Shaking(_AtSpeed):
    def _loads(self, b: Batch, loads: Loads) -> Any:
        from ..reference.batch import frame_loads

        key = ("frame", self.speed)
        if key not in loads.frame:
            loads.frame[key] = frame_loads(b.mechanism, b.kin, self.speed)
        return loads.frame[key]


class _FramePeak(_Shaking):
    """The peak over the period of one of the frame's loads (a field of
    :class:`mjlink.reference.batch.FrameLoads`: ``part``), a force's magnitude or a moment's
    absolute value."""

    part: ClassVar[str]
    unit: ClassVar[str]
    label: ClassVar[str]

    def columns(self) -> list[Column]:
        return [Column(self.kind + self._tag(), self.unit, f"peak {self.label}")]

    def _q(self, b: Batch, loads: Loads) -> np.ndarray:
        q = getattr(self._loads(b, loads), self.part)
        return b.per_variant(norms(q) if q.ndim == 2 else q)

    def compute(self, b: Batch, nominal: Batch, loads: Loads) -> dict[str, np.ndarray]:
        return {self.columns()[0].name: np.abs(self._q(b, loads)).max(axis=1)}

    def curve(self, b: Batch, loads: Loads) -> Curve | None:
        return Curve(f"{self.label} at {self.speed:g} rad/s", self.unit, self._q(b, loads))


class ShakingForcePeak(_FramePeak):
    """Peak shaking force at constant crank speed: max over the period of |F_s|, F_s = -sum_i
    m_i a_Si the resultant of the links' inertia forces (the counterweight's included), N. It
    is what balancing acts on: zero for a balanced mechanism at any speed. Gravity and the
    file's point forces are not in it (``frame_force_peak``, ``gravity_load``;
    :class:`mjlink.reference.batch.FrameLoads`)."""

    kind = "shaking_force_peak"
    part, unit, label = "inertia_force", "N", "shaking force |F_s| (inertia)"


class ShakingMomentPeak(_FramePeak):
    """Peak shaking moment at constant crank speed: max over the period of |M_s|, M_s = sum_i
    [r_Si x (-m_i a_Si) - J_Si alpha_i] about the input crank's pivot (the inertia forces' and
    moments' moment), N*m. Gravity's and the point forces' moments are in
    ``frame_moment_peak``."""

    kind = "shaking_moment_peak"
    part, unit, label = "inertia_moment", "N*m", "shaking moment (inertia)"


class FrameForcePeak(_FramePeak):
    """Peak force on the frame at constant crank speed: max over the period of |F|, F = sum_i
    m_i (g - a_Si) + the file's point forces, the resultant of every ground pair's reaction on
    the frame (what its mounts carry: the shaking force, the gravity load and the point
    forces together), N."""

    kind = "frame_force_peak"
    part, unit, label = "force", "N", "force on the frame |F| (inertia, gravity, forces)"


class FrameMomentPeak(_FramePeak):
    """Peak moment on the frame at constant crank speed: max over the period of |M|, M about the
    input crank's pivot from the inertia, gravity and the point forces, the drive's reaction
    included (:class:`mjlink.reference.batch.FrameLoads`), N*m."""

    kind = "frame_moment_peak"
    part, unit, label = "moment", "N*m", "moment on the frame"


class GravityLoad(Metric):
    """The gravity load on the frame, |sum_i m_i g| (the links' and counterweight's weight), N:
    the same at every crank angle and speed."""

    kind = "gravity_load"

    def columns(self) -> list[Column]:
        return [Column("gravity_load", "N", "gravity load on the frame")]

    def compute(self, b: Batch, nominal: Batch, loads: Loads) -> dict[str, np.ndarray]:
        from ..reference.batch import frame_loads

        fl = frame_loads(b.mechanism, b.kin, 0.0)
        assert fl.gravity_force is not None
        return {"gravity_load": b.per_variant(norms(fl.gravity_force)).max(axis=1)}


# ------------------------------------------------------------------------ motion quality
def _points(mech: Mechanism, raw: Any, where: str, n: int) -> tuple[str, ...]:
    if not isinstance(raw, list) or len(raw) != n or not all(isinstance(p, str) for p in raw):
        raise MetricError(f"{where}: 'points' must be a list of {n} point names")
    for p in raw:
        if p not in mech.point_names:
            near = difflib.get_close_matches(p, list(mech.point_names), n=1)
            hint = f"did you mean '{near[0]}'? " if near else ""
            raise MetricError(f"{where}: unknown point '{p}' ({hint}points: {', '.join(mech.point_names)})")
    return tuple(raw)


class AccelerationPeak(_AtSpeed):
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


class SpeedFluctuation(Metric):
    """Coefficient of speed fluctuation delta = (omega_max - omega_min) / omega_mean of the
    periodic steady motion under the file's drive (its ``[steady]`` motor, else its
    ``[dynamics.motor]``, with its damping), dimensionless (see
    :func:`mjlink.reference.batch.steady_delta`)."""

    kind = "speed_fluctuation"
    needs_loads = True

    def read(self, raw: dict[str, Any]) -> None:
        if self.mech.steady is None and self.mech.dynamics.motor is None:
            raise MetricError(
                f"{self.where}: {self.mech.name} has no drive characteristic ([steady] or [dynamics.motor])"
            )

    def columns(self) -> list[Column]:
        return [Column("delta", "", "coefficient of speed fluctuation")]

    def compute(self, b: Batch, nominal: Batch, loads: Loads) -> dict[str, np.ndarray]:
        from ..reference.batch import steady_delta

        return {"delta": steady_delta(b)}


def _slug(label: str) -> str:
    return "".join(c if c.isalnum() else "_" for c in label).strip("_")


# --------------------------------------------------------------------------- the study side
def read(mech: Mechanism, raw: Any, i: int) -> Metric:
    """The ``i``-th ``[[metric]]`` table of a study file, or a one-line MetricError."""
    where = f"[[metric]] #{i + 1}"
    if not isinstance(raw, dict):
        raise MetricError(f"{where}: must be a table")
    kind = raw.get("kind")
    if not isinstance(kind, str):
        raise MetricError(f"{where}: needs 'kind' (one of {', '.join(Metric.types)})")
    if kind not in Metric.types:
        near = difflib.get_close_matches(kind, list(Metric.types), n=1)
        hint = f"did you mean '{near[0]}'? " if near else ""
        raise MetricError(f"{where}: unknown metric '{kind}' ({hint}valid: {', '.join(Metric.types)})")
    return Metric.types[kind](mech, raw, f"{where} ({kind})")


@dataclass(frozen=True)
class Feasibility:
    """Per variant: ``feasible`` (V,) bool and ``reason`` ('' where feasible)."""

    feasible: np.ndarray
    reason: tuple[str, ...]


def feasibility(b: Batch) -> Feasibility:
    """Which variants assemble over the whole period and keep clear of dead points.

    A variant is infeasible where its values make no mechanism (``b.invalid``), where a block
    cannot close at some crank angle (reason names the block and the angle ranges, deg from
    the variant's phi0), or where a dyad's transmission angle leaves 20..160 deg or a slider's
    pressure angle exceeds 60 deg (the limits within which ``check`` accepts a mechanism).
    """
    V = b.variants
    reason = list(b.invalid)
    theta = b.theta
    steps = {s.point: s for s in b.mechanism.steps}
    for point, margin in b.kin.margins.items():
        bad = b.per_variant(~(margin >= 0.0))
        for i in np.flatnonzero(bad.any(axis=1)):
            if not reason[i]:
                reason[i] = f"{steps[point].named()} cannot close at {angle_ranges(theta, bad[i])} deg from phi0"
    P = b.kin.positions()
    for s in b.mechanism.steps:
        dp = s.dead_point(P)
        if dp is None:
            continue
        near = b.per_variant(~(dp.margin_deg >= dp.required_margin_deg))
        value = b.per_variant(dp.value_deg)
        for i in np.flatnonzero(near.any(axis=1)):
            if not reason[i]:
                j = int(np.argmax(np.where(near[i], 90.0 - b.per_variant(dp.margin_deg)[i], -np.inf)))
                limit = (
                    f"{MIN_TRANSMISSION_DEG:g}..{180 - MIN_TRANSMISSION_DEG:g} deg"
                    if dp.quantity == "transmission angle"
                    else f"{MAX_PRESSURE_DEG:g} deg"
                )
                reason[i] = (
                    f"{s.named()} passes a dead point: {dp.quantity} {value[i, j]:.1f} deg (limit {limit}) "
                    f"at {angle_ranges(theta, near[i])} deg from phi0"
                )
    feasible = np.array([not r for r in reason], dtype=bool)
    assert len(feasible) == V
    return Feasibility(feasible, tuple(reason))


def compute(metrics: Sequence[Metric], b: Batch, nominal: Batch) -> dict[str, np.ndarray]:
    """Every metric's columns for every variant of ``b`` ((V,) each); ``nominal`` is the
    nominal design's batch (one variant) at the same angles."""
    loads = Loads()
    out: dict[str, np.ndarray] = {}
    with np.errstate(all="ignore"):
        for m in metrics:
            out.update(m.compute(b, nominal, loads))
    return out


def columns(metrics: Sequence[Metric]) -> list[Column]:
    """Every metric's columns, in order; a name used twice is a MetricError."""
    cols = list(itertools.chain.from_iterable(m.columns() for m in metrics))
    seen: set[str] = set()
    for c in cols:
        if c.name in seen:
            raise MetricError(f"[[metric]]: column '{c.name}' is computed twice (two identical metrics)")
        seen.add(c.name)
    return cols
