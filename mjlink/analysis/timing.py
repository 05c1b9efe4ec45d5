"""A sewing head's timing over one stitch, measured from the reference and checked against the
windows of its ``[timing]`` table (:mod:`mjlink.model.timing`).

The main-shaft angle of every event is counted from the needle bar's top dead centre, in the
shaft's sense of rotation (the handwheel's scale of the makers' manuals). Events are found on a
grid of ``samples`` angles per stitch and placed between samples by linear interpolation: at the
default 7,200 samples a 0.05 deg grid, far finer than any window.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from .. import reference
from ..model.blocks import Crank
from ..model.mechanism import Mechanism
from ..model.timing import SETTINGS, Timing, Window
from ..reference.batch import Batch
from ..units import DEG, MM
from .metric_base import Column, Loads, Metric, MetricError

GENERAL = {
    "dog_below_while_needle_down": "feed dog's highest point above the throat plate while the needle point is below it",
    "feed_in_fabric": "feed given while the needle point is in the fabric",
    "take_up_after_release": "main-shaft angle from the loop's release off the hook to the take-up lever's top",
}
"""The checks every head gets, whatever the maker: the stitch cannot form otherwise."""


LABELS = {
    "dog_below_while_needle_down": "feed dog below the plate while the needle is",
    "feed_in_fabric": "feed with the needle in the fabric",
    "take_up_after_release": "take-up top after the loop's release",
    "hook_rise": "needle bar rise when the hook meets the needle",
    "hook_above_eye": "hook point above the needle eye",
    "dog_height": "feed dog height above the plate",
    "needle_at_dog_flush": "needle point when the dog is flush",
}
"""Each check's name in tables (``what`` says it in full)."""


@dataclass(frozen=True)
class TimingRow:
    """One check: ``value`` and ``window`` in SI (m or rad), ``unit`` 'mm' or 'deg' as shown.
    ``maker`` is None for the general checks; ``counts`` whether a miss fails the run (the
    general checks and the file's ``target`` maker's)."""

    key: str
    what: str
    maker: str | None
    value: float
    window: Window
    unit: str
    counts: bool

    @property
    def ok(self) -> bool:
        return bool(np.isfinite(self.value)) and self.window.holds(self.value)

    @property
    def label(self) -> str:
        return LABELS[self.key]

    def shown(self, x: float | None) -> str:
        if x is None:
            return ""
        return f"{x / (MM if self.unit == 'mm' else DEG):.3f}"

    def as_dict(self) -> dict[str, object]:
        k = MM if self.unit == "mm" else DEG
        return {
            "check": self.key,
            "what": self.what,
            "settings": self.maker,
            "value": self.value / k,
            "lo": None if self.window.lo is None else self.window.lo / k,
            "hi": None if self.window.hi is None else self.window.hi / k,
            "unit": self.unit,
            "result": "pass" if self.ok else "FAIL",
            "counts": self.counts,
        }


@dataclass(frozen=True)
class HeadTiming:
    """The head's timing over one stitch.

    ``theta`` (N,) main-shaft angle from needle top dead centre, deg, increasing; ``curves``
    name -> (N,) values on it (heights mm above the plate, the take-up eyelet mm, the hook's
    angle deg, the dog's advance mm); ``events`` name -> main-shaft angle, deg; ``rows`` the
    checks."""

    theta: np.ndarray
    curves: dict[str, np.ndarray]
    events: dict[str, float]
    rows: tuple[TimingRow, ...]
    target: str

    def failures(self) -> tuple[str, ...]:
        """One line per counting check that misses its window."""
        return tuple(
            f"timing: {r.what}{f' ({r.maker})' if r.maker else ''} is {r.shown(r.value)} {r.unit}, "
            f"window {_window(r)} {r.unit}"
            for r in self.rows
            if r.counts and not r.ok
        )

    def as_dict(self) -> dict[str, object]:
        return {
            "target": self.target,
            "events_deg": {k: round(v, 3) for k, v in self.events.items()},
            "checks": [r.as_dict() for r in self.rows],
        }


def _window(r: TimingRow) -> str:
    lo, hi = r.shown(r.window.lo), r.shown(r.window.hi)
    return f"{lo or '-inf'}..{hi or 'inf'}"


def window_text(r: TimingRow) -> str:
    """The row's window as shown in tables: '1.800..2.200'."""
    return _window(r)


def _crossing(theta: np.ndarray, f: np.ndarray, level: float, falling: bool) -> np.ndarray:
    """Angles (deg) where ``f`` crosses ``level`` (falling or rising), interpolated; the grid is
    periodic (the last sample is followed by the first, one stitch later)."""
    a, b = f - level, np.roll(f - level, -1)
    i = np.nonzero((a > 0) & (b <= 0) if falling else (a < 0) & (b >= 0))[0]
    t1 = np.where(i + 1 < len(theta), theta[(i + 1) % len(theta)], theta[0] + 360.0)
    frac = a[i] / (a[i] - b[i])
    out: np.ndarray = theta[i] + frac * (t1 - theta[i])
    return out


def _at(theta: np.ndarray, f: np.ndarray, t: float) -> float:
    return float(np.interp(t % 360.0, np.append(theta, theta[0] + 360.0), np.append(f, f[0])))


def head_timing(mech: Mechanism, samples: int = 7200) -> HeadTiming:
    """Measure the events of one stitch and check them against ``mech.timing``.

    Args:
      mech: a mechanism with a ``[timing]`` table.
      samples: input angles per stitch.
    Returns:
      :class:`HeadTiming`.
    Raises:
      ValueError: the mechanism has no ``[timing]`` table.
    """
    tm = mech.timing
    if tm is None:
        raise ValueError(f"{mech.name} has no [timing] table")
    sense = 1.0 if mech.speed >= 0 else -1.0
    u = np.arange(samples) / samples * mech.period  # shaft turn from phi0, rad
    hook = hook_crank(mech)
    kin = reference.solve(mech, mech.phi0 + sense * u)
    pos = {p: kin.position(p) for p in set(tm.roles.values()) | {hook.pivot}}
    return measure(tm, hook, u, pos)


def hook_crank(mech: Mechanism) -> Crank:
    """The geared crank whose point is the ``[timing]`` table's hook point."""
    assert mech.timing is not None
    return next(s for s in mech.steps if isinstance(s, Crank) and s.point == mech.timing.roles["hook_point"])


def measure(tm: Timing, hook: Crank, u: np.ndarray, pos: dict[str, np.ndarray]) -> HeadTiming:
    """The events and checks of one stitch from positions sampled over it.

    Args:
      tm: the head's ``[timing]`` table.
      hook: the hook's crank (its pivot and ratio).
      u: (A,) main-shaft turn of each sample in the shaft's sense of rotation, rad, in
        [0, 2 pi): one stitch is one turn of the main shaft (a [timing] table requires it).
      pos: each role's point and the hook's pivot -> (A, 3) positions, m.
    Returns:
      :class:`HeadTiming`, its angles counted from the needle bar's top dead centre.
    """
    roles = tm.roles
    first = np.argsort(u, kind="stable")
    y_bar = pos[roles["needle_bar"]][first, 1]
    top = int(np.argmax(y_bar))
    # Main-shaft angle from the needle bar's top dead centre, rolled to start there.
    order = np.roll(first, -top)
    theta = np.degrees(u[order] - u[order[0]]) % 360.0
    theta[0] = 0.0
    P = {k: v[order] for k, v in pos.items()}
    plate = tm.plate
    bar = P[roles["needle_bar"]][:, 1]
    tip = P[roles["needle_point"]][:, 1] - plate
    eye = P[roles["needle_eye"]][:, 1] - plate
    hp = P[roles["hook_point"]]
    dog = P[roles["feed_dog"]]
    dog_h = dog[:, 1] - plate
    take = P[roles["take_up"]][:, 1]
    centre = P[hook.pivot][0]
    bdc = int(np.argmin(bar))
    rise = bar - bar[bdc]
    hook_angle = np.degrees(np.arctan2(hp[:, 1] - centre[1], hp[:, 0] - centre[0])) % 360.0

    # The hook point against the needle's centre line (the line through the bar's two points).
    line = P[roles["needle_bar"]] - P[roles["needle_point"]]
    rel = hp - P[roles["needle_point"]]
    side = line[:, 0] * rel[:, 1] - line[:, 1] * rel[:, 0]
    cross = np.concatenate([_crossing(theta, side, 0.0, True), _crossing(theta, side, 0.0, False)])
    above = np.array([_at(theta, hp[:, 1] - centre[1], t) > 0 for t in cross], dtype=bool)
    picks = cross[above]
    pick = float(picks[np.argmin((picks - theta[bdc]) % 360.0)]) if len(picks) else math.nan
    ratio = abs(hook.ratio)
    release = (pick + math.degrees(tm.loop_release) / ratio) % 360.0 if math.isfinite(pick) else math.nan
    j = int(np.argmax(take))
    a, b, c = take[j - 1], take[j], take[(j + 1) % len(take)]
    # The top between samples: the vertex of the parabola through the best one and its neighbours.
    shift = 0.5 * (a - c) / (a - 2.0 * b + c) if (a - 2.0 * b + c) < 0 else 0.0
    take_top = float(theta[j] + shift * 360.0 / len(theta)) % 360.0
    flush = _crossing(theta, dog_h, 0.0, True)
    flush_at = float(flush[0]) if len(flush) else math.nan
    tip_down = _crossing(theta, tip, 0.0, True)
    tip_up = _crossing(theta, tip, 0.0, False)
    dog_up = _crossing(theta, dog_h, 0.0, False)

    # The dog's advance: along the direction it moves in at its highest point.
    hi = int(np.argmax(dog_h))
    vx = np.gradient(dog[:, 0])
    forward = 1.0 if vx[hi] >= 0 else -1.0
    advance = forward * (dog[:, 0] - dog[:, 0].min() if forward > 0 else dog[:, 0] - dog[:, 0].max())
    # The conditions on a grid ten times finer, the curves interpolated linearly between the
    # samples: a coarse study grid then gives what simulate's fine one does.
    fine = np.arange(10 * len(theta)) * (36.0 / len(theta))
    ext = np.append(theta, 360.0)
    f_tip, f_dog, f_x = (np.interp(fine, ext, np.append(v, v[0])) for v in (tip, dog_h, dog[:, 0]))
    step = forward * np.diff(np.append(f_x, f_x[0]))
    in_fabric = (f_tip < tm.fabric) | (np.roll(f_tip, -1) < tm.fabric)
    feeding = (f_dog > 0) & (np.roll(f_dog, -1) > 0) & (step > 0)
    fed_in_fabric = float(step[feeding & in_fabric].sum())
    down = f_tip < 0
    # The dog's height where the needle point is below the plate, its ends (the crossings) included.
    ends = [_at(theta, dog_h, t) for t in (*tip_down, *tip_up)]
    worst = max([*ends, float(f_dog[down].max()) if down.any() else -math.inf])

    rows: list[TimingRow] = [
        TimingRow(
            "dog_below_while_needle_down",
            GENERAL["dog_below_while_needle_down"],
            None,
            worst,
            Window(None, 0.0),
            "mm",
            True,
        ),
        TimingRow(
            "feed_in_fabric", GENERAL["feed_in_fabric"], None, fed_in_fabric, Window(0.0, tm.feed_in_fabric), "mm", True
        ),
        TimingRow(
            "take_up_after_release",
            GENERAL["take_up_after_release"],
            None,
            math.radians((take_top - release) % 360.0) if math.isfinite(release) else math.nan,
            Window(0.0, math.pi),
            "deg",
            True,
        ),
    ]
    measured = {
        "hook_rise": _at(theta, rise, pick) if math.isfinite(pick) else math.nan,
        "hook_above_eye": _at(theta, hp[:, 1] - plate - eye, pick) if math.isfinite(pick) else math.nan,
        "dog_height": float(dog_h.max()),
        "needle_at_dog_flush": _at(theta, tip, flush_at) if math.isfinite(flush_at) else math.nan,
    }
    for m in tm.settings:
        for key, window in m.windows.items():
            rows.append(TimingRow(key, SETTINGS[key], m.name, measured[key], window, "mm", m.name == tm.target))
    events = {
        "needle bar top": 0.0,
        "needle bar bottom": float(theta[bdc]),
        "hook picks the loop": pick,
        "loop released": release,
        "take-up top": take_top,
        "dog flush, descending": flush_at,
        "dog through the plate, rising": float(dog_up[0]) if len(dog_up) else math.nan,
        "needle point through the plate, down": float(tip_down[0]) if len(tip_down) else math.nan,
        "needle point through the plate, up": float(tip_up[0]) if len(tip_up) else math.nan,
    }
    curves = {
        "needle point": tip / MM,
        "needle eye": eye / MM,
        "needle bar rise": rise / MM,
        "take-up eyelet": (take - take.min()) / MM,
        "hook angle": hook_angle,
        "hook point height": (hp[:, 1] - plate) / MM,
        "dog height": dog_h / MM,
        "dog advance": advance / MM,
    }
    return HeadTiming(theta, curves, events, tuple(rows), tm.target)


class TimingChecks(Metric):
    """A sewing head's timing checks, per variant: one column per check of the ``[timing]``
    table (the general ones and those of ``settings``, default the file's target maker), in mm
    or deg as the table shows them, and ``timing_ok``: 1 where every one of them holds its
    window, else 0, so that its mean is the fraction of heads that meet them all. Measured as
    :func:`head_timing` does, on the study's crank angles."""

    kind = "timing"
    options = ("settings",)

    def read(self, raw: dict[str, Any]) -> None:
        tm = self.mech.timing
        if tm is None:
            raise MetricError(f"{self.where}: {self.mech.name} has no [timing] table (docs/head.md)")
        name = raw.get("settings", tm.target)
        makers = [m.name for m in tm.settings]
        if name not in makers:
            raise MetricError(f"{self.where}: settings '{name}' is not one of {', '.join(makers)}")
        self.maker = str(name)
        self.tag = "" if self.maker == tm.target else f"_{self.maker}"

    def _keys(self) -> list[str]:
        assert self.mech.timing is not None
        return [*GENERAL, *self.mech.timing.maker(self.maker).windows]

    def columns(self) -> list[Column]:
        cols = [
            Column(f"timing_{k}{self.tag}", "deg" if k == "take_up_after_release" else "mm", LABELS[k])
            for k in self._keys()
        ]
        cols.append(Column(f"timing_ok{self.tag}", "", f"1 if every timing window holds ({self.maker} and general)"))
        return cols

    def compute(self, b: Batch, nominal: Batch, loads: Loads) -> dict[str, np.ndarray]:
        mech = b.mechanism
        tm = self.mech.timing
        assert tm is not None
        tm = dataclasses.replace(tm, target=self.maker)
        hook = hook_crank(self.mech)
        # The batch's angles run from phi0 counter-clockwise; the shaft's own sense may not.
        u = b.theta if mech.speed >= 0 else np.mod(-b.theta, 2.0 * math.pi)
        names = set(tm.roles.values()) | {hook.pivot}
        pts = {p: b.per_variant(np.broadcast_to(b.kin.points[p].v, (b.variants * b.angles, 3))) for p in names}
        keys = self._keys()
        out = np.full((b.variants, len(keys) + 1), np.nan)
        for i in range(b.variants):
            head = measure(tm, hook, u, {p: v[i] for p, v in pts.items()})
            rows = {r.key: r for r in head.rows if r.maker in (None, self.maker)}
            out[i, :-1] = [rows[k].value / (DEG if rows[k].unit == "deg" else MM) for k in keys]
            out[i, -1] = float(all(rows[k].ok for k in keys))
        return {c.name: out[:, j] for j, c in enumerate(self.columns())}


__all__ = ["GENERAL", "LABELS", "HeadTiming", "TimingChecks", "TimingRow", "head_timing", "measure", "window_text"]
