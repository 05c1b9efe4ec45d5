"""A designer's own motion metric: a point's position, velocity, acceleration or jerk (along an
axis or as a magnitude), a link's angle, angular velocity, angular acceleration or velocity
ratio to the input crank, or a dyad's transmission or a slider's pressure angle, taken as its
peak, RMS, range, largest or smallest value over the period, or as its value at an event of
the cycle.

::

    [[metric]]
    kind = "motion"
    name = "penetration_velocity"        # the column's name (optional)
    point = "NT"                         # or link = "lever", or block = "P3"
    quantity = "velocity"                # position (mm), velocity, acceleration, jerk (SI)
    axis = "y"                           # x, y or z; without it the vector's magnitude
    event = { point = "NT", height = -98.5, direction = "down" }   # or statistic = "peak"

A link's angle is its direction in the plane (deg), continuous over the period from its value
at the setting in -180..180; at an event, as the link stands (-180..180). A link that turns
fully has no largest or smallest angle: its statistics are NaN.

Events (``event``, a table; without one, ``statistic``):

* a point crossing a height along an axis (``height`` mm, default axis y) or another point's
  height (``height_of``), in a ``direction`` (``up`` or ``down``, in time: the sense of the
  crank's rotation is taken into account); the first such crossing from the crank's setting.
  With ``from = "min"`` (or ``"max"``) the height is measured from the point's own lowest (or
  highest) coordinate over the cycle: the fabric's top 12.5 mm above the needle point's bottom
  dead centre, wherever a variant puts that centre;
* an extreme of a point's coordinate (``extreme`` = ``max`` or ``min``), e.g. the needle bar's
  bottom dead centre; or of another quantity (``quantity``): a point's velocity, acceleration
  or jerk along ``axis`` (without one, the magnitude's), or a link's (``link``) angle, angular
  velocity, angular acceleration or velocity ratio, e.g. ``{ point = "NT", quantity =
  "velocity", axis = "y", extreme = "min" }``, the instant the needle falls fastest;
* a crank angle (``angle`` deg, the input crank's absolute angle as the file's ``phi0``).

How it is exact: a linkage driven by a crank moves analytically in the crank angle, so its
samples over one period (uniform, the end excluded) define its trigonometric interpolant to
near machine precision. Events and extremes are found on that interpolant by Newton's method
from the bracketing samples (its derivative spectral), the value at the event is the
interpolant there, and the jerk is the spectral derivative of the exact acceleration. Velocity
and acceleration come from the reference's exact derivatives, at constant crank speed
(``speed``, default the file's). ``tests/test_motion.py`` checks each against a plain solution
(a scalar root of the reference's position, closed forms of the crank-slider).

A variant in which the event does not happen (the needle never reaches that height) gets NaN:
an optimization counts it infeasible, a study's table shows it empty.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any, ClassVar

import numpy as np

from ..model.reader import shown
from ..reference.batch import Batch
from .metric_base import COLUMN_NAME, AtSpeed, Column, Curve, Loads, MetricError, taken_by_table

POINT = {"position": "mm", "velocity": "m/s", "acceleration": "m/s^2", "jerk": "m/s^3"}
LINK = {"angle": "deg", "angular_velocity": "rad/s", "angular_acceleration": "rad/s^2", "velocity_ratio": ""}
TIMED = ("velocity", "acceleration", "jerk", "angular_velocity", "angular_acceleration")  # depend on the speed
STATISTICS = ("peak", "rms", "range", "max", "min")
_EVENT_KEYS = ("point", "link", "quantity", "axis", "height", "from", "height_of", "direction", "extreme", "angle")
_NEWTON = 8  # iterations: quadratic convergence from a bracket one sample wide


@dataclass(frozen=True, kw_only=True)
class Event:
    """An instant of the cycle: a crossing (``height`` m, from ``origin`` 'min'/'max' of the
    point's own coordinate where given, or ``height_of``; ``direction`` +1 up, -1 down), an
    ``extreme`` ('max'/'min') of ``point``'s coordinate ``axis`` or of another ``quantity`` of
    ``point`` (along ``axis``, None: its magnitude) or of ``link``, or a crank ``angle`` (rad,
    absolute)."""

    point: str = ""
    axis: int | None = 1
    height: float | None = None
    origin: str = ""
    height_of: str = ""
    direction: int = 0
    extreme: str = ""
    angle: float | None = None
    link: str = ""
    quantity: str = "position"

    def tag(self) -> str:
        if self.angle is not None:
            return f"at_{math.degrees(self.angle):g}deg".replace("-", "m").replace(".", "p")
        ax = "" if self.axis is None else "xyz"[self.axis]
        if self.extreme and self.quantity != "position":
            return f"at_{self.point or self.link}_{self.quantity}{'_' + ax if ax else ''}_{self.extreme}"
        if self.extreme:
            return f"at_{self.point}_{ax}_{self.extreme}"
        to = self.height_of or f"{self.height * 1e3:g}mm".replace("-", "m").replace(".", "p")  # type: ignore[operator]
        if self.origin:
            to += f"_from_{self.origin}"
        return f"at_{self.point}_{ax}_{'up' if self.direction > 0 else 'down'}_{to}"


class Motion(AtSpeed):
    """The motion of a point, a link or a block at constant crank speed, taken as ``statistic``
    (peak: largest magnitude; rms; range; max; min) over the period or at ``event`` (module
    doc). A point's position (mm), velocity (m/s), acceleration (m/s^2) or jerk (m/s^3), along
    ``axis`` or as the vector's magnitude; a link's angle (deg), angular velocity (rad/s),
    angular acceleration (rad/s^2) or velocity ratio to the input crank (-); a dyad's
    transmission angle or a slider's pressure angle (deg), named by the block's point."""

    kind = "motion"
    needs_loads = False
    options: ClassVar[tuple[str, ...]] = (
        "point",
        "link",
        "block",
        "speed",
        "quantity",
        "axis",
        "statistic",
        "event",
        "name",
    )

    def read(self, raw: dict[str, Any]) -> None:
        super().read(raw)
        subject = [k for k in ("point", "link", "block") if k in raw]
        if len(subject) != 1:
            raise MetricError(
                f"{self.where}: needs exactly one of point (its position, velocity, acceleration, jerk), link "
                "(its angle, angular velocity, angular acceleration, velocity ratio) or block (a dyad's or a "
                f"slider's point: its transmission or pressure angle), got {', '.join(subject) or 'none'}"
            )
        self.subject = subject[0]
        self.link = self.block = ""
        q = raw.get("quantity")
        if self.subject == "point":
            self._point(raw["point"], f"{self.where}: point")
            self.point = raw["point"]
            table = POINT
        elif self.subject == "link":
            links = [l.name for l in self.mech.links]
            if raw["link"] not in links:
                raise MetricError(
                    f"{self.where}: link {shown(raw['link'])} is not a link of {self.mech.name} (links: {', '.join(links)})"
                )
            self.link = raw["link"]
            table = LINK
        else:
            blocks = {s.point: s.kind for s in self.mech.steps if s.kind in ("dyad", "slider")}
            if not isinstance(raw["block"], str) or raw["block"] not in blocks:
                raise MetricError(
                    f"{self.where}: block {shown(raw['block'])} is not a dyad's or a slider's point of "
                    f"{self.mech.name} (blocks: {', '.join(blocks) or 'none'})"
                )
            self.block = raw["block"]
            own = "transmission_angle" if blocks[self.block] == "dyad" else "pressure_angle"
            q = own if q is None else q
            if q != own:
                raise MetricError(
                    f"{self.where}: block {self.block} is a {blocks[self.block]}: its quantity is {own}, got {shown(q)}"
                )
            table = {own: "deg"}
        if not isinstance(q, str) or q not in table:
            raise MetricError(
                f"{self.where}: a {self.subject}'s quantity must be one of {', '.join(table)}, got {shown(q)}"
            )
        self.quantity = str(q)
        self.unit = table[self.quantity]
        if self.subject != "point" and "axis" in raw:
            raise MetricError(f"{self.where}: a {self.subject}'s {self.quantity} takes no axis")
        self.axis = _axis(raw.get("axis"), f"{self.where}: axis", default=None)
        if self.quantity == "position" and self.axis is None:
            raise MetricError(
                f"{self.where}: a position needs an axis (x, y or z): its magnitude would depend on where the origin is"
            )
        if "event" in raw and "statistic" in raw:
            raise MetricError(f"{self.where}: give either 'statistic' or 'event', not both")
        self.event = self._event(raw["event"]) if "event" in raw else None
        stat = raw.get("statistic", "peak")
        if self.event is None and stat not in STATISTICS:
            raise MetricError(f"{self.where}: statistic must be one of {', '.join(STATISTICS)}, got {shown(stat)}")
        self.statistic = "" if self.event is not None else str(stat)
        name = raw.get("name")
        if name is not None and not (isinstance(name, str) and COLUMN_NAME.fullmatch(name)):
            raise MetricError(
                f"{self.where}: name must be a column name of letters, digits and '_' (not first a digit), "
                f"at most 64 characters, got {shown(name)}"
            )
        if isinstance(name, str) and taken_by_table(name):
            raise MetricError(f"{self.where}: name '{name}' is a column every study table has; choose another")
        ax = "" if self.axis is None else "_" + "xyz"[self.axis]
        how = self.event.tag() if self.event is not None else self.statistic
        timed = self.quantity in TIMED
        self.name = name or f"{self.quantity}{ax}_{self.point or self.link or self.block}_{how}" + (
            self._tag() if timed else ""
        )

    def _event(self, raw: Any) -> Event:
        where = f"{self.where}: event"
        if not isinstance(raw, dict):
            raise MetricError(f'{where} must be a table, e.g. {{ point = "NT", height = -98.5, direction = "down" }}')
        for k in raw:
            if k not in _EVENT_KEYS:
                raise MetricError(f"{where}: unknown key '{k}' (valid: {', '.join(_EVENT_KEYS)})")
        kinds = [k for k in ("height", "height_of", "extreme", "angle") if k in raw]
        if len(kinds) != 1:
            raise MetricError(
                f"{where} needs exactly one of height (mm), height_of (a point), extreme (max/min) or angle "
                f"(deg), got {', '.join(kinds) or 'none'}"
            )
        if "from" in raw and "height" not in raw:
            raise MetricError(f"{where}: 'from' measures a height (mm) from the point's own min or max; give height")
        origin = raw.get("from", "")
        if origin not in ("", "min", "max"):
            raise MetricError(
                f"{where} from must be 'min' or 'max' (the point's own lowest or highest coordinate), got {shown(origin)}"
            )
        if "angle" in raw:
            extra = [k for k in raw if k != "angle"]
            if extra:
                raise MetricError(f"{where}: a crank angle takes no {', '.join(extra)}")
            return Event(angle=math.radians(_number(raw["angle"], f"{where} angle", 1e6)))
        if ("link" in raw or ("quantity" in raw and raw["quantity"] != "position")) and "extreme" not in raw:
            raise MetricError(
                f"{where}: a link or a quantity other than a point's position names an extreme "
                "(extreme = 'max' or 'min'); a crossing is a point's height"
            )
        if "link" in raw:
            return self._link_extreme(raw, where)
        point = raw.get("point", self.point)
        if not point:
            raise MetricError(
                f"{where} needs its point or link (a {self.subject}'s event is a point's crossing, or an extreme "
                "of a point's or a link's quantity)"
            )
        self._point(point, f"{where} point")
        q = raw.get("quantity", "position")
        if not isinstance(q, str) or q not in POINT:
            raise MetricError(f"{where} quantity: a point's must be one of {', '.join(POINT)}, got {shown(q)}")
        # A coordinate is along y unless told; another quantity without an axis is its magnitude.
        axis = _axis(raw.get("axis"), f"{where} axis", default=1 if q == "position" else None)
        if "extreme" in raw:
            self._extreme(raw, where)
            return Event(point=point, axis=axis, extreme=raw["extreme"], quantity=str(q))
        assert axis is not None
        d = raw.get("direction")
        if d not in ("up", "down"):
            raise MetricError(
                f"{where} direction must be 'up' or 'down' (along +{'xyz'[axis]} or against it), got {shown(d)}"
            )
        if "height_of" in raw:
            self._point(raw["height_of"], f"{where} height_of")
            if raw["height_of"] == point:
                raise MetricError(f"{where}: a point cannot cross its own height")
            return Event(point=point, axis=axis, height_of=raw["height_of"], direction=1 if d == "up" else -1)
        h = _number(raw["height"], f"{where} height", 1e6) * 1e-3
        return Event(point=point, axis=axis, height=h, origin=origin, direction=1 if d == "up" else -1)

    @staticmethod
    def _extreme(raw: dict[str, Any], where: str) -> None:
        if raw["extreme"] not in ("max", "min"):
            raise MetricError(f"{where} extreme must be 'max' or 'min', got {shown(raw['extreme'])}")
        if "direction" in raw:
            raise MetricError(f"{where}: an extreme takes no direction")

    def _link_extreme(self, raw: dict[str, Any], where: str) -> Event:
        links = [l.name for l in self.mech.links]
        if not isinstance(raw["link"], str) or raw["link"] not in links:
            raise MetricError(
                f"{where} link: {shown(raw['link'])} is not a link of {self.mech.name} (links: {', '.join(links)})"
            )
        extra = [k for k in raw if k not in ("link", "quantity", "extreme")]
        if extra:
            raise MetricError(f"{where}: a link's extreme takes no {', '.join(extra)}")
        q = raw.get("quantity", "angle")
        if not isinstance(q, str) or q not in LINK:
            raise MetricError(f"{where} quantity: a link's must be one of {', '.join(LINK)}, got {shown(q)}")
        self._extreme(raw, where)
        return Event(link=raw["link"], axis=None, extreme=raw["extreme"], quantity=str(q))

    def _point(self, p: Any, where: str) -> None:
        if not isinstance(p, str) or p not in self.mech.point_names:
            raise MetricError(
                f"{where}: {shown(p)} is not a point of {self.mech.name} (points: {', '.join(self.mech.point_names)})"
            )

    def _what(self) -> str:
        if self.subject == "point":
            return f"{self.quantity} {'|.|' if self.axis is None else 'xyz'[self.axis]} of {self.point}"
        return f"{self.quantity.replace('_', ' ')} of {self.link or self.block}"

    def columns(self) -> list[Column]:
        how = f"at {self.event.tag()[3:]}" if self.event is not None else self.statistic
        return [Column(self.name, self.unit, f"{self._what()}, {how}")]

    # -- the quantity over the cycle ----------------------------------------------------------
    def _components(self, b: Batch) -> np.ndarray:
        """(V, A, C) the metric's quantity's components (:meth:`_of`)."""
        return self._of(b, self.subject, self.point or self.link or self.block, self.quantity, self.axis)

    def _of(self, b: Batch, subject: str, name: str, quantity: str, axis: int | None) -> np.ndarray:
        """(V, A, C) the components of ``quantity`` of the ``subject`` ('point', 'link' or
        'block') ``name`` (C = 1 along ``axis`` or for a link's or block's angle, 3 for a
        magnitude); a link's angle with its turns taken out (:meth:`_turns`)."""
        rows = b.variants * b.angles
        w = self.speed
        if subject == "block":
            step = next(s for s in b.mechanism.steps if s.point == name)
            dp = step.dead_point(b.kin.positions())
            assert dp is not None
            return b.per_variant(np.broadcast_to(dp.value_deg, (rows,)))[:, :, None]
        if subject == "link":
            a = b.kin.angles[name]
            if quantity == "angle":
                u = np.unwrap(b.per_variant(np.broadcast_to(a.v, (rows,))), axis=1)
                out: np.ndarray = u - self._turns(u)[:, None] * 2.0 * math.pi * b.theta[None, :] / _period(b)
                return out[:, :, None]
            q = {"angular_velocity": a.d * w, "angular_acceleration": a.dd * w * w, "velocity_ratio": a.d}[quantity]
            return b.per_variant(np.broadcast_to(q, (rows,)))[:, :, None]
        p = b.kin.points[name]
        if quantity == "position":
            q = p.v * 1e3
        elif quantity == "velocity":
            q = p.d * w
        else:
            q = p.dd * w * w
        q = b.per_variant(np.broadcast_to(q, (rows, 3)))
        if quantity == "jerk":  # d/dt = omega d/dphi of the exact acceleration
            q = _derivative(q, _period(b), axis=1) * w
        return q if axis is None else q[:, :, axis : axis + 1]

    @staticmethod
    def _turns(u: np.ndarray) -> np.ndarray:
        """(V,) whole turns a link makes over the period, from its unwrapped angle samples (V, A)."""
        last = np.angle(np.exp(1j * (u[:, 0] - u[:, -1])))  # the step from the last sample back to the first
        turns: np.ndarray = np.round((u[:, -1] + last - u[:, 0]) / (2.0 * math.pi))
        return turns

    def _signal(self, c: np.ndarray) -> np.ndarray:
        return c[..., 0] if c.shape[-1] == 1 else np.sqrt((c * c).sum(axis=-1))

    def compute(self, b: Batch, nominal: Batch, loads: Loads) -> dict[str, np.ndarray]:
        c = self._components(b)
        T = _period(b)
        angle = self.subject == "link" and self.quantity == "angle"
        turns = (
            self._turns(
                np.unwrap(b.per_variant(np.broadcast_to(b.kin.angles[self.link].v, (b.variants * b.angles,))), axis=1)
            )
            if angle
            else None
        )
        if self.event is not None:
            t = self._instant(b, self.event)
            ok = np.isfinite(t)
            t = np.where(ok, t, 0.0)
            value = self._signal(_evaluate(np.fft.rfft(c, axis=1), T, t, b.angles))
            if turns is not None:  # the turns back, then the angle as the link stands: -180..180 deg
                value = np.degrees(np.angle(np.exp(1j * (value + turns * 2.0 * math.pi * t / T))))
            return {self.name: np.where(ok, value, np.nan)}
        s = self._signal(c)
        if turns is not None:
            # A link's angle over the period, continuous from its value at the setting (in
            # -180..180 deg); a link that turns has no such extremes: NaN.
            s = np.degrees(s - s[:, :1] + np.angle(np.exp(1j * s[:, :1])))
        if self.statistic == "rms":
            value = np.sqrt((s * s).mean(axis=1))
        elif c.shape[-1] > 1:
            # A magnitude's extremes from its square's, which is as smooth as the components:
            # the magnitude itself has a kink wherever it passes through nought, and its
            # interpolant rings there over the whole period.
            q = (c * c).sum(axis=-1)
            spec = np.fft.rfft(q, axis=1)
            hi = np.sqrt(np.maximum(_extreme(spec, q, T, True), 0.0))
            lo = np.sqrt(np.maximum(_extreme(spec, q, T, False), 0.0))
            value = {"max": hi, "min": lo, "range": hi - lo, "peak": hi}[self.statistic]
        else:
            spec = np.fft.rfft(s, axis=1)
            hi, lo = _extreme(spec, s, T, True), _extreme(spec, s, T, False)
            value = {"max": hi, "min": lo, "range": hi - lo, "peak": np.maximum(np.abs(hi), np.abs(lo))}[self.statistic]
        return {self.name: value if turns is None else np.where(turns == 0, value, np.nan)}

    def curve(self, b: Batch, loads: Loads) -> Curve | None:
        return Curve(self._what(), self.unit, self._signal(self._components(b)))

    # -- events --------------------------------------------------------------------------------
    def _instant(self, b: Batch, ev: Event) -> np.ndarray:
        """(V,) the event's angle from each variant's phi0 (rad, in [0, period)), NaN where the
        variant's cycle has none."""
        T = _period(b)
        if ev.angle is not None:
            phi0 = b.per_variant(np.broadcast_to(b.kin.phi, (b.variants * b.angles,)))[:, 0]
            return np.mod(ev.angle - phi0, T)
        if ev.extreme and (ev.link or ev.quantity != "position"):
            subject, name = ("link", ev.link) if ev.link else ("point", ev.point)
            c = self._of(b, subject, name, ev.quantity, ev.axis)
            q = c[..., 0] if c.shape[-1] == 1 else (c * c).sum(axis=-1)  # a magnitude's square: smooth
            t = _argextreme(np.fft.rfft(q, axis=1), q, T, ev.extreme == "max")
            if ev.link and ev.quantity == "angle":  # a link that turns fully has no extreme angle
                rows = b.variants * b.angles
                u = np.unwrap(b.per_variant(np.broadcast_to(b.kin.angles[ev.link].v, (rows,))), axis=1)
                t = np.where(self._turns(u) == 0, t, np.nan)
            return t
        assert ev.axis is not None
        y = b.per_variant(np.broadcast_to(b.kin.points[ev.point].v, (b.variants * b.angles, 3)))[:, :, ev.axis]
        if ev.extreme:
            spec = np.fft.rfft(y, axis=1)
            return _argextreme(spec, y, T, ev.extreme == "max")
        if ev.height_of:
            other = b.per_variant(np.broadcast_to(b.kin.points[ev.height_of].v, (b.variants * b.angles, 3)))
            e = y - other[:, :, ev.axis]
        else:
            assert ev.height is not None
            e = y - ev.height
            if ev.origin:
                # From the point's own extreme, refined between samples as the extreme metrics are.
                e = e - _extreme(np.fft.rfft(y, axis=1), y, T, ev.origin == "max")[:, None]
        # Time runs with the batch's angles for a crank turning counter-clockwise, against them
        # for one turning clockwise: "up" in time is then falling along the angles.
        ahead = self.speed > 0
        return _crossing(e, T, rising=(ev.direction > 0) == ahead, ahead=ahead)


# ---------------------------------------------------------------------- spectral machinery
def _period(b: Batch) -> float:
    return float(b.theta[1] - b.theta[0]) * b.angles if b.angles > 1 else 2.0 * math.pi


def _weights(A: int, K: int) -> np.ndarray:
    """Real-series weights of the rfft coefficients: 1 for the mean (and an even count's
    Nyquist term, which has no partner), 2 for the others."""
    w = np.full(K, 2.0)
    w[0] = 1.0
    if A % 2 == 0:
        w[-1] = 1.0
    return w / A


def _evaluate(spec: np.ndarray, T: float, t: np.ndarray, A: int, order: int = 0) -> np.ndarray:
    """The trigonometric interpolant (or its ``order``-th derivative) of each row of samples at
    its own instant: ``spec`` (V, K, ...) rfft along axis 1, ``t`` (V,) rad from the first
    sample; returns (V, ...)."""
    K = spec.shape[1]
    k = 2.0 * math.pi * np.arange(K) / T
    w = _weights(A, K) * (1j * k) ** order
    if A % 2 == 0 and order % 2 == 1:
        w[-1] = 0.0  # the Nyquist cosine's derivative vanishes at every sample: leave it out
    phase = np.exp(1j * np.outer(t, k)) * w  # (V, K)
    return np.real(np.einsum("vk,vk...->v...", phase, spec))


def _derivative(q: np.ndarray, T: float, axis: int) -> np.ndarray:
    """The spectral derivative of periodic samples along ``axis``."""
    A = q.shape[axis]
    spec = np.fft.rfft(q, axis=axis)
    k = 2.0 * math.pi * np.arange(spec.shape[axis]) / T
    if A % 2 == 0:
        k[-1] = 0.0
    shape = [1] * q.ndim
    shape[axis] = len(k)
    return np.fft.irfft(spec * (1j * k).reshape(shape), n=A, axis=axis)


def _newton(
    spec: np.ndarray, T: float, t: np.ndarray, A: int, lo: np.ndarray, hi: np.ndarray, order: int
) -> np.ndarray:
    """Roots of the interpolant's ``order``-th derivative from ``t``, kept within [lo, hi]."""
    for _ in range(_NEWTON):
        f = _evaluate(spec, T, t, A, order)
        df = _evaluate(spec, T, t, A, order + 1)
        with np.errstate(all="ignore"):
            t = np.clip(np.where(df != 0, t - f / df, t), lo, hi)
    return t


def _argextreme(spec: np.ndarray, s: np.ndarray, T: float, high: bool) -> np.ndarray:
    """(V,) the angle of each row's largest (or smallest) value: the best sample refined by
    Newton on the interpolant's derivative within one sample either side."""
    A = s.shape[1]
    h = T / A
    j = np.argmax(s, axis=1) if high else np.argmin(s, axis=1)
    t0 = j * h
    t: np.ndarray = np.mod(_newton(spec, T, t0, A, t0 - h, t0 + h, 1), T)
    return t


def _extreme(spec: np.ndarray, s: np.ndarray, T: float, high: bool) -> np.ndarray:
    t = _argextreme(spec, s, T, high)
    v = _evaluate(spec, T, t, s.shape[1])
    best = s.max(axis=1) if high else s.min(axis=1)
    out: np.ndarray = np.maximum(v, best) if high else np.minimum(v, best)  # never worse than a sample
    return out


def _crossing(e: np.ndarray, T: float, rising: bool, ahead: bool) -> np.ndarray:
    """(V,) the angle (from the first sample, in [0, T)) where each row of ``e`` crosses zero
    rising along the angles (``rising``) or falling; of several, the first met going from the
    first sample along the angles (``ahead``) or back against them. NaN where there is none."""
    V, A = e.shape
    h = T / A
    nxt = np.roll(e, -1, axis=1)  # interval j runs from sample j to sample j + 1 (cyclic)
    want = ((e < 0) & (nxt >= 0)) if rising else ((e > 0) & (nxt <= 0))
    out = np.full(V, np.nan)
    rows = np.flatnonzero(want.any(axis=1))
    if len(rows) == 0:
        return out
    w = want[rows]
    j = np.argmax(w, axis=1) if ahead else A - 1 - np.argmax(w[:, ::-1], axis=1)
    ej, ek = e[rows, j], nxt[rows, j]
    t0 = (j + ej / (ej - ek)) * h
    spec = np.fft.rfft(e[rows], axis=1)
    out[rows] = np.mod(_newton(spec, T, t0, A, j * h, (j + 1) * h, 0), T)
    return out


def _axis(a: Any, where: str, default: int | None) -> int | None:
    if a is None:
        return default
    if a not in ("x", "y", "z"):
        raise MetricError(f"{where} must be 'x', 'y' or 'z', got {shown(a)}")
    return "xyz".index(a)


def _number(v: Any, where: str, bound: float) -> float:
    ok = not isinstance(v, bool) and isinstance(v, int | float)
    try:
        ok = ok and math.isfinite(v) and abs(v) <= bound
    except OverflowError:
        ok = False
    if not ok:
        raise MetricError(f"{where} must be a number within +-{bound:g}, got {shown(v)}")
    return float(v)
