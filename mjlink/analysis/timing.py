"""A sewing head's timing over one stitch, measured from the reference and checked against the
windows of its ``[timing]`` table (:mod:`mjlink.model.timing`).

The main-shaft angle of every event is counted from the needle bar's top dead centre, in the
shaft's sense of rotation (the handwheel's scale of the makers' manuals). Events are found on a
grid of ``samples`` angles per stitch and placed between samples by linear interpolation: at the
default 7,200 samples a 0.05 deg grid, far finer than any window.
"""

from __future__ import annotations

import dataclasses
import hashlib
import itertools
import math
from dataclasses import dataclass
from typing import Any, ClassVar

import numpy as np

from .. import reference
from ..model.blocks import Crank
from ..model.mechanism import Mechanism
from ..model.timing import SETTINGS, StitchType, Timing, Window, hook_crank
from ..reference.batch import Batch
from ..units import DEG, MM
from .metric_base import Column, Curve, Loads, Metric, MetricError
from .stitch import (
    StitchEnd,
    _at,
    _between,
    _carried,
    _chain_below,
    _crossing,
    _geometry,
    _lock_below,
    _peak,
    _set_point,
    spring_holds,
    stitch_end,
)

GENERAL = {
    "dog_below_while_needle_down": "feed dog's highest point above the throat plate while the needle point is below it",
    "feed_in_fabric": "feed given while the needle point is in the fabric",
    "take_up_after_release": "main-shaft angle from the loop's release off the hook to the take-up lever's top",
}
"""The checks every head gets, whatever the maker: the stitch cannot form otherwise."""

GENERAL_ROLES = {
    "dog_below_while_needle_down": ("needle_bar", "needle_point", "feed_dog"),
    "feed_in_fabric": ("needle_bar", "needle_point", "feed_dog"),
    "take_up_after_release": ("hook_point", "take_up"),
}
"""The parts each general check needs named: it is made where they are."""


BALANCE = {
    "thread_shortfall": "largest shortfall of thread from the stitch's setting to the loop's release: what the "
    "take-up holds back of what the needle and the loop take, beyond what the thread stretches (drawn through "
    "the tension, or torn)",
    "thread_slack": "largest slack of thread from the stitch's setting to the loop's release, against the thread "
    "the check spring's travel holds (beyond it, loose loops form)",
    "spring_spare": "thread the check spring's travel holds (its hook from rest to its stop, or to where the thread "
    "runs straight) less the largest slack: below nought loose loops form",
    "loop_thread": "most needle thread below the material while the hook carries the loop round the bobbin case, "
    "against the 8.9 cm of Union Special's 301 Stitch manual (within 15 %; a comparison, not a requirement)",
}
"""The thread balance's checks (a head with a ``[balance]`` table; ``loop_thread`` a lockstitch's)."""

UNION_SPECIAL_LOOP = 89.0 * MM
"""Needle thread carried below the material and round the bobbin per stitch, m: "approximately
3-1/2 inches or 8.9 cm" (Union Special, *301 Stitch* technical manual, Introduction)."""

EYE_STITCHES = "thread through the eye before the seam"
"""The measured value (``HeadTiming.values``, in stitches) of :attr:`ThreadBalance.eye_stitches`."""

LABELS = {
    "thread_shortfall": "thread short of what needle and loop take",
    "thread_slack": "slack the check spring must hold",
    "spring_spare": "thread the check spring holds beyond the slack",
    "loop_thread": "most thread below the material (loop)",
    "dog_below_while_needle_down": "feed dog below the plate while the needle is below it",
    "feed_in_fabric": "feed with the needle in the fabric",
    "take_up_after_release": "take-up top after the loop's release",
    "hook_rise": "needle bar rise when the hook meets the needle",
    "hook_above_eye": "hook point above the needle eye",
    "dog_height": "feed dog height above the plate",
    "needle_at_dog_flush": "needle point when the dog is flush",
}
"""Each check's name in tables (``what`` says it in full)."""


@dataclass(frozen=True, kw_only=True)
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

    @property
    def verdict(self) -> str:
        """'pass' or 'FAIL' for a check that decides the run; 'meets' or 'misses' for another
        maker's window, shown for comparison."""
        if self.counts:
            return "pass" if self.ok else "FAIL"
        return "meets" if self.ok else "misses"

    def shown(self, x: float | None) -> str:
        if x is None:
            return ""
        return f"{x / (MM if self.unit == 'mm' else DEG):.3f}"

    def window_text(self) -> str:
        """The window as tables show it: '1.800..2.200' (an open end as -inf or inf)."""
        lo, hi = self.shown(self.window.lo), self.shown(self.window.hi)
        return f"{lo or '-inf'}..{hi or 'inf'}"

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
            "result": self.verdict,  # the terminal's and the page's word for the row
            "counts": self.counts,
        }


@dataclass(frozen=True, kw_only=True)
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
    positions: dict[str, np.ndarray] = dataclasses.field(default_factory=dict, repr=False)
    balance: ThreadBalance | None = None
    order: np.ndarray | None = dataclasses.field(default=None, repr=False)  # input sample of each angle
    values: dict[str, tuple[float, str]] = dataclasses.field(default_factory=dict)  # measured, informational
    origin: str = "the needle bar's top dead centre"  # where the angles start

    def failures(self) -> tuple[str, ...]:
        """One line per counting check that misses its window."""
        return tuple(
            f"timing: {r.what}{f' ({r.maker})' if r.maker else ''} is {r.shown(r.value)} {r.unit}, "
            f"window {r.window_text()} {r.unit}"
            for r in self.rows
            if r.counts and not r.ok
        )

    def as_dict(self) -> dict[str, object]:
        return {
            "target": self.target or None,
            "angles_from": self.origin,
            "events_deg": {k: round(v, 3) for k, v in self.events.items()},
            "values": {k: {"value": v, "unit": u} for k, (v, u) in self.values.items()},
            "checks": [r.as_dict() for r in self.rows],
        }


def _general(key: str, value: float, window: Window, unit: str) -> TimingRow:
    """One of the :data:`GENERAL` checks: every head gets it and a miss fails the run."""
    return TimingRow(key=key, what=GENERAL[key], maker=None, value=value, window=window, unit=unit, counts=True)


def head_timing(mech: Mechanism, samples: int = 7200) -> HeadTiming:
    """Measure the events of one stitch and check them against ``mech.timing``.

    Args:
      mech: a mechanism with a ``[timing]`` table.
      samples: input angles per stitch.
    Returns:
      :class:`HeadTiming`; with the needle named, its point's velocity as it passes the fabric's
      top going down (penetration) and coming up (exit), m/s, from the reference's exact
      derivative at the crossing (``values``).
    Raises:
      ValueError: the mechanism has no ``[timing]`` table.
    """
    tm = mech.timing
    if tm is None:
        raise ValueError(f"{mech.name} has no [timing] table")
    sense = 1.0 if mech.speed >= 0 else -1.0
    u = np.arange(samples) / samples * mech.period  # shaft turn from phi0, rad
    kin = reference.solve(mech, mech.phi0 + sense * u)
    names = set(tm.roles.values()) | set(mech.thread or ())
    hook = hook_crank(mech) if tm.has("hook_point") else None
    if hook is not None:
        names.add(hook.pivot)
    pos = {p: kin.position(p) for p in names}
    head = measure(tm, hook, u, pos)
    if tm.has("needle_point"):
        assert head.order is not None
        vy = kin.points[tm.roles["needle_point"]].d[head.order, 1] * mech.speed
        values = dict(head.values)
        for event, key in (
            ("needle point into the fabric, down", "penetration velocity"),
            ("needle point out of the fabric, up", "exit velocity"),
        ):
            values[key] = (
                (_at(head.theta, vy, head.events[event]), "m/s")
                if math.isfinite(head.events[event])
                else (math.nan, "m/s")
            )
        head = dataclasses.replace(head, values=values)
    if mech.balance is None or not mech.thread:
        return head
    bal = thread_balance(mech, head)
    values = {**head.values, EYE_STITCHES: (bal.eye_stitches, "stitches")}
    return dataclasses.replace(head, rows=head.rows + bal.rows, balance=bal, values=values)


def measure(tm: Timing, hook: Crank | None, u: np.ndarray, pos: dict[str, np.ndarray]) -> HeadTiming:
    """The events and checks of one stitch from positions sampled over it, for the parts the
    ``[timing]`` table names (a check is made where its parts are).

    Args:
      tm: the head's ``[timing]`` table.
      hook: the hook's crank (its pivot and ratio); None without a hook.
      u: (A,) main-shaft turn of each sample in the shaft's sense of rotation, rad, in
        [0, 2 pi): one stitch is one turn of the main shaft (a [timing] table requires it).
      pos: each role's point and the hook's pivot -> (A, 3) positions, m.
    Returns:
      :class:`HeadTiming`, its angles counted from the needle bar's top dead centre (without a
      needle: from the crank's setting).
    """
    roles = tm.roles
    first = np.argsort(u, kind="stable")
    needle = tm.has("needle_bar", "needle_point")
    top = int(np.argmax(pos[roles["needle_bar"]][first, 1])) if needle else 0
    # Main-shaft angle from the needle bar's top dead centre, rolled to start there.
    order = np.roll(first, -top)
    theta = np.degrees(u[order] - u[order[0]]) % 360.0
    theta[0] = 0.0
    P = {k: v[order] for k, v in pos.items()}
    plate = tm.plate
    events: dict[str, float] = {}
    curves: dict[str, np.ndarray] = {}
    values: dict[str, tuple[float, str]] = {}
    rows: list[TimingRow] = []
    measured: dict[str, float] = {}

    if needle:
        bar = P[roles["needle_bar"]][:, 1]
        tip = P[roles["needle_point"]][:, 1] - plate
        bdc = int(np.argmin(bar))
        rise = bar - bar[bdc]
        tip_down, tip_up = _crossing(theta, tip, 0.0, True), _crossing(theta, tip, 0.0, False)
        into, out = _crossing(theta, tip, tm.fabric, True), _crossing(theta, tip, tm.fabric, False)
        events |= {
            "needle bar top": 0.0,
            "needle bar bottom": float(theta[bdc]),
            "needle point into the fabric, down": float(into[0]) if len(into) else math.nan,
            "needle point through the plate, down": float(tip_down[0]) if len(tip_down) else math.nan,
            "needle point through the plate, up": float(tip_up[0]) if len(tip_up) else math.nan,
            "needle point out of the fabric, up": float(out[0]) if len(out) else math.nan,
        }
        curves |= {"needle point": tip / MM, "needle bar rise": rise / MM}
    if tm.has("needle_eye"):
        eye = P[roles["needle_eye"]][:, 1] - plate
        curves["needle eye"] = eye / MM

    pick = release = math.nan
    if hook is not None:
        hp = P[roles["hook_point"]]
        centre = P[hook.pivot][0]
        hook_angle = np.degrees(np.arctan2(hp[:, 1] - centre[1], hp[:, 0] - centre[0])) % 360.0
        # The hook point against the needle's centre line (the line through the bar's two points).
        line = P[roles["needle_bar"]] - P[roles["needle_point"]]
        rel = hp - P[roles["needle_point"]]
        side = line[:, 0] * rel[:, 1] - line[:, 1] * rel[:, 0]
        cross = np.concatenate([_crossing(theta, side, 0.0, True), _crossing(theta, side, 0.0, False)])
        above = np.array([_at(theta, hp[:, 1] - centre[1], t) > 0 for t in cross], dtype=bool)
        picks = cross[above]
        pick = float(picks[np.argmin((picks - theta[bdc]) % 360.0)]) if len(picks) else math.nan
        if tm.stitch is StitchType.CHAIN:
            # A chain stitch's looper holds its loop until it takes the next: the held loop is
            # cast off at the pick-up (the needle has passed through it), and the take-up draws
            # it tight.
            release = pick
        else:
            release = _carried(tm, hook, pick) if math.isfinite(pick) else math.nan
        events |= {"hook picks the loop": pick, "loop released": release}
        curves |= {"hook angle": hook_angle, "hook point height": (hp[:, 1] - plate) / MM}
        measured["hook_rise"] = _at(theta, rise, pick) if math.isfinite(pick) else math.nan
        measured["hook_above_eye"] = _at(theta, hp[:, 1] - plate - eye, pick) if math.isfinite(pick) else math.nan

    if tm.has("take_up"):
        take = P[roles["take_up"]][:, 1]
        j = int(np.argmax(take))
        a, b, c = take[j - 1], take[j], take[(j + 1) % len(take)]
        # The top between samples: the vertex of the parabola through the best one and its neighbours.
        shift = 0.5 * (a - c) / (a - 2.0 * b + c) if (a - 2.0 * b + c) < 0 else 0.0
        take_top = float(theta[j] + shift * 360.0 / len(theta)) % 360.0
        events["take-up top"] = take_top
        curves["take-up eyelet"] = (take - take.min()) / MM
        rows.append(
            _general(
                "take_up_after_release",
                math.radians((take_top - release) % 360.0) if math.isfinite(release) else math.nan,
                Window(0.0, math.pi),
                "deg",
            )
        )

    if tm.has("feed_dog"):
        dog = P[roles["feed_dog"]]
        dog_h = dog[:, 1] - plate
        flush = _crossing(theta, dog_h, 0.0, True)
        flush_at = float(flush[0]) if len(flush) else math.nan
        dog_up = _crossing(theta, dog_h, 0.0, False)
        # The dog's advance: along the direction it moves in at its highest point.
        hi = int(np.argmax(dog_h))
        vx = np.gradient(dog[:, 0])
        forward = 1.0 if vx[hi] >= 0 else -1.0
        advance = forward * (dog[:, 0] - dog[:, 0].min() if forward > 0 else dog[:, 0] - dog[:, 0].max())
        events |= {
            "dog flush, descending": flush_at,
            "dog through the plate, rising": float(dog_up[0]) if len(dog_up) else math.nan,
        }
        curves |= {"dog height": dog_h / MM, "dog advance": advance / MM}
        measured["dog_height"] = float(dog_h.max())
        values["dog height above the plate"] = (float(dog_h.max()) / MM, "mm")
        if needle:
            measured["needle_at_dog_flush"] = _at(theta, tip, flush_at) if math.isfinite(flush_at) else math.nan
            # The conditions on a grid ten times finer, the curves interpolated linearly
            # between the samples: a coarse study grid then gives what simulate's fine one does.
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
            rows[:0] = [
                _general("dog_below_while_needle_down", worst, Window(None, 0.0), "mm"),
                _general("feed_in_fabric", fed_in_fabric, Window(0.0, tm.feed_in_fabric), "mm"),
            ]

    for m in tm.settings:
        for key, window in m.windows.items():
            rows.append(
                TimingRow(
                    key=key,
                    what=SETTINGS[key],
                    maker=m.name,
                    value=measured[key],
                    window=window,
                    unit="mm",
                    counts=m.name == tm.target,
                )
            )
    return HeadTiming(
        theta=theta,
        curves=curves,
        events=events,
        rows=tuple(rows),
        target=tm.target,
        positions=P,
        order=order,
        values=values,
        origin="the needle bar's top dead centre" if needle else "the crank's setting",
    )


class TimingChecks(Metric):
    """A sewing head's timing checks, per variant: one column per check of the ``[timing]``
    table (the general ones and those of ``settings``, default the file's target maker), in mm
    or deg as the table shows them, and ``timing_ok``: 1 where every one of them holds its
    window, else 0, so that its mean is the fraction of heads that meet them all. Measured as
    :func:`head_timing` does, on the study's crank angles."""

    kind = "timing"
    options: ClassVar[tuple[str, ...]] = ("settings",)

    def read(self, raw: dict[str, Any]) -> None:
        tm = self.mech.timing
        if tm is None:
            raise MetricError(f"{self.where}: {self.mech.name} has no [timing] table (docs/head.md)")
        name = raw.get("settings", tm.target)
        makers = [m.name for m in tm.settings]
        if name not in makers and (makers or "settings" in raw):
            raise MetricError(
                f"{self.where}: settings '{name}' is not one of {', '.join(makers) or 'none: [timing] has no settings table'}"
            )
        self.maker = str(name)
        self.tag = "" if self.maker == tm.target else f"_{self.maker}"

    def _keys(self) -> list[str]:
        assert self.mech.timing is not None
        tm = self.mech.timing
        extra = list(BALANCE) if self.mech.balance is not None and self.mech.thread else []
        if tm.stitch is StitchType.CHAIN:
            extra = [k for k in extra if k != "loop_thread"]
        general = [k for k in GENERAL if tm.has(*GENERAL_ROLES[k])]
        windows = list(tm.maker(self.maker).windows) if self.maker else []
        return [*general, *windows, *extra]

    def columns(self) -> list[Column]:
        cols = [
            Column(f"timing_{k}{self.tag}", "deg" if k == "take_up_after_release" else "mm", LABELS[k])
            for k in self._keys()
        ]
        which = f"{self.maker} and general" if self.maker else "general"
        cols.append(Column(f"timing_ok{self.tag}", "", f"1 if every timing window holds ({which})"))
        return cols

    def _heads(self, b: Batch) -> list[tuple[HeadTiming, ThreadBalance | None, dict[str, TimingRow]]]:
        """Each variant's timing, thread balance (None without [balance]) and rows by key."""
        return [(head, bal, rows) for head, bal, rows, _ in self.variants(b)]

    def variants(self, b: Batch) -> list[tuple[HeadTiming, ThreadBalance | None, dict[str, TimingRow], Mechanism]]:
        """Each variant's timing, thread balance, rows by key and its own head (the file's with
        the variant's numbers of the [timing], [balance], [tension] tables and its speed)."""
        mech = b.mechanism
        tm = self.mech.timing
        assert tm is not None
        tm = dataclasses.replace(tm, target=self.maker)
        hook = hook_crank(self.mech) if tm.has("hook_point") else None
        # The batch's angles run from phi0 counter-clockwise; the shaft's own sense may not.
        u = b.theta if _of(mech.speed, 0, b) >= 0 else np.mod(-b.theta, 2.0 * math.pi)
        names = set(tm.roles.values()) | ({hook.pivot} if hook else set()) | set(self.mech.thread or ())
        pts = {p: b.per_variant(np.broadcast_to(b.kin.points[p].v, (b.variants * b.angles, 3))) for p in names}
        out = []
        # Variants that differ only in speed or in the [tension] table share their timing and
        # balance (neither depends on either; the speed's sign turns the hook's sense).
        seen: dict[bytes, tuple[HeadTiming, ThreadBalance | None]] = {}
        for i in range(b.variants):
            # A study may vary the fabric, the stitch or the thread's numbers: this variant's.
            own_tm = dataclasses.replace(tm, fabric=_of(mech.timing.fabric if mech.timing else tm.fabric, i, b))
            own = self.mech
            if self.mech.balance is not None and mech.balance is not None:
                vb = mech.balance
                own = dataclasses.replace(
                    self.mech,
                    timing=own_tm,
                    balance=dataclasses.replace(
                        vb,
                        stitch_length=_of(vb.stitch_length, i, b),
                        bobbin_case=_of(vb.bobbin_case, i, b),
                        looper=_of(vb.looper, i, b),
                        bobbin_case_width=_of(vb.bobbin_case_width, i, b),
                        check_spring_travel=_of(vb.check_spring_travel, i, b),
                        stretch=_of(vb.stretch, i, b),
                    ),
                )
            own = dataclasses.replace(own, speed=_of(mech.speed, i, b))
            if self.mech.tension is not None or mech.tension is not None:
                vt = mech.tension or self.mech.tension
                assert vt is not None
                own = dataclasses.replace(
                    own,
                    tension=dataclasses.replace(
                        vt, **{f.name: _of(getattr(vt, f.name), i, b) for f in dataclasses.fields(vt)}
                    ),
                )
            where = {p: v[i] for p, v in pts.items()}
            key = hashlib.blake2b(repr((own_tm, own.balance, own.speed >= 0)).encode(), digest_size=20)
            for p in sorted(where):
                key.update(np.ascontiguousarray(where[p]).tobytes())
            if (digest := key.digest()) not in seen:
                head = measure(own_tm, hook, u, where)
                seen[digest] = (head, thread_balance(own, head) if own.balance is not None and own.thread else None)
            head, bal = seen[digest]
            rows = {r.key: r for r in (*head.rows, *(bal.rows if bal else ())) if r.maker in (None, self.maker)}
            out.append((head, bal, rows, own))
        return out

    def compute(self, b: Batch, nominal: Batch, loads: Loads) -> dict[str, np.ndarray]:
        keys = self._keys()
        out = np.full((b.variants, len(keys) + 1), np.nan)
        for i, (_, _, rows) in enumerate(self._heads(b)):
            out[i, :-1] = [rows[k].value / (DEG if rows[k].unit == "deg" else MM) for k in keys]
            out[i, -1] = float(all(rows[k].ok for k in keys if rows[k].counts))
        return {c.name: out[:, j] for j, c in enumerate(self.columns())}

    def curve(self, b: Batch, loads: Loads) -> Curve | None:
        """The needle thread's balance (supply - demand, mm) over the cycle, for a head with a
        ``[balance]`` table: NaN where the take-up sets the stitch."""
        if self.mech.balance is None or not self.mech.thread:
            return None
        values = np.full((b.variants, b.angles), np.nan)
        for i, (head, bal, _) in enumerate(self._heads(b)):
            assert bal is not None and head.order is not None
            values[i, head.order] = bal.balance
        return Curve("needle thread: supply - demand", "mm", values, limit=0.0)


@dataclass(frozen=True, kw_only=True)
class ThreadBalance:
    """The needle thread over one stitch (docs/head.md, The thread balance), on the timing's
    angles ``theta`` (deg from the needle bar's top): ``path`` (N,) the thread's length from
    the tension discs to the needle's eye, mm; ``supply`` (N,) what the path has given out
    since the take-up's top, mm; ``demand`` (N,) what the needle, the fabric and the hook's
    loop have taken beyond their length at the take-up's top, mm; ``balance`` = supply -
    demand (slack > 0, shortfall < 0), NaN in the stitch-setting phase where the take-up draws
    the thread tight; ``phases`` name -> (start, end) deg; ``per_stitch`` the needle thread a
    stitch holds, mm; ``rows`` the checks; ``hole`` and ``end`` (N,) mm, the needle's hole and
    the last stitch's end behind the needle's line (:class:`StitchEnd`); ``under`` (N,) mm the
    needle thread below the material while the hook carries a lockstitch's loop (NaN
    elsewhere), ``past`` (N,) mm the part of the thread below the eye past the hook's blade
    point then (the loop's leg from the blade to the needle's hole, up through it and along the
    top to the last stitch's end; NaN elsewhere), ``blade_turn`` (N,) deg the thread's turn at the
    blade point between the loop's two legs then (NaN elsewhere), ``case_turn`` (N,) deg how far
    the eye's leg turns on the bobbin case then, where the thread slides over the case as it
    crosses the blade (NaN elsewhere), ``most_under`` its largest and ``most_under_at`` where the blade point then is,
    deg of the hook's turn past its lowest point (six o'clock), NaN for a chain stitch;
    ``below`` (N,) mm the needle thread's taut length below the eye."""

    theta: np.ndarray
    path: np.ndarray
    supply: np.ndarray
    demand: np.ndarray
    balance: np.ndarray
    phases: dict[str, tuple[float, float]]
    per_stitch: float
    rows: tuple[TimingRow, ...]
    hole: np.ndarray
    end: np.ndarray
    under: np.ndarray
    past: np.ndarray
    blade_turn: np.ndarray
    case_turn: np.ndarray
    most_under: float
    most_under_at: float
    below: np.ndarray

    @property
    def eye_stitches(self) -> float:
        """Stitches a piece of needle thread goes up and down through the needle's eye before it
        lies in the seam: the longest thread below the eye over the thread a stitch holds.

        The thread at the eye is the thread the stitches have taken plus what lies below the eye,
        so a piece first reaches the eye when the thread below it is longest (``below``'s
        largest), that much thread from the last stitch's end; each stitch set then takes
        ``per_stitch`` of it, and the piece lies in the seam once they have taken all that
        (the whole stitches from its first pass to the seam are this, rounded up or down)."""
        taut = self.below[np.isfinite(self.below)]
        return float(taut.max()) / self.per_stitch if taut.size else math.nan


def thread_balance(mech: Mechanism, head: HeadTiming) -> ThreadBalance:
    """The needle thread's balance over the stitch ``head`` measured.

    The path's length L runs from the tension discs to the needle's eye through the file's
    ``[thread]`` points. Below the eye the thread runs to the end of the last stitch on the
    fabric's top (:func:`stitch_end`: the hole the needle left, which the feed carries from the
    moment the needle leaves it): straight while the eye is above the fabric, up the needle and
    along the fabric while it is in it, and, once the hook has taken the loop, over the hook's
    blade point and around the bobbin case (both legs of the loop, the one to the eye and the
    one to the underside of the needle's hole, wrapped around the case in the hook's sense),
    up through that hole and along the top to the last stitch's end until the loop is released.
    The supply is L at the take-up's top minus L; the demand is the thread below the eye minus
    its value at the take-up's top. From the release to the take-up's next top the take-up draws
    the loop tight and the stitch's thread from the spool: no balance there.

    A chain stitch (``[timing] stitch = "101"``, StitchType.CHAIN) is followed as :func:`_chain_below` says: its
    looper holds the loop until it takes the next one, so the balance runs from the setting
    to the next pick-up, where the held loop is cast off and drawn tight.
    """
    tm, bal = mech.timing, mech.balance
    assert tm is not None and bal is not None and mech.thread
    P, th, ev = head.positions, head.theta, head.events
    path = np.zeros(len(th))
    for a, b in itertools.pairwise(mech.thread):
        path += np.linalg.norm(P[b] - P[a], axis=1)
    hook = hook_crank(mech)
    pick, release = ev["hook picks the loop"], ev["loop released"]
    at = stitch_end(head, tm.fabric, bal.stitch_length, release)
    enters = at.enters
    # The stitch is set where the path is longest between the loop's release (a chain stitch:
    # the held loop's cast-off) and the needle's entry into the fabric: the take-up has drawn
    # the most thread.
    window = _between(th, release, enters)
    under = past = turn = slid = np.full(len(th), np.nan)
    if tm.stitch is StitchType.CHAIN:
        below = _chain_below(mech, head, hook, at)
        end = pick
        per_stitch = 3.0 * bal.stitch_length + 2.0 * tm.fabric
    else:
        below, under, past, turn, slid = _lock_below(mech, head, hook, at)
        end = release
        per_stitch = bal.stitch_length + tm.fabric
    drawn, path_at, below_at, start = _set_point(th, path, below, window, enters)
    forming = _between(th, start, end)
    supply = path_at - path
    demand = below - below_at
    balance = np.where(forming, supply - demand, np.nan)
    diff = supply - demand
    # The phase ends at the release (a chain stitch: the next pick-up), between two samples: the
    # balance there, extrapolated from the phase's last two samples, is a candidate too (a
    # coarse grid would stop short of it).
    k = int(np.nonzero(forming & ~np.roll(forming, -1))[0][0]) if forming.any() and not forming.all() else -1
    at_end = diff[k] + (diff[k] - diff[k - 1]) * ((release - th[k]) % 360.0) / ((th[k] - th[k - 1]) % 360.0)
    # The balance is nought at the set point itself, which now falls between two samples.
    short = max(_peak(-diff, forming), -float(at_end), 0.0)
    slack = max(_peak(diff, forming), float(at_end), 0.0)
    cs = mech.thread.index(bal.check_spring)
    up, rest, down = (P[mech.thread[cs + k]] for k in (-1, 0, 1))
    pivot = None if bal.check_spring_pivot is None else mech.ground[bal.check_spring_pivot]
    holds = float(spring_holds(up, rest, down, bal.check_spring_travel, pivot).min())
    rows = (
        TimingRow(
            key="thread_shortfall",
            what=BALANCE["thread_shortfall"],
            maker=None,
            value=short,
            window=Window(None, bal.stretch * float(path.min())),
            unit="mm",
            counts=True,
        ),
        TimingRow(
            key="thread_slack",
            what=BALANCE["thread_slack"],
            maker=None,
            value=slack,
            window=Window(None, holds),
            unit="mm",
            counts=False,  # the check spring's travel is information: a loose loop, not a failed stitch
        ),
        TimingRow(
            key="spring_spare",
            what=BALANCE["spring_spare"],
            maker=None,
            value=holds - slack,
            window=Window(0.0, None),
            unit="mm",
            counts=False,
        ),
    )
    most_under = most_under_at = math.nan
    if tm.stitch is StitchType.LOCKSTITCH and np.isfinite(under).any():
        j = int(np.nanargmax(under))
        most_under = _peak(np.nan_to_num(under, nan=-np.inf), np.isfinite(under))
        # The blade point's angle past the hook's lowest point, in the hook's sense.
        _, _, sense, _, _, hp, centre = _geometry(mech, head, hook)
        v = hp[j, :2] - centre
        most_under_at = math.degrees(sense * (math.atan2(v[1], v[0]) + math.pi / 2.0))
        most_under_at = (most_under_at + 180.0) % 360.0 - 180.0
        rows += (
            TimingRow(
                key="loop_thread",
                what=BALANCE["loop_thread"],
                maker=None,
                value=most_under,
                window=Window(0.85 * UNION_SPECIAL_LOOP, 1.15 * UNION_SPECIAL_LOOP),
                unit="mm",
                counts=False,  # one published figure for the stitch type, not this head's maker's setting
            ),
        )
    if tm.stitch is StitchType.CHAIN:
        spread = _carried(tm, hook, pick)
        phases = {}
        if _between(np.array([spread]), drawn, enters)[0]:
            phases["loop spread on the looper"] = (drawn, spread)
        phases["loop held, fabric fed"] = (spread if phases else drawn, enters)
        phases["needle through the held loop"] = (enters, pick)
        phases["next loop taken, held loop cast off and set"] = (pick, drawn)
    else:
        phases = {
            "needle descending": (drawn, enters),
            "needle in the fabric": (enters, pick),
            "loop taken and enlarged around the bobbin": (pick, release),
            "loop cast off, stitch set": (release, drawn),
        }
    return ThreadBalance(
        theta=th,
        path=path / MM,
        supply=supply / MM,
        demand=demand / MM,
        balance=balance / MM,
        phases=phases,
        per_stitch=per_stitch / MM,
        rows=rows,
        hole=at.hole / MM,
        end=at.end / MM,
        under=under / MM,
        past=past / MM,
        blade_turn=np.degrees(turn),
        case_turn=np.degrees(slid),
        most_under=most_under / MM,
        most_under_at=most_under_at,
        below=below / MM,
    )


def _of(x: Any, i: int, b: Batch) -> float:
    """Variant ``i``'s value of a number a study may vary: a (V*A,) row array or a scalar."""
    return float(np.asarray(x).reshape(-1)[i * b.angles]) if np.ndim(x) else float(x)


__all__ = [
    "BALANCE",
    "EYE_STITCHES",
    "GENERAL",
    "LABELS",
    "HeadTiming",
    "StitchEnd",
    "ThreadBalance",
    "TimingChecks",
    "TimingRow",
    "head_timing",
    "measure",
    "stitch_end",
    "thread_balance",
]
