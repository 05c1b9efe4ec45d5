"""What every design metric shares: the :class:`Metric` base (one class per metric, registered
by its ``kind``), its :class:`Column` and :class:`Curve`, the :class:`Loads` several load
metrics compute once, the speed option of the metrics at constant crank speed
(:class:`AtSpeed`) and the helpers over a batch's crank angles. The metrics themselves are in
:mod:`.kinematic_metrics` and :mod:`.load_metrics`; :mod:`.metrics` is their catalogue and the
study side (read, columns, feasibility, compute).
"""

from __future__ import annotations

import math
import re
from abc import ABC, abstractmethod
from collections.abc import Iterator
from contextlib import contextmanager
from contextvars import ContextVar
from dataclasses import dataclass, field
from typing import Any, ClassVar

import numpy as np

from ..errors import InputError, MjlinkError, did_you_mean
from ..model.limits import MAX_SPEED, MIN_SPEED, above, below
from ..model.mechanism import Mechanism
from ..model.reader import shown
from ..reference import kinetostatics
from ..reference.batch import Batch, angle_grid
from ..reference.dynamics import reduced
from ..reference.kinematics import solve

# A study's calibration traces the memory its metrics need (:mod:`mjlink.study.plan`), not their
# values: a metric that steps each variant to a periodic state may step it one cycle instead,
# as what it holds does not grow with the cycles stepped, and tracing every allocation of the
# whole stepping costs many times the stepping.
_PROBING: ContextVar[bool] = ContextVar("mjlink_probing", default=False)


@contextmanager
def probing() -> Iterator[None]:
    """Within it, metrics compute for their memory's sake only (their values not used)."""
    token = _PROBING.set(True)
    try:
        yield
    finally:
        _PROBING.reset(token)


def probed() -> bool:
    """Whether metrics compute within :func:`probing`."""
    return _PROBING.get()


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
    together: ClassVar[int] = 1  # variants a task holds at most for the metric to step them at once
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
                hint = did_you_mean(k, sorted(allowed))
                raise MetricError(f"{where}: unknown key '{k}' ({hint}valid: {', '.join(sorted(allowed))})")
        self.point = ""
        if self.needs_point:
            p = raw.get("point")
            if not isinstance(p, str):
                raise MetricError(f"{where}: needs 'point' (a point of {mech.name})")
            if p not in mech.point_names:
                hint = did_you_mean(p, list(mech.point_names))
                raise MetricError(f"{where}: unknown point '{p}' ({hint}points: {', '.join(mech.point_names)})")
            self.point = p
        self.read(raw)

    @classmethod
    def share(cls, n: int) -> float:
        """The cost of a variant computed in a batch of ``n`` against its cost alone (1: a
        metric whose batches cost their variants' sum; a study's plan scales its calibration,
        run on a few variants, by it to a task's size)."""
        return 1.0

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
        if below(abs(w), MIN_SPEED) or above(abs(w), MAX_SPEED):
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
        peak: np.ndarray = np.where(ok, xv - dv * dv / (2.0 * ddv), xv)
        return peak


def _coordinate(b: Batch, point: str, ax: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(V, A) coordinate ``ax`` of a point with its first and second derivative in phi."""
    p = b.kin.points[point]
    return b.per_variant(p.v[:, ax]), b.per_variant(p.d[:, ax]), b.per_variant(p.dd[:, ax])


def _step(b: Batch) -> float:
    return float(b.theta[1] - b.theta[0]) if b.angles > 1 else 0.0


def _main_axis(mech: Mechanism, point: str) -> int:
    """The axis along which the nominal design's point moves most (over one period)."""

    kin = solve(mech, mech.phi0 + angle_grid(mech, 72), check=False)
    return int(np.argmax(np.ptp(kin.points[point].v, axis=0)))


def _dead_points(b: Batch) -> list[Any]:
    P = b.kin.positions()
    return [d for d in (s.dead_point(P) for s in b.mechanism.steps) if d is not None]


COLUMN_NAME = re.compile(r"[A-Za-z_][A-Za-z0-9_]{0,63}")
"""A column name a designer gives (a motion metric's ``name``, a Python metric's key)."""

TABLE_COLUMNS = ("variant", "feasible", "reason", "within_bounds")
"""Columns every study table has (and every ``mujoco...`` one): no metric may take their names."""


def taken_by_table(name: str) -> bool:
    """Whether ``name`` is one of a study table's own columns."""
    return name in TABLE_COLUMNS or name.startswith("mujoco")


def speed_tag(speed: float) -> str:
    """A column name's speed, as a designer reads it: ``_at_5000rpm`` for 523.6 rad/s (four
    significant digits of rpm; ``m`` for a clockwise speed, ``p`` for a decimal point)."""
    rpm = speed * 60.0 / (2.0 * math.pi)
    text = f"{rpm:.4g}" if abs(rpm) < 1e4 else f"{rpm:.0f}"
    return f"_at_{text}rpm".replace("-", "m").replace(".", "p")


def old_speed_name(name: str) -> str | None:
    """The column a name of the earlier form (``shaking_force_peak_at_523p6rad_s``) now has
    (``shaking_force_peak_at_5000rpm``), or None for a name of another form."""
    m = re.fullmatch(r"(.*)_at_(m?)([0-9]+(?:p[0-9]+)?)rad_s", name)
    if m is None:
        return None
    value = float(m[3].replace("p", "."))
    return m[1] + speed_tag(-value if m[2] else value)


class AtSpeed(Metric):
    """A metric at constant crank speed: its ``speed`` option (rad/s, default the file's), in its
    columns' names when it is not the file's."""

    options: ClassVar[tuple[str, ...]] = ("speed",)
    needs_loads = True

    def read(self, raw: dict[str, Any]) -> None:
        self.speed = self._speed(raw)

    def _tag(self) -> str:
        return "" if self.speed == self.mech.speed else speed_tag(self.speed)

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


def _slug(label: str) -> str:
    return "".join(c if c.isalnum() else "_" for c in label).strip("_")
